//! Hostile input, round two: the bad cases of a 724-case hostile run, each as a regression test
//! run on the real binary with inputs made here. Every refusal is exit 1 with one line naming the
//! file, key or flag and the likely cause; after every case the inputs and the unrelated files
//! around them are byte-identical (BLAKE3 of every file under the test's directory).
//!
//! One small survey (the demo scenario at 2 kHz: 14 strips of ~18 000 points) is simulated once
//! and copied into each test's own directory.

use crate::binary;

use binary::{fails_with, lidarqa, s, snapshot};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The shared simulated survey (read-only; tests copy what they use).
fn survey() -> &'static Path {
    static SURVEY: OnceLock<tempfile::TempDir> = OnceLock::new();
    SURVEY
        .get_or_init(|| {
            let dir = tempfile::tempdir().unwrap();
            let demo = binary::stdout_ok(&["simulate", "--scenario", "demo", "--print"]);
            let small = demo.replacen("pulse_rate_hz = 50000.0", "pulse_rate_hz = 2000.0", 1);
            assert_ne!(small, demo, "the demo scenario's pulse rate line moved");
            let toml = dir.path().join("small.toml");
            std::fs::write(&toml, small).unwrap();
            let sim = dir.path().join("sim");
            binary::run_ok(&[
                "simulate",
                "--scenario",
                s(&toml),
                "--format",
                "las",
                "-o",
                s(&sim),
            ]);
            dir
        })
        .path()
}

/// A test directory with copies of the survey's `files` (strip_001.las, sbet.out, …).
fn workspace(files: &[&str]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for f in files {
        std::fs::copy(survey().join("sim").join(f), dir.path().join(f)).unwrap();
    }
    dir
}

/// `lidarqa ARGS` refused with every needle, and nothing under `dir` changed.
fn refused_untouched(dir: &Path, args: &[&str], needles: &[&str]) -> String {
    let before = snapshot(dir);
    let err = fails_with(&lidarqa(args), needles);
    assert_eq!(snapshot(dir), before, "lidarqa {args:?} changed files");
    err
}

fn p(dir: &tempfile::TempDir, name: &str) -> PathBuf {
    dir.path().join(name)
}

fn tpu_args<'a>(input: &'a Path, dir: &'a Path, out: &'a Path, sensor: &'a Path) -> Vec<&'a str> {
    vec![
        "tpu",
        s(input),
        "--trajectory",
        leak(dir.join("sbet.out")),
        "--sensor",
        s(sensor),
        "-o",
        s(out),
    ]
}

fn leak(p: PathBuf) -> &'static str {
    Box::leak(p.to_str().unwrap().to_owned().into_boxed_str())
}

/// Bad case 1: `collect --summary` onto the manifest's own inputs.
#[test]
fn collect_never_writes_its_summary_over_the_manifests_inputs() {
    let w = workspace(&[
        "strip_001.las",
        "strip_002.las",
        "sbet.out",
        "smrmsg.out",
        "sensor.toml",
    ]);
    let tiles = p(&w, "tiles");
    std::fs::create_dir(&tiles).unwrap();
    std::fs::rename(p(&w, "strip_001.las"), tiles.join("t1.las")).unwrap();
    std::fs::rename(p(&w, "strip_002.las"), tiles.join("t2.las")).unwrap();
    let manifest = p(&w, "manifest.json");
    binary::run_ok(&[
        "plan",
        "tpu",
        "--tiles",
        s(&tiles),
        "--trajectory",
        s(&p(&w, "sbet.out")),
        "--smrmsg",
        s(&p(&w, "smrmsg.out")),
        "--sensor",
        s(&p(&w, "sensor.toml")),
        "--output-dir",
        s(&p(&w, "tpu")),
        "-o",
        s(&manifest),
    ]);
    for victim in [
        "sensor.toml",
        "sbet.out",
        "smrmsg.out",
        "tiles/t1.las",
        "manifest.json",
    ] {
        let target = p(&w, victim);
        refused_untouched(
            w.path(),
            &["collect", s(&manifest), "--summary", s(&target)],
            &["refusing to overwrite the input file"],
        );
    }
}

