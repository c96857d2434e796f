//! `lidarqa tpu FILE.csd`: Optech CSD raw sensor records georeferenced with their σ, no
//! trajectory (the records carry the pose). The work is lidarqa-pipeline's `tpu_csd`; this
//! module checks the flags that apply, runs it and prints the summary.

use crate::format::{OutputFormat, print_json, print_text, print_warnings, write_json_file};
use anyhow::{Result, bail};
use clap::ValueEnum;
use lidarqa_io::Crs;
use lidarqa_pipeline::{CsdMounting, CsdTpuJob, CsdTpuReport, tpu_csd};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// `--mounting`: which boresight georeferences raw sensor records.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Default)]
pub enum MountingFlag {
    /// The CSD header's misalignment angles + IMU offsets (as the file's own software and PDAL).
    #[default]
    CsdHeader,
    /// The sensor file's [mounting] (an override on purpose, e.g. a new calibration).
    SensorFile,
}

/// What a CSD run needs from `lidarqa tpu`'s flags.
pub struct CsdRun<'a> {
    pub input: &'a Path,
    pub output: &'a Path,
    pub sensor: &'a Path,
    pub crs: Option<Crs>,
    pub mounting: MountingFlag,
    pub summary: Option<&'a PathBuf>,
    pub format: OutputFormat,
}

/// Runs `lidarqa tpu` on a CSD file.
pub fn run(r: CsdRun<'_>) -> Result<()> {
    let Some(crs) = r.crs else {
        bail!(
            "{}: Optech CSD positions are geodetic (WGS 84); give the output's UTM CRS with \
             --epsg (e.g. 32617) or --utm-zone",
            r.input.display()
        );
    };
    if r.output.is_dir() {
        bail!(
            "{}: the input is a file, so the output must be a file, not a directory",
            r.output.display()
        );
    }
    // The one output guard, before any work: the LAS and the summary against both inputs and
    // each other.
    let mut outputs = vec![r.output];
    outputs.extend(r.summary.map(PathBuf::as_path));
    lidarqa_io::check_outputs(&outputs, &[r.input, r.sensor])?;
    let sensor = lidarqa_io::read_sensor(r.sensor)?;
    let report = tpu_csd(&CsdTpuJob {
        input: r.input,
        output: r.output,
        sensor: &sensor,
        sensor_path: r.sensor,
        crs: &crs,
        mounting: match r.mounting {
            MountingFlag::CsdHeader => CsdMounting::CsdHeader,
            MountingFlag::SensorFile => CsdMounting::SensorFile,
        },
    })?;
    print_warnings(&report.warnings);
    if let Some(path) = r.summary {
        write_json_file(path, &report, &[r.input, r.sensor])?;
    }
    match r.format {
        OutputFormat::Json => print_json(&report),
        OutputFormat::Table => print_text(&table(&report)),
    }
}

/// The summary as text: what was read, the mounting, the σ in cm.
fn table(r: &CsdTpuReport) -> String {
    let mut s = String::new();
    let h = &r.header;
    let _ = writeln!(
        s,
        "{} read as Optech CSD ({} {} v{:.3}, GPS week {}): {} pulses, {} without a return",
        r.input.display(),
        h.vendor,
        h.software,
        h.format_version,
        h.gps_week,
        r.pulses,
        r.pulses_without_return
    );
    let m = &r.mounting;
    let _ = writeln!(
        s,
        "mounting from {}: boresight roll {:.5}°, pitch {:.5}°, yaw {:.5}°; lever arm {:?} m",
        m.source.replace('_', " "),
        m.boresight_deg[0],
        m.boresight_deg[1],
        m.boresight_deg[2],
        m.lever_arm_m
    );
    let _ = writeln!(
        s,
        "{} points written to {} ({})",
        r.points_written,
        r.output.display(),
        r.crs
    );
    let _ = writeln!(
        s,
        "{:<18} {:>9} {:>9} {:>9} {:>9}",
        "sigma (cm)", "min", "median", "p95", "max"
    );
    let ordered = lidarqa_pipeline::SIGMA_NAMES[..5]
        .iter()
        .filter_map(|n| r.sigma.get_key_value(n));
    for (name, st) in ordered {
        let _ = writeln!(
            s,
            "{:<18} {:>9.2} {:>9.2} {:>9.2} {:>9.2}",
            name,
            st.min * 100.0,
            st.median * 100.0,
            st.p95 * 100.0,
            st.max * 100.0
        );
    }
    s
}
