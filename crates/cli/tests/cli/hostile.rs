//! Hostile input for every command: outputs never touch inputs, bounded
//! work, and one clear line for each refusal.
//!
//! Every case here was an exit 0 with a destroyed input, a silently wrong number, an abort or a
//! hang before #25: the same strip given twice, two inputs with one file name, `report -o` over
//! a product, manifest paths out of their directory or over an input, stale tiles, unbounded
//! `--neighbours` / pulses / Monte Carlo draws / search radius, budgets of rays pointing up,
//! control in degrees, doubled OS messages, and `lidarqa` with no command.
//!
//! One small survey (the demo scenario at 2 kHz: four strips of ~18 000 points) is simulated
//! once and shared read-only by the tests; each test writes into its own directory.

use crate::binary;

use binary::{lidarqa, s};
use std::path::{Path, PathBuf};
use std::process::Output;
use std::sync::OnceLock;

/// The shared survey: (its directory, kept alive for the whole test run).
fn survey() -> &'static Path {
    static SURVEY: OnceLock<tempfile::TempDir> = OnceLock::new();
    SURVEY
        .get_or_init(|| {
            let dir = tempfile::tempdir().unwrap();
            let scenario = small_scenario(dir.path(), 2000.0);
            ok(&[
                "simulate",
                "--scenario",
                s(&scenario),
                "--format",
                "las",
                "-o",
                leak(dir.path().join("sim")),
            ]);
            dir
        })
        .path()
}

/// A path as a `&'static str` argument (leaked: a test process is short-lived).
fn leak(p: PathBuf) -> &'static str {
    Box::leak(p.to_str().unwrap().to_owned().into_boxed_str())
}

fn sim(name: &str) -> PathBuf {
    survey().join("sim").join(name)
}

/// The demo scenario at `rate_hz` written to `dir/small.toml`.
fn small_scenario(dir: &Path, rate_hz: f64) -> PathBuf {
    let text = demo_scenario();
    let small = text.replacen(
        "pulse_rate_hz = 50000.0",
        &format!("pulse_rate_hz = {rate_hz:?}"),
        1,
    );
    assert_ne!(small, text, "the demo scenario's pulse rate line moved");
    let path = dir.join("small.toml");
    std::fs::write(&path, small).unwrap();
    path
}

fn demo_scenario() -> String {
    let out = lidarqa(&["simulate", "--scenario", "demo", "--print"]);
    assert!(out.status.success());
    String::from_utf8(out.stdout).unwrap()
}

/// The stderr of a successful run.
fn ok(args: &[&str]) -> String {
    String::from_utf8_lossy(&binary::run_ok(args).stderr).into_owned()
}

/// [`binary::fails_with`], and no repeated OS text and no temporary-file name.
fn fails_with(out: &Output, needles: &[&str]) -> String {
    let err = binary::fails_with(out, needles);
    // lidarqa's temporary files are `.NAME.PID.XXXXXX.tmp` (the test directories `/tmp/.tmpXXX`).
    assert!(
        !err.split([' ', ':', ',', ')']).any(|w| w.ends_with(".tmp")),
        "a temporary file named: {err}"
    );
    assert!(
        err.matches("(os error").count() <= 1,
        "OS text said twice: {err}"
    );
    err
}

fn run_fails(args: &[&str], needles: &[&str]) -> String {
    fails_with(&lidarqa(args), needles)
}

fn shared() -> Vec<String> {
    vec![
        "--trajectory".into(),
        leak(sim("sbet.out")).into(),
        "--sensor".into(),
        leak(sim("sensor.toml")).into(),
    ]
}

/// `args` followed by the shared trajectory and sensor flags.
fn with_shared<'a>(args: &[&'a str], shared: &'a [String]) -> Vec<&'a str> {
    let mut v = args.to_vec();
    v.extend(shared.iter().map(String::as_str));
    v
}

/// The visible files of `dir` (not `tile`'s hidden record of what it wrote).
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !n.starts_with('.'))
        .collect();
    v.sort();
    v
}

