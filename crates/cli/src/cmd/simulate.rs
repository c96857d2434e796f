//! `lidarqa simulate`: write a simulated survey with known truth.
//!
//! Parses the flags, builds the checked scenario, runs lidarqa-sim and writes its structs with
//! lidarqa-io: one LAS/LAZ per strip, `sbet.out` + `smrmsg.out`, `control.csv`, `truth.json` and
//! the nominal `sensor.toml` the user of the survey would have. Every file is atomic.

use anyhow::Context;
use lidarqa_io::{
    AtomicFile, LasTimeBase, LasWriteOptions, LasWriter, RawVlr, SbetPose, SmrmsgSigma, UtmDatum,
    UtmZone, sbet_raw, write_records_to_path,
};
use lidarqa_sim::{Scenario, SimOptions, Survey, builtin_toml, simulate_with_progress};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Example shown after `lidarqa simulate --help`.
pub const AFTER_HELP: &str = "\
Examples:
  lidarqa simulate --scenario demo -o sim/
  lidarqa simulate --scenario calibration --print > my-survey.toml
  lidarqa simulate --scenario my-survey.toml --seed 7 --format las -o sim7/
  lidarqa simulate --scenario bathymetry --truth -o bathy/   # + each point's actual error

Built-in scenarios: demo, calibration, bathymetry.

Files of the same name in the output directory are replaced; an output that is an input
(--scenario) is refused.";

/// Point-cloud output format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum CloudFormat {
    /// Compressed LAZ.
    Laz,
    /// Uncompressed LAS 1.4.
    Las,
}

/// Flags of `lidarqa simulate`.
#[derive(Debug, clap::Args)]
pub struct SimulateArgs {
    /// Built-in scenario (demo, calibration, bathymetry) or a scenario TOML file.
    #[arg(long, value_name = "NAME|FILE", default_value = "demo")]
    pub scenario: String,
    /// Print the scenario as TOML (a starting point for your own) and exit.
    #[arg(long)]
    pub print: bool,
    /// Output directory (created if missing).
    #[arg(
        short = 'o',
        long = "output",
        value_name = "DIR",
        default_value = "lidarqa-sim"
    )]
    pub output: PathBuf,
    /// Seed of every random draw (overrides the scenario's).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Point-cloud format of the strips.
    #[arg(long, value_enum, default_value_t = CloudFormat::Laz)]
    pub format: CloudFormat,
    /// Also write each point's actual error, lidar − true, as extra bytes `error_x`, `error_y`,
    /// `error_z` (f32 metres along the projected x, y and up axes, of the coordinates as stored),
    /// so any TPU can be scored against the truth point by point.
    #[arg(long)]
    pub truth: bool,
}

/// Reads the scenario named by `--scenario` (built-in name first, then a file), with the seed
/// override; also returns its text for `--print`.
fn load(args: &SimulateArgs) -> anyhow::Result<(Scenario, String)> {
    let (text, origin) = match builtin_toml(&args.scenario) {
        Some(t) => (
            t.to_string(),
            format!("built-in scenario {}", args.scenario),
        ),
        None => {
            let path = Path::new(&args.scenario);
            let text = std::fs::read_to_string(path).with_context(|| {
                format!(
                    "{}: not a built-in scenario (demo, calibration, bathymetry) and not a readable file",
                    path.display()
                )
            })?;
            (text, path.display().to_string())
        }
    };
    let mut scenario = Scenario::from_toml_str(&text).with_context(|| origin.clone())?;
    if let Some(seed) = args.seed {
        scenario = scenario.with_seed(seed);
    }
    // A built-in without overrides prints with its comments; anything else as re-serialised.
    let printable = if args.seed.is_none() {
        text
    } else {
        scenario.to_toml_string()
    };
    Ok((scenario, printable))
}