/// Bad case 1: `run` on a hand-edited manifest whose output goes through `lnk -> ..`.
#[test]
fn run_refuses_an_output_that_a_symbolic_link_takes_out_of_the_manifests_directory() {
    let outer = tempfile::tempdir().unwrap();
    let survey_dir = outer.path().join("survey");
    std::fs::create_dir(&survey_dir).unwrap();
    let other = outer.path().join("other_strip.las");
    std::fs::copy(survey().join("sim/strip_003.las"), &other).unwrap();
    for f in ["strip_001.las", "sbet.out", "sensor.toml"] {
        std::fs::copy(survey().join("sim").join(f), survey_dir.join(f)).unwrap();
    }
    let tiles = survey_dir.join("tiles");
    std::fs::create_dir(&tiles).unwrap();
    std::fs::rename(survey_dir.join("strip_001.las"), tiles.join("t1.las")).unwrap();
    let manifest = survey_dir.join("manifest.json");
    binary::run_ok(&[
        "plan",
        "tpu",
        "--tiles",
        s(&tiles),
        "--trajectory",
        s(&survey_dir.join("sbet.out")),
        "--sensor",
        s(&survey_dir.join("sensor.toml")),
        "--output-dir",
        s(&survey_dir.join("tpu")),
        "-o",
        s(&manifest),
    ]);
    std::os::unix::fs::symlink("..", survey_dir.join("lnk")).unwrap();
    let mut doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&manifest).unwrap()).unwrap();
    doc["entries"][0]["output"] = serde_json::json!("lnk/other_strip.las");
    std::fs::write(&manifest, serde_json::to_string_pretty(&doc).unwrap()).unwrap();
    refused_untouched(
        outer.path(),
        &["run", s(&manifest), "--index", "0"],
        &[
            "lnk/other_strip.las",
            "symbolic link",
            "outside the manifest's directory",
        ],
    );
}

/// Bad case 1: `tile --overwrite` removes only the tiles it wrote, never a user's strip named
/// like one; a full run leaves its record and no staging directory.
#[test]
fn tile_overwrite_replaces_only_what_tile_wrote() {
    let w = workspace(&["strip_001.las", "strip_002.las"]);
    let out = p(&w, "tiles");
    let strips = [p(&w, "strip_001.las"), p(&w, "strip_002.las")];
    let args = |grid: &'static str, overwrite: bool| {
        let mut v = vec!["tile".to_string()];
        v.extend(strips.iter().map(|x| s(x).to_string()));
        v.extend(["--grid".into(), grid.into(), "-o".into(), s(&out).into()]);
        if overwrite {
            v.push("--overwrite".into());
        }
        v
    };
    let run = |v: &[String]| lidarqa(&v.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(run(&args("3x3", false)).status.success());
    assert!(out.join(".lidarqa-tiles.json").is_file());
    let hidden: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(".lidarqa-tile."))
        .collect();
    assert!(hidden.is_empty(), "staging left behind: {hidden:?}");
    // The user's strip under a tile's name: refused, kept byte for byte.
    std::fs::copy(&strips[0], out.join("tile_9_9.laz")).unwrap();
    let v = args("2x2", true);
    refused_untouched(
        w.path(),
        &v.iter().map(String::as_str).collect::<Vec<_>>(),
        &["tile_9_9.laz", "not a tile `lidarqa tile` wrote there"],
    );
    // A tile edited since it was written is no longer the tool's either.
    std::fs::remove_file(out.join("tile_9_9.laz")).unwrap();
    assert!(run(&args("2x2", true)).status.success());
    let mut f = std::fs::OpenOptions::new()
        .append(true)
        .open(out.join("tile_0_0.laz"))
        .unwrap();
    std::io::Write::write_all(&mut f, b"x").unwrap();
    drop(f);
    refused_untouched(
        w.path(),
        &args("2x2", true)
            .iter()
            .map(String::as_str)
            .collect::<Vec<_>>(),
        &["tile_0_0.laz", "changed since"],
    );
}