#[test]
fn no_command_prints_help_and_exits_2() {
    for args in [&[][..], &["plan"][..]] {
        let out = lidarqa(args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(text.contains("Usage: lidarqa"), "{text}");
    }
}

#[test]
fn help_says_which_commands_replace_existing_outputs() {
    for (cmd, needle) in [
        ("tile", "--overwrite"),
        ("correct", "replaced"),
        ("report", "never over"),
        ("demo", "replaced"),
    ] {
        let out = lidarqa(&[cmd, "--help"]);
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(text.contains(needle), "{cmd} --help lacks {needle}: {text}");
    }
}

#[test]
fn report_never_writes_over_a_product_it_reads() {
    let dir = tempfile::tempdir().unwrap();
    let out = lidarqa(&["budget", "--preset", "czmil", "--format", "json"]);
    assert!(out.status.success());
    let budget = dir.path().join("budget.json");
    std::fs::write(&budget, &out.stdout).unwrap();
    run_fails(
        &["report", s(dir.path()), "-o", s(&budget)],
        &["budget.json", "refusing to overwrite"],
    );
    assert_eq!(std::fs::read(&budget).unwrap(), out.stdout);
    // Another spelling of the same file.
    let other = dir.path().join(".").join("budget.json");
    run_fails(
        &["report", s(dir.path()), "-o", s(&other)],
        &["budget.json"],
    );
    assert_eq!(std::fs::read(&budget).unwrap(), out.stdout);
    ok(&["report", s(dir.path())]);
    assert!(dir.path().join("report.html").exists());
}

#[test]
fn correct_refuses_two_strips_with_one_file_name_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    std::fs::create_dir(&a).unwrap();
    std::fs::create_dir(&b).unwrap();
    std::fs::copy(sim("strip_001.las"), a.join("s1.las")).unwrap();
    std::fs::copy(sim("strip_002.las"), b.join("s1.las")).unwrap();
    let cal = dir.path().join("calibration.json");
    std::fs::write(&cal, "{}").unwrap();
    let out_dir = dir.path().join("out");
    let sh = shared();
    let (a1, b1) = (a.join("s1.las"), b.join("s1.las"));
    let args = with_shared(
        &[
            "correct",
            s(&a1),
            s(&b1),
            "--calibration",
            s(&cal),
            "-o",
            s(&out_dir),
        ],
        &sh,
    );
    run_fails(&args, &["a/s1.las", "b/s1.las", "same file name"]);
    assert!(!out_dir.join("s1.las").exists());
}

#[test]
fn the_same_strip_twice_is_refused_by_every_command_that_takes_strips() {
    let dir = tempfile::tempdir().unwrap();
    let strip = sim("strip_001.las");
    let again = survey().join("sim").join(".").join("strip_001.las");
    let link = dir.path().join("link.las");
    std::os::unix::fs::symlink(&strip, &link).unwrap();
    let sh = shared();
    let cal = dir.path().join("calibration.json");
    std::fs::write(&cal, "{}").unwrap();
    let out = dir.path().join("out");
    let cases: Vec<Vec<&str>> = vec![
        vec!["overlap", s(&strip), s(&strip)],
        vec!["overlap", s(&strip), s(&again)],
        vec![
            "targets",
            s(&strip),
            s(&link),
            "--control",
            leak(sim("control.csv")),
            "-o",
            s(&out),
        ],
        vec!["tile", s(&strip), s(&strip), "-o", s(&out)],
        with_shared(
            &[
                "calibrate",
                s(&strip),
                s(&again),
                "--auto-ties",
                "-o",
                "x.json",
            ],
            &sh,
        ),
        with_shared(
            &[
                "correct",
                s(&strip),
                s(&strip),
                "--calibration",
                s(&cal),
                "-o",
                s(&out),
            ],
            &sh,
        ),
    ];
    for args in cases {
        run_fails(&args, &["strip_001.las", "given twice"]);
    }
    assert!(!out.exists() || names(&out).is_empty());
    // A directory of tiles holding one tile under two names.
    let tiles = dir.path().join("tiles");
    std::fs::create_dir(&tiles).unwrap();
    std::fs::copy(&strip, tiles.join("a.las")).unwrap();
    std::os::unix::fs::symlink(tiles.join("a.las"), tiles.join("b.las")).unwrap();
    let tpu_out = dir.path().join("tpu");
    let args = with_shared(&["tpu", s(&tiles), "-o", s(&tpu_out)], &sh);
    run_fails(&args, &["given twice"]);
}