/// Run `lidarqa simulate`.
///
/// # Errors
/// A one-line message naming the scenario key or the output file at fault.
pub fn run(args: &SimulateArgs) -> anyhow::Result<()> {
    let (scenario, text) = load(args)?;
    if args.print {
        let mut out = std::io::stdout().lock();
        out.write_all(text.as_bytes())?;
        return out.flush().map_err(Into::into);
    }
    let dir = &args.output;
    std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create", dir.display()))?;

    let bar = crate::progress::bar("simulating", scenario.pulse_count(), "pulses");
    let options = SimOptions {
        keep_truth: args.truth,
        ..SimOptions::default()
    };
    let survey = simulate_with_progress(&scenario, &options, &|n| bar.inc(n))
        .with_context(|| format!("scenario {}", scenario.name()))?;
    bar.finish_and_clear();

    let ext = match args.format {
        CloudFormat::Laz => "laz",
        CloudFormat::Las => "las",
    };
    // SPEC §7: an output equal to an input (a scenario file kept in the output directory under
    // an output's name) is refused before anything is written.
    if builtin_toml(&args.scenario).is_none() {
        let fixed = [
            "sbet.out",
            "smrmsg.out",
            "control.csv",
            "truth.json",
            "sensor.toml",
        ];
        let strips = survey
            .strips
            .iter()
            .map(|s| format!("strip_{:03}.{ext}", s.id));
        for name in fixed.into_iter().map(String::from).chain(strips) {
            lidarqa_io::check_not_an_input(dir.join(name), &[Path::new(&args.scenario)])?;
        }
    }
    for strip in &survey.strips {
        let path = dir.join(format!("strip_{:03}.{ext}", strip.id));
        write_strip(&path, &scenario, &survey, strip)?;
    }
    write_trajectory(dir, &survey)?;
    write_control(&dir.join("control.csv"), &survey)?;
    let truth = serde_json::to_string_pretty(&survey.truth)?;
    write_text(&dir.join("truth.json"), &(truth + "\n"))?;
    write_text(
        &dir.join("sensor.toml"),
        &lidarqa_io::sensor_to_toml(scenario.sensor()),
    )?;
    println!(
        "wrote {} points in {} strips ({} pulses), sbet.out, smrmsg.out, control.csv ({} targets), truth.json and sensor.toml to {}",
        survey.point_count(),
        survey.strips.len(),
        scenario.pulse_count(),
        survey.control.len(),
        dir.display()
    );
    Ok(())
}

fn write_text(path: &Path, text: &str) -> anyhow::Result<()> {
    let mut file = AtomicFile::create(path, &[] as &[&Path])?;
    file.write_all(text.as_bytes())
        .with_context(|| format!("{}: write failed", path.display()))?;
    file.commit()?;
    Ok(())
}

/// WKT1 of the scenario's UTM CRS, so the LAS carries it (LAS 1.4 point format 6 requires WKT).
fn utm_wkt(zone: &UtmZone, epsg: u32) -> String {
    let (geogcs, datum, spheroid, a_inv_f, sph_code, datum_code, geog_code) = match zone.datum() {
        UtmDatum::Nad83 => (
            "NAD83",
            "North_American_Datum_1983",
            "GRS 1980",
            "298.257222101",
            7019,
            6269,
            4269,
        ),
        _ => (
            "WGS 84",
            "WGS_1984",
            "WGS 84",
            "298.257223563",
            7030,
            6326,
            4326,
        ),
    };
    let hemisphere = match zone.hemisphere() {
        lidarqa_io::Hemisphere::North => ("N", 0),
        lidarqa_io::Hemisphere::South => ("S", 10_000_000),
    };
    format!(
        "PROJCS[\"{geogcs} / UTM zone {z}{h}\",GEOGCS[\"{geogcs}\",DATUM[\"{datum}\",SPHEROID[\"{spheroid}\",6378137,{a_inv_f},AUTHORITY[\"EPSG\",\"{sph_code}\"]],AUTHORITY[\"EPSG\",\"{datum_code}\"]],PRIMEM[\"Greenwich\",0,AUTHORITY[\"EPSG\",\"8901\"]],UNIT[\"degree\",0.0174532925199433,AUTHORITY[\"EPSG\",\"9122\"]],AUTHORITY[\"EPSG\",\"{geog_code}\"]],PROJECTION[\"Transverse_Mercator\"],PARAMETER[\"latitude_of_origin\",0],PARAMETER[\"central_meridian\",{cm}],PARAMETER[\"scale_factor\",0.9996],PARAMETER[\"false_easting\",500000],PARAMETER[\"false_northing\",{fn_}],UNIT[\"metre\",1,AUTHORITY[\"EPSG\",\"9001\"]],AXIS[\"Easting\",EAST],AXIS[\"Northing\",NORTH],AUTHORITY[\"EPSG\",\"{epsg}\"]]",
        z = zone.zone(),
        h = hemisphere.0,
        cm = zone.central_meridian_rad().to_degrees().round(),
        fn_ = hemisphere.1,
    )
}

fn write_strip(
    path: &Path,
    scenario: &Scenario,
    survey: &Survey,
    strip: &lidarqa_sim::Strip,
) -> anyhow::Result<()> {
    let [e0, n0] = scenario.origin_m();
    let mut wkt = utm_wkt(scenario.zone(), scenario.epsg()).into_bytes();
    wkt.push(0);
    let options = LasWriteOptions {
        version_minor: 4,
        point_format: 6,
        scale: [0.001; 3],
        offset: [e0.round(), n0.round(), 0.0],
        time_base: LasTimeBase::AdjustedStandard,
        crs_vlrs: vec![RawVlr {
            user_id: "LASF_Projection".into(),
            record_id: 2112,
            description: "OGC WKT".into(),
            data: wkt,
        }],
        extra_dims: if strip.truth.is_empty() {
            Vec::new()
        } else {
            TRUTH_DIMS
                .iter()
                .map(|(n, d)| (n.to_string(), d.to_string()))
                .collect()
        },
        file_source_id: strip.id,
        extra_dims_f64: Vec::new(),
    };
    let scale = options.scale;
    let offset = options.offset;
    // The error of the coordinates as stored: the LAS record rounds them to its scale.
    let stored = |v: f64, k: usize| ((v - offset[k]) / scale[k]).round() * scale[k] + offset[k];
    let mut w = LasWriter::create(path, &options, &[] as &[&Path])?;
    for (i, p) in strip.points.iter().enumerate() {
        let point = survey.las_point(p);
        match strip.truth.get(i) {
            Some(t) => {
                let error = [
                    (stored(point.x, 0) - t.easting_m) as f32,
                    (stored(point.y, 1) - t.northing_m) as f32,
                    (stored(point.z, 2) - t.height_m) as f32,
                ];
                w.write_point(&point, &error)?;
            }
            None => w.write_point(&point, &[])?,
        }
    }
    w.finish()?;
    Ok(())
}