/// Bad case 3: a grid inside the flag's bound but of more tiles than one run writes.
#[test]
fn tile_refuses_a_grid_of_too_many_tiles_before_writing_any() {
    let w = workspace(&["strip_001.las", "strip_002.las"]);
    let out = p(&w, "g");
    refused_untouched(
        w.path(),
        &[
            "tile",
            s(&p(&w, "strip_001.las")),
            s(&p(&w, "strip_002.las")),
            "--grid",
            "1000x1000",
            "-o",
            s(&out),
        ],
        &["grid 1000x1000", "non-empty tiles", "choose a coarser grid"],
    );
    assert!(!out.exists());
}

/// Bad case 2: a product destroyed by its own command (`--summary` = `-o`, or a tile output).
#[test]
fn tpu_refuses_a_summary_onto_its_own_output_before_any_work() {
    let w = workspace(&["strip_001.las", "sbet.out", "sensor.toml"]);
    let x = p(&w, "x.las");
    let mut args = tpu_args(&p(&w, "strip_001.las"), w.path(), &x, &p(&w, "sensor.toml"))
        .into_iter()
        .map(str::to_string)
        .collect::<Vec<_>>();
    args.extend(["--summary".into(), s(&x).into()]);
    refused_untouched(
        w.path(),
        &args.iter().map(String::as_str).collect::<Vec<_>>(),
        &["x.las", "one output would overwrite the other"],
    );
    assert!(!x.exists());
    let tiles = p(&w, "tiles");
    std::fs::create_dir(&tiles).unwrap();
    std::fs::copy(p(&w, "strip_001.las"), tiles.join("tile_0_0.las")).unwrap();
    let out = p(&w, "out");
    let summary = out.join("tile_0_0.las");
    let mut args = tpu_args(&tiles, w.path(), &out, &p(&w, "sensor.toml"))
        .into_iter()
        .map(str::to_string)
        .collect::<Vec<_>>();
    args.extend(["--summary".into(), s(&summary).into()]);
    refused_untouched(
        w.path(),
        &args.iter().map(String::as_str).collect::<Vec<_>>(),
        &["tile_0_0.las", "one output would overwrite the other"],
    );
    assert!(
        !out.exists(),
        "the output directory was created before the refusal"
    );
}

/// Writes `strip` with `n` records' X, Y, Z replaced by far-off values (corrupted records).
pub(crate) fn corrupt_records(strip: &Path, n: usize) {
    let mut bytes = std::fs::read(strip).unwrap();
    let offset = u32::from_le_bytes(bytes[96..100].try_into().unwrap()) as usize;
    let len = u16::from_le_bytes(bytes[105..107].try_into().unwrap()) as usize;
    let count = (bytes.len() - offset) / len;
    for k in 0..n {
        let at = offset + (k * count / n) * len;
        for (i, v) in [2_000_000_000i32, -2_000_000_000, 1_900_000_000]
            .iter()
            .enumerate()
        {
            let v = v - (k as i32) * 1000;
            bytes[at + 4 * i..at + 4 * i + 4].copy_from_slice(&v.to_le_bytes());
        }
    }
    std::fs::write(strip, bytes).unwrap();
}