#[test]
fn tile_refuses_a_non_empty_directory_and_overwrite_removes_stale_tiles() {
    let dir = tempfile::tempdir().unwrap();
    let ts = dir.path().join("ts");
    let strips: Vec<PathBuf> = (1..=4).map(|i| sim(&format!("strip_00{i}.las"))).collect();
    let mut args: Vec<&str> = vec!["tile"];
    args.extend(strips.iter().map(|p| s(p)));
    args.extend(["--format", "las", "-o", s(&ts)]);
    let mut four = args.clone();
    four.extend(["--grid", "4x4"]);
    let said = ok(&four);
    let points: u64 = said.split_whitespace().nth(1).unwrap().parse().unwrap();
    let first = names(&ts);
    assert!(first.len() > 4, "{first:?}");
    let mut two = args.clone();
    two.extend(["--grid", "2x2"]);
    run_fails(&two, &["not empty", "--overwrite"]);
    assert_eq!(names(&ts), first, "the refused run changed the directory");
    two.push("--overwrite");
    let said = ok(&two);
    assert!(
        said.contains(&format!("{points} points in 4 tiles")),
        "{said}"
    );
    assert_eq!(
        names(&ts),
        [
            "tile_0_0.las",
            "tile_0_1.las",
            "tile_1_0.las",
            "tile_1_1.las"
        ]
    );
    // A point cloud that is not a tile is never removed: refused.
    std::fs::copy(&strips[0], ts.join("mine.las")).unwrap();
    run_fails(&two, &["mine.las", "not a tile"]);
    assert!(ts.join("mine.las").exists());
}

/// A plan of two tiles, its manifest in `dir` (so the sensor file is under the manifest's root
/// when `root_has_inputs`).
fn planned(dir: &Path) -> PathBuf {
    let tiles = dir.join("tiles");
    std::fs::create_dir_all(&tiles).unwrap();
    std::fs::copy(sim("strip_001.las"), tiles.join("t1.las")).unwrap();
    std::fs::copy(sim("strip_002.las"), tiles.join("t2.las")).unwrap();
    std::fs::copy(sim("sensor.toml"), dir.join("sensor.toml")).unwrap();
    let manifest = dir.join("manifest.json");
    ok(&[
        "plan",
        "tpu",
        "--tiles",
        s(&tiles),
        "--trajectory",
        leak(sim("sbet.out")),
        "--sensor",
        s(&dir.join("sensor.toml")),
        "--output-dir",
        s(&dir.join("tpu")),
        "-o",
        s(&manifest),
    ]);
    manifest
}

#[test]
fn manifests_never_write_out_of_their_directory_or_over_an_input() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = planned(dir.path());
    let text = std::fs::read_to_string(&manifest).unwrap();
    let doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    let sensor_before = std::fs::read(dir.path().join("sensor.toml")).unwrap();
    // Unique names: an old binary that lets them escape must not fail a later run.
    let pid = std::process::id();
    let outside = std::env::temp_dir().join(format!("lidarqa-hostile-outside-{pid}.las"));
    let escaped = format!("../escaped-{pid}.las");
    let cases = [
        ("output", serde_json::json!(escaped), "`..`"),
        ("report", serde_json::json!("tpu/../../x.json"), "`..`"),
        (
            "output",
            serde_json::json!(s(&outside)),
            "outside the manifest's directory",
        ),
        (
            "output",
            serde_json::json!("sensor.toml"),
            "is also an input",
        ),
        (
            "report",
            doc["entries"][1]["input"]["path"].clone(),
            "is also an input",
        ),
        (
            "output",
            doc["entries"][1]["output"].clone(),
            "one would overwrite the other",
        ),
    ];
    for (key, value, needle) in cases {
        let mut m = doc.clone();
        m["entries"][0][key] = value.clone();
        let bad = dir.path().join("bad.json");
        std::fs::write(&bad, serde_json::to_string_pretty(&m).unwrap()).unwrap();
        run_fails(&["run", s(&bad), "--index", "0"], &[needle]);
        run_fails(&["collect", s(&bad)], &[needle]);
        assert!(!outside.exists());
        assert!(!dir.path().parent().unwrap().join(&escaped[3..]).exists());
    }
    assert_eq!(
        std::fs::read(dir.path().join("sensor.toml")).unwrap(),
        sensor_before
    );
    // plan itself refuses an output directory outside the manifest's.
    let elsewhere = tempfile::tempdir().unwrap();
    run_fails(
        &[
            "plan",
            "tpu",
            "--tiles",
            leak(dir.path().join("tiles")),
            "--trajectory",
            leak(sim("sbet.out")),
            "--sensor",
            leak(sim("sensor.toml")),
            "--output-dir",
            s(elsewhere.path()),
            "-o",
            leak(dir.path().join("m2.json")),
        ],
        &["outside the manifest's directory"],
    );
    assert!(!dir.path().join("m2.json").exists());
}

