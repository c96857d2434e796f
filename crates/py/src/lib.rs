//! Python bindings of lidarqa (SPEC §9): the per-tile entry points of lidarqa-pipeline, taking
//! paths (never point arrays: a tile stays on disk, as it does for a job array) and releasing
//! the GIL while they run, so a Dask worker's threads, or the Python threads of one process,
//! run tiles in parallel. Results come back as JSON text; the `lidarqa` Python package turns
//! them into dicts.
//!
//! Every function raises `lidarqa.LidarqaError` with lidarqa's one-line message (naming the
//! file, key or value) on failure.

use lidarqa_calib::OverlapOptions;
use lidarqa_io::{ControlPoints, Crs};
use lidarqa_pipeline::{
    CorrectTileJob, Manifest, TargetsTileJob, TileReport, TpuContext, TpuOptions, TpuTileJob,
    collect as collect_manifest, control_for_targets, correct_tile as correct_one,
    evaluate_nva as evaluate_nva_files, evaluate_target_files, extract_targets_tile as targets_one,
    find_targets as find_targets_in, overlap_files, predicted_from_sensor,
    read_calibrated_mounting, run_entry, targets_csv, tpu_tile as tpu_one,
};
use lidarqa_report::predicted_from_tpu_summary;
use lidarqa_targets::{CentreMethod, ControlPoint, EvaluateOptions, TargetConfig};
use lidarqa_tpu::{Biases, GeometryRequest, Preset, Sweep, evaluate, evaluate_sweep};
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use std::path::{Path, PathBuf};

create_exception!(
    _lidarqa,
    LidarqaError,
    PyException,
    "A lidarqa error (one line naming the file, key or value)."
);

fn err(e: impl std::fmt::Display) -> PyErr {
    LidarqaError::new_err(e.to_string())
}

fn json(v: &impl serde::Serialize) -> PyResult<String> {
    serde_json::to_string(v).map_err(err)
}

fn options(
    gps_week: Option<i64>,
    epsg: Option<u32>,
    skip_outside: bool,
    skip_invalid: bool,
) -> PyResult<TpuOptions> {
    Ok(TpuOptions {
        crs: epsg.map(Crs::from_epsg).transpose().map_err(err)?,
        gps_week,
        skip_outside,
        skip_invalid,
        ..TpuOptions::default()
    })
}

/// Per-point TPU of one tile: `input` LAS/LAZ → `output` with σ extra bytes. Returns the tile's
/// summary as JSON (the object `lidarqa tpu --summary` writes, for this one tile).
#[pyfunction]
#[pyo3(signature = (input, output, trajectory, sensor, smrmsg=None, gps_week=None, epsg=None, skip_outside=false, skip_invalid=false))]
#[allow(clippy::too_many_arguments)]
fn tpu_tile(
    py: Python<'_>,
    input: PathBuf,
    output: PathBuf,
    trajectory: PathBuf,
    sensor: PathBuf,
    smrmsg: Option<PathBuf>,
    gps_week: Option<i64>,
    epsg: Option<u32>,
    skip_outside: bool,
    skip_invalid: bool,
) -> PyResult<String> {
    let opts = options(gps_week, epsg, skip_outside, skip_invalid)?;
    py.allow_threads(|| {
        let ctx =
            TpuContext::from_files(&sensor, &trajectory, smrmsg.as_deref(), opts).map_err(err)?;
        let report = tpu_one(&TpuTileJob {
            input: &input,
            output: &output,
            context: &ctx,
            progress: Default::default(),
        })
        .map_err(err)?;
        let (_, survey) = TileReport::merge(&[report]).ok_or_else(|| err("no tile"))?;
        json(&survey)
    })
}

/// Re-georeferences one tile with `calibration` (calibration.json from `lidarqa calibrate`).
/// Returns `{"input", "output", "points"}` as JSON.
#[pyfunction]
#[pyo3(signature = (input, output, trajectory, sensor, calibration, gps_week=None))]
fn correct_tile(
    py: Python<'_>,
    input: PathBuf,
    output: PathBuf,
    trajectory: PathBuf,
    sensor: PathBuf,
    calibration: PathBuf,
    gps_week: Option<i64>,
) -> PyResult<String> {
    py.allow_threads(|| {
        let mounting = read_calibrated_mounting(&calibration).map_err(err)?;
        let ctx = TpuContext::from_files(
            &sensor,
            &trajectory,
            None,
            TpuOptions {
                gps_week,
                ..TpuOptions::default()
            },
        )
        .map_err(err)?;
        let r = correct_one(&CorrectTileJob {
            input: &input,
            output: &output,
            context: &ctx,
            mounting: &mounting,
            other_inputs: &[calibration.as_path()],
            progress: Default::default(),
        })
        .map_err(err)?;
        Ok(
            serde_json::json!({"input": r.input, "output": r.output, "points": r.points})
                .to_string(),
        )
    })
}