/// Bad case 3: `overlap` on strips with 100 corrupted XYZ records each sized its grid by them
/// (hundreds of terabytes, an abort): now the robust extent, the same pair statistics.
#[test]
fn overlap_with_corrupted_records_is_sized_by_the_robust_extent() {
    let w = workspace(&["strip_001.las", "strip_002.las"]);
    // The written product holds the dz grid (stdout's JSON only the pairs).
    let product = |name: &str| -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(p(&w, name)).unwrap()).unwrap()
    };
    let clean_json = p(&w, "clean_overlap.json");
    binary::run_ok(&[
        "overlap",
        s(&p(&w, "strip_001.las")),
        s(&p(&w, "strip_002.las")),
        "--cell-m",
        "5",
        "-o",
        s(&clean_json),
    ]);
    let clean = product("clean_overlap.json");
    for f in ["strip_001.las", "strip_002.las"] {
        let bad = p(&w, &format!("bad_{f}"));
        std::fs::copy(p(&w, f), &bad).unwrap();
        corrupt_records(&bad, 100);
    }
    let bad_json = p(&w, "bad_overlap.json");
    let out = lidarqa(&[
        "overlap",
        s(&p(&w, "bad_strip_001.las")),
        s(&p(&w, "bad_strip_002.las")),
        "--cell-m",
        "5",
        "-o",
        s(&bad_json),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let bad = product("bad_overlap.json");
    for name in ["clean_overlap.json", "bad_overlap.json"] {
        crate::assert_round_trips::<lidarqa_products::OverlapDocument>(&p(&w, name));
    }
    let rms = |v: &serde_json::Value| v["pairs"][0]["rmsdz_m"].as_f64().unwrap();
    // 100 of 18 181 points gone from the comparison: the RMS moves by millimetres at most.
    assert!(
        (rms(&bad) - rms(&clean)).abs() < 0.02,
        "{} vs {}",
        rms(&bad),
        rms(&clean)
    );
    let cells = |v: &serde_json::Value| {
        v["grid"]["nx"].as_u64().unwrap() * v["grid"]["ny"].as_u64().unwrap()
    };
    // Sized by the outliers the grid would hold ~10¹² cells; the robust extent (1–99 % quantiles
    // and their padding) keeps it within a few times the clean strips' grid.
    assert!(
        cells(&bad) <= 4 * cells(&clean),
        "{} vs {}",
        cells(&bad),
        cells(&clean)
    );
}

/// Bad case 3: `RAYON_NUM_THREADS=5000` panicked; now bounded with a warning.
#[test]
fn thousands_of_threads_requested_are_bounded_with_a_warning() {
    let w = workspace(&["strip_001.las", "sbet.out", "sensor.toml"]);
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_lidarqa"))
        .args(tpu_args(
            &p(&w, "strip_001.las"),
            w.path(),
            &p(&w, "out.las"),
            &p(&w, "sensor.toml"),
        ))
        .env("RAYON_NUM_THREADS", "5000")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("RAYON_NUM_THREADS=5000 is more than"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

/// Bad cases 4 and 6: sensor-file values outside physical ranges, refused per key with the
/// likely unit slip, by `tpu` and `correct` alike.
#[test]
fn sensor_values_outside_physical_ranges_are_refused_per_key() {
    let w = workspace(&["strip_001.las", "sbet.out", "sensor.toml"]);
    let text = std::fs::read_to_string(p(&w, "sensor.toml")).unwrap();
    let set = |key: &str, value: &str| -> String {
        let line = text
            .lines()
            .find(|l| l.split('=').next().is_some_and(|k| k.trim() == key))
            .unwrap_or_else(|| panic!("{key} not in the simulated sensor file"));
        text.replacen(line, &format!("{key} = {value}"), 1)
    };
    let cases: Vec<(String, Vec<&str>)> = vec![
        (
            set("gnss_up_m", "5000"),
            vec![
                "sigma.gnss_up_m",
                "centimetres or millimetres read as metres",
            ],
        ),
        (
            set("range_m", "1e30"),
            vec!["sigma.range_m", "millimetres read as metres"],
        ),
        (
            set("lever_arm_m", "[500.0, 0.0, 0.0]"),
            vec![
                "mounting.lever_arm_m",
                "500.000 m",
                "millimetres or centimetres",
            ],
        ),
        (
            set("lever_arm_m", "[0.1, 0.2, 0.3, 0.4]"),
            vec!["lever_arm_m must have exactly three numbers", "got 4"],
        ),
        (
            set("boresight_roll_deg", "180.0"),
            vec!["mounting.boresight_roll_deg", "180°", "not a misalignment"],
        ),
        (
            text.replacen("[scanner]", "[scanner]\nbeam_divergence_mrad = 500", 1),
            vec![
                "scanner.beam_divergence_mrad",
                "microradians read as milliradians",
            ],
        ),
    ];
    for (k, (sensor, needles)) in cases.iter().enumerate() {
        let bad = p(&w, &format!("bad{k}.toml"));
        std::fs::write(&bad, sensor).unwrap();
        let out = p(&w, "out.las");
        refused_untouched(
            w.path(),
            &tpu_args(&p(&w, "strip_001.las"), w.path(), &out, &bad),
            needles,
        );
        // correct reads the same sensor file through the same check.
        let cal = p(&w, "cal.json");
        std::fs::write(
            &cal,
            r#"{"parameters": {"lever_x_m": 0.0, "lever_y_m": 0.0, "lever_z_m": 0.0,
                "boresight_roll_deg": 0.0, "boresight_pitch_deg": 0.0, "boresight_yaw_deg": 0.0}}"#,
        )
        .unwrap();
        let corrected = p(&w, "corrected");
        refused_untouched(
            w.path(),
            &binary::with_calibration(
                "correct",
                &p(&w, "strip_001.las"),
                [&p(&w, "sbet.out"), &bad, &cal],
                &corrected,
            ),
            needles,
        );
        std::fs::remove_file(&cal).unwrap();
    }
    // A conic sensor's water refractive index of 13.3 (1.33 with a slipped decimal point).
    let conic = "[scanner]\ntype = \"conic\"\nn_water = 13.3\n";
    let bad = p(&w, "conic.toml");
    std::fs::write(&bad, conic).unwrap();
    refused_untouched(
        w.path(),
        &tpu_args(&p(&w, "strip_001.las"), w.path(), &p(&w, "out.las"), &bad),
        &["scanner.n_water", "13.3", "misplaced decimal point"],
    );
}

/// Bad cases 4 and 6: a hand-edited calibration with a 500 m lever arm, a 180° boresight or a
/// σ of 1e6 m: `correct` and `tpu --calibration` refuse it, naming the key.
#[test]
fn calibration_values_outside_physical_ranges_are_refused() {
    let w = workspace(&["strip_001.las", "sbet.out", "sensor.toml"]);
    let params = |lever_x: f64, roll: f64| {
        format!(
            r#""parameters": {{"lever_x_m": {lever_x}, "lever_y_m": 0.0, "lever_z_m": 0.0,
               "boresight_roll_deg": {roll}, "boresight_pitch_deg": 0.0, "boresight_yaw_deg": 0.0}}"#
        )
    };
    let cases = [
        (
            format!("{{{}}}", params(500.0, 0.0)),
            vec!["parameters.lever_arm_m", "500.000 m"],
        ),
        (
            format!("{{{}}}", params(0.0, 180.0)),
            vec!["parameters.boresight_roll_deg", "180°"],
        ),
        (
            format!(
                r#"{{{}, "sigma": {{"lever_x_m": 1e6}}}}"#,
                params(0.05, 0.0)
            ),
            vec!["sigma.lever_x_m", "1000000", "millimetres read as metres"],
        ),
    ];
    for (doc, needles) in cases {
        let cal = p(&w, "calibration.json");
        std::fs::write(&cal, doc).unwrap();
        let out = p(&w, "corrected");
        refused_untouched(
            w.path(),
            &binary::with_calibration(
                "correct",
                &p(&w, "strip_001.las"),
                [&p(&w, "sbet.out"), &p(&w, "sensor.toml"), &cal],
                &out,
            ),
            &needles,
        );
    }
}

/// Bad case 5: a LAS header whose point count is half the records read half the points in
/// silence (a count of 0 was already refused); now refused with both counts.
#[test]
fn a_header_point_count_short_of_the_records_is_refused() {
    let w = workspace(&["strip_001.las", "sbet.out", "sensor.toml"]);
    let strip = p(&w, "strip_001.las");
    let mut bytes = std::fs::read(&strip).unwrap();
    let legacy = u32::from_le_bytes(bytes[107..111].try_into().unwrap());
    let minor = bytes[25];
    let total = if legacy != 0 {
        u64::from(legacy)
    } else {
        u64::from_le_bytes(bytes[247..255].try_into().unwrap())
    };
    let half = total / 2;
    if legacy != 0 {
        bytes[107..111].copy_from_slice(&(half as u32).to_le_bytes());
    }
    if minor >= 4 {
        bytes[247..255].copy_from_slice(&half.to_le_bytes());
    }
    std::fs::write(&strip, bytes).unwrap();
    refused_untouched(
        w.path(),
        &tpu_args(&strip, w.path(), &p(&w, "out.las"), &p(&w, "sensor.toml")),
        &[
            "strip_001.las",
            &format!("header says {half} points but the file holds {total} point records"),
        ],
    );
}