#[test]
fn plan_reads_the_sensor_file_and_the_trajectory_up_front() {
    let dir = tempfile::tempdir().unwrap();
    let tiles = dir.path().join("tiles");
    std::fs::create_dir(&tiles).unwrap();
    std::fs::copy(sim("strip_001.las"), tiles.join("t1.las")).unwrap();
    let sensor = std::fs::read_to_string(sim("sensor.toml")).unwrap();
    let typo = dir.path().join("typo.toml");
    std::fs::write(
        &typo,
        sensor.replace("boresight_roll_deg", "boresight_rol_deg"),
    )
    .unwrap();
    let sbet = std::fs::read(sim("sbet.out")).unwrap();
    let truncated = dir.path().join("truncated.out");
    std::fs::write(&truncated, &sbet[..sbet.len() - 100]).unwrap();
    let manifest = dir.path().join("m.json");
    for (trajectory, sensor, needles) in [
        (
            sim("sbet.out"),
            typo.clone(),
            ["typo.toml", "boresight_rol_deg"],
        ),
        (
            truncated.clone(),
            sim("sensor.toml"),
            ["truncated.out", "136-byte"],
        ),
    ] {
        run_fails(
            &[
                "plan",
                "tpu",
                "--tiles",
                s(&tiles),
                "--trajectory",
                s(&trajectory),
                "--sensor",
                s(&sensor),
                "-o",
                s(&manifest),
            ],
            &needles,
        );
        assert!(!manifest.exists());
    }
}

#[test]
fn neighbours_are_bounded_in_tpu_and_plan() {
    let dir = tempfile::tempdir().unwrap();
    let sh = shared();
    let out = dir.path().join("o.las");
    for k in ["4294967295", "100000000", "257", "2"] {
        let args = with_shared(
            &[
                "tpu",
                leak(sim("strip_001.las")),
                "-o",
                s(&out),
                "--neighbours",
                k,
            ],
            &sh,
        );
        run_fails(&args, &["--neighbours", k, "3 to 256"]);
        assert!(!out.exists());
    }
    let tiles = dir.path().join("tiles");
    std::fs::create_dir(&tiles).unwrap();
    std::fs::copy(sim("strip_001.las"), tiles.join("t1.las")).unwrap();
    let args = with_shared(
        &[
            "plan",
            "tpu",
            "--tiles",
            s(&tiles),
            "-o",
            leak(dir.path().join("m.json")),
            "--neighbours",
            "1000000000",
        ],
        &sh,
    );
    run_fails(&args, &["--neighbours", "3 to 256"]);
}

#[test]
fn simulate_bounds_every_size_key() {
    let dir = tempfile::tempdir().unwrap();
    let text = demo_scenario();
    let cases = [
        (
            "pulse_rate_hz = 50000.0",
            "pulse_rate_hz = 1e12",
            "scanner.pulse_rate_hz",
        ),
        // 4 MHz is a real rate, but over the demo's 127 s it is 5.1e8 pulses.
        ("pulse_rate_hz = 50000.0", "pulse_rate_hz = 4e6", "pulses"),
        (
            "trajectory_rate_hz = 200.0",
            "trajectory_rate_hz = 1e9",
            "motion.trajectory_rate_hz",
        ),
        ("height_m = 100.0", "height_m = 1e7", "height_m"),
    ];
    for (from, to, needle) in cases {
        let changed = text.replacen(from, to, 1);
        assert_ne!(changed, text, "{from} moved");
        let path = dir.path().join("s.toml");
        std::fs::write(&path, changed).unwrap();
        let out = dir.path().join("out");
        let start = std::time::Instant::now();
        run_fails(
            &["simulate", "--scenario", s(&path), "-o", s(&out)],
            &["s.toml", needle],
        );
        assert!(start.elapsed().as_secs() < 10, "{to}: not refused up front");
        assert!(!out.exists());
    }
}