/// The control points of a control CSV and the extraction settings of `method` (a
/// [`CentreMethod`] name).
fn targets_setup(
    control: &Path,
    radius_m: Option<f64>,
    method: &str,
) -> PyResult<(Vec<ControlPoint>, TargetConfig)> {
    let method: CentreMethod = method.parse().map_err(|e| err(format!("method: {e}")))?;
    let table = ControlPoints::from_path(control).map_err(err)?;
    let points = control_for_targets(&table, radius_m).map_err(err)?;
    let mut config = TargetConfig::default();
    config.centre.method = method;
    Ok((points, config))
}

/// Target extraction in one tile near the control points of `control` (CSV
/// `id,x,y,z[,sigma_h,sigma_v,radius_m]`); writes the tile's report JSON to `output` and
/// returns it.
#[pyfunction]
#[pyo3(signature = (input, output, control, radius_m=None, method="circle-fit", window_m=6.0))]
fn extract_targets_tile(
    py: Python<'_>,
    input: PathBuf,
    output: PathBuf,
    control: PathBuf,
    radius_m: Option<f64>,
    method: &str,
    window_m: f64,
) -> PyResult<String> {
    py.allow_threads(|| {
        let (points, config) = targets_setup(&control, radius_m, method)?;
        let r = targets_one(&TargetsTileJob {
            input: &input,
            output: &output,
            control: &points,
            config: &config,
            window_m,
            other_inputs: &[control.as_path()],
        })
        .map_err(err)?;
        json(&r)
    })
}

/// Targets in several files (strips or tiles) near the control points of `control` (CSV
/// `id,x,y,z[,sigma_h,sigma_v,radius_m]`), each file searched on its own and the per-file centres
/// merged per control id (what `lidarqa targets` does). Returns the merged report and its
/// warnings as JSON (`{"report": ..., "warnings": [...]}`); with `output`, also writes the targets
/// CSV there (atomically, never over an input), byte for byte what `lidarqa targets -o` writes.
#[pyfunction]
#[pyo3(signature = (inputs, control, radius_m=None, method="circle-fit", window_m=6.0, output=None))]
fn find_targets(
    py: Python<'_>,
    inputs: Vec<PathBuf>,
    control: PathBuf,
    radius_m: Option<f64>,
    method: &str,
    window_m: f64,
    output: Option<PathBuf>,
) -> PyResult<String> {
    py.allow_threads(|| {
        lidarqa_io::check_distinct_inputs(&inputs).map_err(err)?;
        let (points, config) = targets_setup(&control, radius_m, method)?;
        let (report, warnings) =
            find_targets_in(&inputs, &points, &config, window_m).map_err(err)?;
        if let Some(out) = &output {
            let mut read: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
            read.push(&control);
            targets_csv(out, &report)
                .write_path(out, &read)
                .map_err(err)?;
        }
        json(&serde_json::json!({ "report": report, "warnings": warnings }))
    })
}