/// The `--truth` extra-bytes dimensions: name and description (each ≤ 32 bytes).
const TRUTH_DIMS: [(&str, &str); 3] = [
    ("error_x", "lidar - true, projected x (m)"),
    ("error_y", "lidar - true, projected y (m)"),
    ("error_z", "lidar - true, height (m)"),
];

fn write_trajectory(dir: &Path, survey: &Survey) -> anyhow::Result<()> {
    let sbet: Vec<sbet_raw::SbetRecord> = survey
        .trajectory()
        .iter()
        .map(|r| {
            sbet_raw::SbetRecord::from(SbetPose {
                time_s: r.time_s,
                latitude_rad: r.latitude_rad,
                longitude_rad: r.longitude_rad,
                height_m: r.height_m,
                // Wander angle 0: the wander frame is north-east-down.
                velocity_wander_mps: [
                    r.velocity_north_m_per_s,
                    r.velocity_east_m_per_s,
                    r.velocity_down_m_per_s,
                ],
                roll_rad: r.roll_rad,
                pitch_rad: r.pitch_rad,
                platform_heading_rad: r.heading_rad,
                wander_angle_rad: 0.0,
                specific_force_body_mps2: [0.0; 3],
                angular_rate_body_radps: [0.0; 3],
            })
        })
        .collect();
    write_records_to_path(dir.join("sbet.out"), &sbet, &[] as &[&Path])?;
    let smrmsg: Vec<sbet_raw::SmrmsgRecord> = survey
        .trajectory_sigma()
        .iter()
        .map(|s| {
            sbet_raw::SmrmsgRecord::from(SmrmsgSigma {
                time_s: s.time_s,
                sigma_north_m: s.position_ned_m[0],
                sigma_east_m: s.position_ned_m[1],
                sigma_down_m: s.position_ned_m[2],
                sigma_velocity_north_mps: s.velocity_ned_m_per_s[0],
                sigma_velocity_east_mps: s.velocity_ned_m_per_s[1],
                sigma_velocity_down_mps: s.velocity_ned_m_per_s[2],
                sigma_roll_rad: s.attitude_rad[0],
                sigma_pitch_rad: s.attitude_rad[1],
                sigma_heading_rad: s.attitude_rad[2],
            })
        })
        .collect();
    write_records_to_path(dir.join("smrmsg.out"), &smrmsg, &[] as &[&Path])?;
    Ok(())
}

/// `control.csv`: `id,x,y,z,sigma_h,sigma_v,radius_m` (SPEC §7 plus the target radius, which
/// `lidarqa targets` reads per target).
fn write_control(path: &Path, survey: &Survey) -> anyhow::Result<()> {
    let mut text = String::from("id,x,y,z,sigma_h,sigma_v,radius_m\n");
    for c in &survey.control {
        text.push_str(&format!(
            "{},{:.4},{:.4},{:.4},{},{},{}\n",
            c.id,
            c.easting_m,
            c.northing_m,
            c.height_m,
            c.sigma_horizontal_m,
            c.sigma_vertical_m,
            c.radius_m
        ));
    }
    write_text(path, &text)
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Debug, Parser)]
    struct Cli {
        #[command(flatten)]
        args: SimulateArgs,
    }

    #[test]
    fn flags_parse() {
        let cli = Cli::try_parse_from([
            "simulate",
            "--scenario",
            "calibration",
            "-o",
            "out",
            "--seed",
            "9",
            "--format",
            "las",
        ])
        .unwrap();
        assert_eq!(cli.args.scenario, "calibration");
        assert_eq!(cli.args.output, PathBuf::from("out"));
        assert_eq!(cli.args.seed, Some(9));
        assert_eq!(cli.args.format, CloudFormat::Las);
        assert!(!cli.args.print);
        assert!(Cli::try_parse_from(["simulate", "--format", "ply"]).is_err());
    }

    #[test]
    fn wkt_names_the_epsg_code() {
        let zone = UtmZone::from_epsg(32649).unwrap();
        let wkt = utm_wkt(&zone, 32649);
        assert_eq!(lidarqa_io::epsg_from_wkt(&wkt), Some(32649));
        assert!(wkt.contains("PARAMETER[\"central_meridian\",111]"));
    }
}