#[test]
fn budget_refuses_impossible_geometry_unbounded_draws_and_duplicate_keys() {
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&[&str], &[&str]); 6] = [
        (
            &["--preset", "zhang2018", "--scan-angle", "95"],
            &["does not point down"],
        ),
        (
            &["--preset", "zhang2018", "--height", "1e300"],
            &["height", "1e300", "100000"],
        ),
        (
            &["--preset", "zhang2018", "--range", "5e6"],
            &["range", "100000"],
        ),
        (
            &["--preset", "czmil", "--monte-carlo", "1000000000000"],
            &["--monte-carlo", "1000000"],
        ),
        (
            &["--preset", "czmil", "--monte-carlo", "1"],
            &["--monte-carlo"],
        ),
        (
            &[
                "--preset",
                "zhang2018",
                "--bias",
                "boresight_roll_deg=1,boresight_roll_deg=2",
            ],
            &["boresight_roll_deg", "twice"],
        ),
    ];
    for (args, needles) in cases {
        let mut a = vec!["budget"];
        a.extend_from_slice(args);
        let out = lidarqa(&a);
        fails_with(&out, needles);
        assert!(out.stdout.is_empty(), "{a:?} printed a budget");
    }
    // The sensor file goes through the same checks as for `tpu`.
    let sensor = dir.path().join("bad.toml");
    std::fs::write(
        &sensor,
        "[scanner]\ntype = \"linear\"\nbeam_divergence_mrad = -1\n",
    )
    .unwrap();
    run_fails(
        &[
            "budget",
            "--sensor",
            s(&sensor),
            "--scan-angle",
            "10",
            "--height",
            "100",
        ],
        &["bad.toml", "scanner.beam_divergence_mrad", "-1"],
    );
    let sh = vec![
        "--trajectory".to_string(),
        leak(sim("sbet.out")).to_string(),
        "--sensor".to_string(),
        s(&sensor).to_string(),
    ];
    let args = with_shared(
        &[
            "tpu",
            leak(sim("strip_001.las")),
            "-o",
            leak(dir.path().join("o.las")),
        ],
        &sh,
    );
    run_fails(&args, &["bad.toml", "scanner.beam_divergence_mrad", "-1"]);
}

#[test]
fn calibrate_bounds_its_search_and_speaks_in_the_csv_terms() {
    let dir = tempfile::tempdir().unwrap();
    let sh = shared();
    let out = dir.path().join("cal.json");
    let strips = [sim("strip_001.las"), sim("strip_002.las")];
    for (flag, value) in [
        ("--radius-m", "1e6"),
        ("--ransac-iterations", "1000000000"),
        ("--max-iterations", "1000000000"),
    ] {
        let args = with_shared(
            &[
                "calibrate",
                s(&strips[0]),
                s(&strips[1]),
                "--auto-ties",
                flag,
                value,
                "-o",
                s(&out),
            ],
            &sh,
        );
        run_fails(&args, &[flag]);
        assert!(!out.exists());
    }
    // A pick 5 km east of the survey: the error names the CSV, its line and its x, y.
    let ties = dir.path().join("ties.csv");
    std::fs::write(
        &ties,
        "tie,strip,x,y\nB,1,645000,2800010\nB,2,645000,2800010\n",
    )
    .unwrap();
    let args = with_shared(
        &[
            "calibrate",
            s(&strips[0]),
            s(&strips[1]),
            "--ties",
            s(&ties),
            "-o",
            s(&out),
        ],
        &sh,
    );
    run_fails(&args, &["ties.csv: line 2: tie B", "x 645000, y 2800010"]);
    assert!(!out.exists());
}