/// Accuracy of a targets CSV (`lidarqa targets` output) against a control CSV: residuals, RMSE
/// (Zhang et al. 2018, eqs. 7–8), ASPRS and NSSDA, as `lidarqa evaluate --targets … --control …`.
/// The predicted σ comes from `tpu` (a `tpu_summary.json`: its median per-point σ, as `--tpu`), or
/// from `sensor` with `height_m` (the sensor file's budget at that height and `scan_angle_deg`,
/// as `--sensor`). Returns the evaluation as JSON.
#[pyfunction]
#[pyo3(signature = (targets, control, horizontal_class_m=None, vertical_class_m=None, sensor=None, height_m=None, scan_angle_deg=None, tpu=None))]
#[allow(clippy::too_many_arguments)]
fn evaluate_targets(
    py: Python<'_>,
    targets: PathBuf,
    control: PathBuf,
    horizontal_class_m: Option<f64>,
    vertical_class_m: Option<f64>,
    sensor: Option<PathBuf>,
    height_m: Option<f64>,
    scan_angle_deg: Option<f64>,
    tpu: Option<PathBuf>,
) -> PyResult<String> {
    let options = EvaluateOptions {
        horizontal_class_m,
        vertical_class_m,
    };
    py.allow_threads(|| {
        let mut e = evaluate_target_files(&targets, &control, &options).map_err(err)?;
        match (&tpu, &sensor, height_m) {
            (Some(t), None, None) => {
                e.set_predicted(predicted_from_tpu_summary(t).map_err(err)?);
            }
            (None, Some(s), Some(h)) => {
                e.set_predicted(predicted_from_sensor(s, h, scan_angle_deg).map_err(err)?);
            }
            (None, None, None) => {}
            (Some(_), _, _) => {
                return Err(err(
                    "tpu and sensor are two predictions: give one (tpu, or sensor with height_m)",
                ));
            }
            _ => {
                return Err(err(
                    "sensor and height_m go together (the predicted σ needs both)",
                ));
            }
        }
        json(&e)
    })
}

/// Swath-to-swath height differences of overlapping strips (LAS/LAZ, two or more) on smooth
/// cells of `cell_m` (USGS Lidar Base Specification interswath accuracy), as `lidarqa overlap -o`
/// writes them: per strip pair RMSDz, max |dz| and mean dz, the dz grid and a profile. Returns the
/// JSON.
#[pyfunction]
#[pyo3(signature = (strips, cell_m=1.0, max_roughness_m=0.05, max_slope_deg=10.0))]
fn overlap(
    py: Python<'_>,
    strips: Vec<PathBuf>,
    cell_m: f64,
    max_roughness_m: f64,
    max_slope_deg: f64,
) -> PyResult<String> {
    let options = OverlapOptions {
        cell_m,
        max_roughness_m,
        max_slope_deg,
        ..OverlapOptions::default()
    };
    py.allow_threads(|| json(&overlap_files(&strips, &options).map_err(err)?.to_document()))
}

/// Vertical checkpoints (CSV `id,x,y,z[,…]`) against the TIN of the class-`ground_class` points
/// of the `ground` LAS/LAZ files (NVA), as `lidarqa evaluate --ground … --checkpoints …`.
/// Returns the evaluation as JSON.
#[pyfunction]
#[pyo3(signature = (ground, checkpoints, ground_class=2, vertical_class_m=None))]
fn evaluate_nva(
    py: Python<'_>,
    ground: Vec<PathBuf>,
    checkpoints: PathBuf,
    ground_class: u8,
    vertical_class_m: Option<f64>,
) -> PyResult<String> {
    let options = EvaluateOptions {
        horizontal_class_m: None,
        vertical_class_m,
    };
    py.allow_threads(|| {
        json(&evaluate_nva_files(&ground, ground_class, &checkpoints, &options).map_err(err)?)
    })
}

/// The error budget of one geometry (degrees and metres, each optional: what is not given comes
/// from the preset, else level flight heading north at scan angle or azimuth 0), of a `preset`
/// (`zhang2018`, formerly `seed000`; `czmil`) or a `sensor` file; with `sweep` (`NAME=START:STOP:STEP`) the budget at
/// every value; with `bias` (`key=value,…`) the displacement those systematic errors cause. Returns
/// what `lidarqa budget --format json` prints, as JSON.
#[pyfunction]
#[pyo3(signature = (preset=None, sensor=None, heading_deg=None, pitch_deg=None, roll_deg=None, scan_angle_deg=None, range_m=None, height_m=None, azimuth_deg=None, range_air_m=None, range_water_m=None, depth_m=None, sweep=None, bias=None))]
#[allow(clippy::too_many_arguments)]
fn budget(
    preset: Option<&str>,
    sensor: Option<PathBuf>,
    heading_deg: Option<f64>,
    pitch_deg: Option<f64>,
    roll_deg: Option<f64>,
    scan_angle_deg: Option<f64>,
    range_m: Option<f64>,
    height_m: Option<f64>,
    azimuth_deg: Option<f64>,
    range_air_m: Option<f64>,
    range_water_m: Option<f64>,
    depth_m: Option<f64>,
    sweep: Option<&str>,
    bias: Option<&str>,
) -> PyResult<String> {
    let (sensor, preset_geometry) = match (preset, &sensor) {
        (Some(name), None) => {
            let p = Preset::from_name(name).ok_or_else(|| {
                err(format!(
                    "preset: unknown preset '{name}' (one of zhang2018, czmil)"
                ))
            })?;
            (p.sensor(), Some(p.geometry()))
        }
        (None, Some(path)) => (lidarqa_io::read_sensor(path).map_err(err)?, None),
        _ => return Err(err("give one of preset or sensor")),
    };
    let sweep = sweep
        .map(|s| s.parse::<Sweep>().map_err(|e| err(format!("sweep: {e}"))))
        .transpose()?;
    let biases = bias
        .map(|b| b.parse::<Biases>().map_err(|e| err(format!("bias: {e}"))))
        .transpose()?;
    let request = GeometryRequest {
        heading_deg,
        pitch_deg,
        roll_deg,
        scan_angle_deg,
        range_m,
        height_m,
        azimuth_deg,
        range_air_m,
        range_water_m,
        depth_m,
    };
    let geometry = request
        .resolve(&sensor, preset_geometry, sweep.as_ref())
        .map_err(err)?;
    match &sweep {
        Some(s) => json(
            &evaluate_sweep(&sensor, &geometry, s, biases.as_ref())
                .map_err(err)?
                .to_sweep(),
        ),
        None => json(
            &evaluate(&sensor, &geometry, biases.as_ref())
                .map_err(err)?
                .to_budget(),
        ),
    }
}