#[test]
fn evaluate_refuses_control_in_another_frame_and_keeps_its_columns_apart() {
    let dir = tempfile::tempdir().unwrap();
    let control = std::fs::read_to_string(sim("control.csv")).unwrap();
    let mut rows: Vec<Vec<String>> = control
        .lines()
        .skip(1)
        .map(|l| l.split(',').take(4).map(str::to_string).collect())
        .collect();
    let write = |name: &str, rows: &[Vec<String>]| {
        let path = dir.path().join(name);
        let mut text = String::from("id,x,y,z\n");
        for r in rows {
            text.push_str(&r.join(","));
            text.push('\n');
        }
        std::fs::write(&path, text).unwrap();
        path
    };
    // Targets: the control points moved by a few cm, one with a long id.
    rows[0][0] = "CHECKPOINT_NORTH_BRIDGE".into();
    let targets: Vec<Vec<String>> = rows
        .iter()
        .map(|r| {
            let x: f64 = r[1].parse().unwrap();
            vec![
                r[0].clone(),
                format!("{}", x + 0.03),
                r[2].clone(),
                r[3].clone(),
            ]
        })
        .collect();
    let targets = write("targets.csv", &targets);
    let good = write("control.csv", &rows);
    let degrees: Vec<Vec<String>> = rows
        .iter()
        .map(|r| vec![r[0].clone(), "110.4".into(), "25.3".into(), r[3].clone()])
        .collect();
    let degrees = write("control_deg.csv", &degrees);
    run_fails(
        &[
            "evaluate",
            "--targets",
            s(&targets),
            "--control",
            s(&degrees),
        ],
        &["control_deg.csv", "degrees"],
    );
    let zone: Vec<Vec<String>> = rows
        .iter()
        .map(|r| {
            let x: f64 = r[1].parse().unwrap();
            vec![
                r[0].clone(),
                format!("{}", x + 200_000.0),
                r[2].clone(),
                r[3].clone(),
            ]
        })
        .collect();
    let zone = write("control_zone.csv", &zone);
    run_fails(
        &["evaluate", "--targets", s(&targets), "--control", s(&zone)],
        &["control_zone.csv", "not in the same frame"],
    );
    // The table: every row splits into the id and four numbers.
    let out = lidarqa(&["evaluate", "--targets", s(&targets), "--control", s(&good)]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    let row = text
        .lines()
        .find(|l| l.starts_with("CHECKPOINT_NORTH_BRIDGE"))
        .unwrap();
    let cols: Vec<&str> = row.split_whitespace().collect();
    assert_eq!(cols.len(), 5, "{row}");
    let east: f64 = cols[2].parse().unwrap();
    assert!((east - 3.0).abs() < 0.01, "{row}");
}

#[test]
fn a_missing_file_is_one_line_with_the_os_text_once() {
    let dir = tempfile::tempdir().unwrap();
    let nope = dir.path().join("nope.las");
    let sh = shared();
    let cases: Vec<Vec<&str>> = vec![
        with_shared(
            &["tpu", s(&nope), "-o", leak(dir.path().join("o.las"))],
            &sh,
        ),
        vec!["overlap", s(&nope), leak(sim("strip_001.las"))],
        vec!["tile", s(&nope), "-o", leak(dir.path().join("t"))],
        vec!["budget", "--sensor", s(&nope), "--height", "100"],
        vec!["run", s(&nope), "--index", "0"],
        vec!["collect", s(&nope)],
        vec![
            "targets",
            s(&nope),
            "--control",
            leak(sim("control.csv")),
            "-o",
            leak(dir.path().join("t.csv")),
        ],
        with_shared(&["calibrate", s(&nope), "--auto-ties", "-o", "c.json"], &sh),
        vec!["evaluate", "--targets", s(&nope), "--control", s(&nope)],
        vec![
            "simulate",
            "--scenario",
            s(&nope),
            "-o",
            leak(dir.path().join("s")),
        ],
    ];
    for args in cases {
        let err = run_fails(&args, &["nope."]);
        assert!(
            err.matches("No such file or directory").count() == 1,
            "{args:?}: {err}"
        );
    }
}

#[test]
fn demo_refuses_an_output_that_is_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("afile");
    std::fs::write(&file, "mine").unwrap();
    run_fails(&["demo", "--quick", "-o", s(&file)], &["afile"]);
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "mine");
}