/// Runs entry `index` of a manifest from `lidarqa plan` (skipped when already complete, unless
/// `force`). Returns `{"index", "skipped", "input", "output", "points_read", "points_written"}`
/// as JSON.
#[pyfunction]
#[pyo3(signature = (manifest, index, force=false))]
fn run_manifest_entry(
    py: Python<'_>,
    manifest: PathBuf,
    index: usize,
    force: bool,
) -> PyResult<String> {
    py.allow_threads(|| {
        let m = Manifest::read(&manifest).map_err(err)?;
        let o = run_entry(&manifest, &m, index, None, force).map_err(err)?;
        Ok(serde_json::json!({
            "index": index,
            "skipped": o.skipped,
            "input": o.report.input,
            "output": o.report.output,
            "points_read": o.report.summary.points_read,
            "points_written": o.report.summary.points_written,
        })
        .to_string())
    })
}

/// Number of entries of a manifest.
#[pyfunction]
fn manifest_len(manifest: PathBuf) -> PyResult<usize> {
    Ok(Manifest::read(&manifest).map_err(err)?.entries.len())
}

/// Merges a manifest's tile reports into the survey summary (as `lidarqa collect`), writing it
/// to `summary` when given (pretty JSON, as `lidarqa collect --summary`), and returns it as JSON.
#[pyfunction]
#[pyo3(signature = (manifest, summary=None))]
fn collect(py: Python<'_>, manifest: PathBuf, summary: Option<PathBuf>) -> PyResult<String> {
    py.allow_threads(|| {
        let m = Manifest::read(&manifest).map_err(err)?;
        let (_, report) = collect_manifest(&manifest, &m).map_err(err)?;
        let text = serde_json::to_string_pretty(&report).map_err(err)? + "\n";
        if let Some(path) = &summary {
            write_atomic(path, &text, &manifest).map_err(err)?;
        }
        Ok(text)
    })
}

fn write_atomic(path: &Path, text: &str, manifest: &Path) -> lidarqa_io::Result<()> {
    use std::io::Write as _;
    let mut f = lidarqa_io::AtomicFile::create(path, &[manifest])?;
    f.write_all(text.as_bytes())
        .map_err(|source| lidarqa_io::Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
    f.commit()
}

/// The native part of the `lidarqa` Python package.
#[pymodule]
fn _lidarqa(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("LidarqaError", m.py().get_type::<LidarqaError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(tpu_tile, m)?)?;
    m.add_function(wrap_pyfunction!(correct_tile, m)?)?;
    m.add_function(wrap_pyfunction!(extract_targets_tile, m)?)?;
    m.add_function(wrap_pyfunction!(find_targets, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate_targets, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate_nva, m)?)?;
    m.add_function(wrap_pyfunction!(overlap, m)?)?;
    m.add_function(wrap_pyfunction!(budget, m)?)?;
    m.add_function(wrap_pyfunction!(run_manifest_entry, m)?)?;
    m.add_function(wrap_pyfunction!(manifest_len, m)?)?;
    m.add_function(wrap_pyfunction!(collect, m)?)?;
    Ok(())
}
