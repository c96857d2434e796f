//! Every example in every subcommand's `--help` runs. The examples are read from the built
//! binary's help text (the "Example:" / "Examples:" block of each subcommand's after_help), so a
//! new or changed example is tested without touching this file; each is run by `sh` in a
//! directory holding the files the examples name, made here from a small simulated survey (the
//! demo's scenario cut to four short lines). `lidarqa` is first on `PATH`, so the examples run
//! exactly as printed, pipes, `&&`, redirections and globs included, but for `lidarqa demo`'s
//! examples, which are the runs of the `demo::` tests and only checked to be so here. Four changes
//! are made, three to keep the test small: `lidarqa demo` takes `--quick`, the scenarios an example simulates
//! (`--scenario demo`, `--scenario my-survey.toml`) are the small one, and `/tmp/…` output paths
//! are put inside the test's directory; and one for the data: the `trajectory` examples run on
//! two short strips of the forest scenario, since the demo's scene has no multi-return pulses.
//! `$SLURM_ARRAY_TASK_ID` is 0, and `lidarqa collect` runs after every manifest entry was run.

use std::path::{Path, PathBuf};
use std::process::Command;

const SUBCOMMANDS: [&str; 17] = [
    "budget",
    "sensor",
    "simulate",
    "tile",
    "targets",
    "evaluate",
    "tpu",
    "trajectory",
    "calibrate",
    "correct",
    "overlap",
    "qc",
    "plan",
    "run",
    "collect",
    "report",
    "demo",
];

fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_lidarqa")
}

/// `lidarqa ARGS` in `dir`, which must succeed.
fn lidarqa(dir: &Path, args: &[&str]) {
    let out = Command::new(bin())
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "setup: lidarqa {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The examples of one subcommand's help: each a command line (continuations joined), with the
/// explanation some examples carry after a run of spaces removed.
fn examples(subcommand: &str) -> Vec<String> {
    let out = Command::new(bin())
        .args([subcommand, "--help"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let help = String::from_utf8(out.stdout).unwrap();
    let mut lines = help.lines().skip_while(|l| !l.starts_with("Example"));
    assert!(
        lines.next().is_some(),
        "`lidarqa {subcommand} --help` has no Example(s) block"
    );
    let mut found = Vec::new();
    let mut current = String::new();
    for line in lines {
        if line.trim().is_empty() {
            break;
        }
        let text = line.trim();
        // A line that starts no example and continues none is an example wrapped by clap at
        // the help's width: a reader copying it would get a broken command.
        assert!(
            !current.is_empty() || text.starts_with("lidarqa "),
            "`lidarqa {subcommand} --help`: the example line `{text}` does not start with \
             `lidarqa` (too long, wrapped? end the line before with `\\`)"
        );
        let (body, continues) = match text.strip_suffix('\\') {
            Some(b) => (b.trim_end(), true),
            None => (text, false),
        };
        current.push_str(body);
        current.push(' ');
        if !continues {
            found.push(without_explanation(current.trim()));
            current.clear();
        }
    }
    assert!(
        !found.is_empty(),
        "`lidarqa {subcommand} --help` lists no example"
    );
    found
}

/// `lidarqa overlap a.laz b.laz     RMSDz per pair` → `lidarqa overlap a.laz b.laz`: text after
/// three or more spaces that is no flag, comment or redirection is an explanation.
fn without_explanation(line: &str) -> String {
    let mut rest = line;
    let mut kept = String::new();
    while let Some(i) = rest.find("   ") {
        let after = rest[i..].trim_start();
        if after.starts_with('-') || after.starts_with('#') || after.starts_with('>') {
            kept.push_str(&rest[..i]);
            kept.push(' ');
            rest = after;
        } else {
            kept.push_str(&rest[..i]);
            return kept.trim().to_string();
        }
    }
    kept.push_str(rest);
    kept.trim().to_string()
}

/// The demo's scenario cut to four lines of ±60 m at 20 kHz (as `tests/simulate.rs` does), with
/// two targets where every strip sees them.
fn small_scenario(dir: &Path) -> PathBuf {
    let out = Command::new(bin())
        .args(["simulate", "--scenario", "demo", "--print"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let mut doc: toml::Table = toml::from_str(&String::from_utf8(out.stdout).unwrap()).unwrap();
    let lines = doc["lines"].as_array_mut().unwrap();
    lines.truncate(4);
    for line in lines.iter_mut() {
        let t = line.as_table_mut().unwrap();
        for key in ["start_m", "end_m"] {
            for v in t[key].as_array_mut().unwrap().iter_mut() {
                *v = toml::Value::Float(v.as_float().unwrap().clamp(-60.0, 60.0));
            }
        }
    }
    doc["scanner"].as_table_mut().unwrap()["pulse_rate_hz"] = toml::Value::Float(20_000.0);
    // Two of the demo's targets, moved to where all four short strips see them.
    let targets = doc["scene"]["targets"].as_array().unwrap().clone();
    let moved: Vec<toml::Value> = targets
        .into_iter()
        .take(2)
        .zip([[-30.0, 10.0], [30.0, -25.0]])
        .map(|(mut t, c)| {
            t.as_table_mut().unwrap()["center_m"] =
                toml::Value::Array(c.iter().map(|&v| toml::Value::Float(v)).collect());
            t
        })
        .collect();
    doc["scene"].as_table_mut().unwrap()["targets"] = toml::Value::Array(moved);
    let path = dir.join("small.toml");
    std::fs::write(&path, toml::to_string(&doc).unwrap()).unwrap();
    path
}

/// The forest scenario (canopy: multi-return pulses, which `lidarqa trajectory` needs) cut to two
/// opposite 4 s lines at 20 kHz.
fn small_forest(dir: &Path) -> PathBuf {
    let out = Command::new(bin())
        .args(["simulate", "--scenario", "forest", "--print"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let mut doc: toml::Table = toml::from_str(&String::from_utf8(out.stdout).unwrap()).unwrap();
    let lines = doc["lines"].as_array_mut().unwrap();
    lines.truncate(1);
    let first = lines[0].as_table_mut().unwrap();
    first["start_m"] = toml::Value::Array(vec![(-120.0).into(), 0.0.into()]);
    first["end_m"] = toml::Value::Array(vec![120.0.into(), 0.0.into()]);
    let mut second = first.clone();
    second["id"] = toml::Value::Integer(2);
    second["start_m"] = toml::Value::Array(vec![120.0.into(), 40.0.into()]);
    second["end_m"] = toml::Value::Array(vec![(-120.0).into(), 40.0.into()]);
    let t0 = second["start_time_s"].as_float().unwrap();
    second["start_time_s"] = (t0 + 100.0).into();
    lines.push(toml::Value::Table(second));
    doc["scanner"].as_table_mut().unwrap()["pulse_rate_hz"] = toml::Value::Float(20_000.0);
    let path = dir.join("forest.toml");
    std::fs::write(&path, toml::to_string(&doc).unwrap()).unwrap();
    path
}

/// The files the examples name, in `w`.
fn fixtures(w: &Path) {
    let scenario = small_scenario(w);
    lidarqa(w, &["simulate", "--scenario", s(&scenario), "-o", "sim"]);
    let sim = w.join("sim");
    let strips: Vec<PathBuf> = (1..=4)
        .map(|i| sim.join(format!("strip_00{i}.laz")))
        .collect();
    for s in &strips {
        assert!(s.exists(), "{} missing", s.display());
    }
    let copy = |from: &Path, to: &str| {
        let to = w.join(to);
        std::fs::create_dir_all(to.parent().unwrap()).unwrap();
        std::fs::copy(from, to).unwrap();
    };
    for name in ["strip.laz", "strip1.laz", "strip_001.laz", "s1.laz"] {
        copy(&strips[0], name);
    }
    for name in ["strip2.laz", "strip_002.laz", "s2.laz"] {
        copy(&strips[1], name);
    }
    copy(&strips[2], "s3.laz");
    copy(&strips[3], "s4.laz");
    for (i, s) in strips.iter().enumerate() {
        copy(s, &format!("strips/strip_00{}.laz", i + 1));
    }
    // The Optech CSD example reads PDAL's public sample (read in place, copied to the scratch
    // directory under the example's name).
    if let Some(csd) = lidarqa_testkit::realdata("optech_csd_pdal") {
        copy(&csd.join("sample.csd"), "sample.csd");
    }
    for name in ["sbet.out", "smrmsg.out", "sensor.toml", "control.csv"] {
        copy(&sim.join(name), name);
    }
    copy(&sim.join("control.csv"), "nva.csv");
    copy(&sim.join("control.csv"), "cp.csv");
    let forest = small_forest(w);
    lidarqa(w, &["simulate", "--scenario", s(&forest), "-o", "forest"]);
    copy(&w.join("forest/strip_001.laz"), "forest1.laz");
    copy(&w.join("forest/strip_002.laz"), "forest2.laz");
    // Hand picks: every control point picked at its plan position in every strip.
    let control = std::fs::read_to_string(w.join("control.csv")).unwrap();
    let mut rows = control.lines();
    let header: Vec<&str> = rows.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (id, x, y) = (col("id"), col("x"), col("y"));
    let mut ties = String::from("tie,strip,x,y\n");
    for row in rows {
        let cells: Vec<&str> = row.split(',').collect();
        for strip in 1..=4 {
            ties.push_str(&format!(
                "{},{strip},{},{}\n",
                cells[id], cells[x], cells[y]
            ));
        }
    }
    std::fs::write(w.join("ties.csv"), ties).unwrap();
    lidarqa(
        w,
        &[
            "targets",
            "strip_001.laz",
            "strip_002.laz",
            "--control",
            "control.csv",
            "-o",
            "targets.csv",
        ],
    );
    lidarqa(
        w,
        &[
            "tpu",
            "strip.laz",
            "--trajectory",
            "sbet.out",
            "--sensor",
            "sensor.toml",
            "-o",
            "fixture_tpu.laz",
            "--summary",
            "tpu_summary.json",
            "--format",
            "json",
        ],
    );
    lidarqa(
        w,
        &[
            "calibrate",
            "s1.laz",
            "s2.laz",
            "s3.laz",
            "s4.laz",
            "--trajectory",
            "sbet.out",
            "--sensor",
            "sensor.toml",
            "--ties",
            "ties.csv",
            "--control",
            "control.csv",
            "-o",
            "calibration.json",
        ],
    );
    copy(&sim.join("sensor.toml"), "my_sensor.toml");
    for dir in ["lidarqa-demo", "run1", "out"] {
        std::fs::create_dir_all(w.join(dir)).unwrap();
    }
    for dir in ["lidarqa-demo", "run1"] {
        std::fs::copy(
            w.join("tpu_summary.json"),
            w.join(dir).join("tpu_summary.json"),
        )
        .unwrap();
    }
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The example as run: `demo` gets `--quick`, `/tmp/NAME` becomes `tmp-NAME` in the directory,
/// and a trajectory is rebuilt from (and used with) the forest's strips, which have multi-return
/// pulses, its SBET written beside the survey's rather than over it.
fn as_run(example: &str) -> String {
    let example = if example.starts_with("lidarqa trajectory")
        || example.contains("--trajectory trajectory.csv")
    {
        example
            .replace("strip1.laz", "forest1.laz")
            .replace("strip2.laz", "forest2.laz")
            .replace("--sbet sbet.out", "--sbet forest_sbet.out")
    } else {
        example.to_string()
    };
    let mut line = example
        .replace("/tmp/", "tmp-")
        .replace("--scenario demo -o", "--scenario small.toml -o")
        .replace("--scenario my-survey.toml", "--scenario small.toml");
    if line.starts_with("lidarqa demo") && !line.contains("--quick") {
        line.push_str(" --quick");
    }
    line
}

#[test]
fn every_help_example_runs() {
    let dir = tempfile::tempdir().unwrap();
    let w = dir.path();
    fixtures(w);
    let bin_dir = Path::new(bin()).parent().unwrap();
    let path = format!(
        "{}:{}",
        bin_dir.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let mut ran = 0;
    let mut seen = std::collections::HashSet::new();
    for sub in SUBCOMMANDS {
        for example in examples(sub) {
            let line = as_run(&example);
            if line.contains("sample.csd") && !w.join("sample.csd").exists() {
                eprintln!("skipped without the public CSD sample: {line}");
                continue;
            }
            // The demo's examples are the runs of the `demo::` tests (`demo --quick -o DIR`,
            // `demo --bathymetry --quick -o DIR`), the longest of this binary: here only their
            // words are checked to be those, so a changed example still fails.
            if line.starts_with("lidarqa demo") {
                let quick = without_output(&line);
                assert!(
                    quick == "lidarqa demo --quick" || quick == "lidarqa demo --bathymetry --quick",
                    "`lidarqa demo --help` example no `demo::` test runs: {example}"
                );
                ran += 1;
                continue;
            }
            if !seen.insert(without_output(&line)) {
                ran += 1;
                continue;
            }
            let out = Command::new("sh")
                .current_dir(w)
                .env("PATH", &path)
                .env("SLURM_ARRAY_TASK_ID", "0")
                .env_remove("JOB_COMPLETION_INDEX")
                .args(["-c", &format!("set -e; {}{line}", before(&line))])
                .output()
                .unwrap();
            assert!(
                out.status.success(),
                "`lidarqa {sub} --help` example failed:\n  {example}\n  (run as: {line})\n{}",
                String::from_utf8_lossy(&out.stderr)
            );
            ran += 1;
        }
    }
    // Every subcommand has an example, and the count is no accident of the parsing.
    assert!(ran >= 35, "only {ran} examples found");
}

/// What runs before an example, as the examples say in words: `lidarqa collect` follows a
/// `lidarqa run` of every entry ("one per tile"), here in a loop until the index is past the end.
fn before(line: &str) -> &'static str {
    if line.starts_with("lidarqa collect manifest.json") {
        "i=0; while lidarqa run manifest.json --index $i >/dev/null 2>&1; do i=$((i+1)); done; "
    } else {
        ""
    }
}

/// The command line without its `-o DIR`, to tell two runs of the same thing.
fn without_output(line: &str) -> String {
    let words: Vec<&str> = line.split_whitespace().collect();
    let mut kept = Vec::new();
    let mut i = 0;
    while i < words.len() {
        if words[i] == "-o" {
            i += 2;
        } else {
            kept.push(words[i]);
            i += 1;
        }
    }
    kept.join(" ")
}

/// The parsing of the help text itself, on the shapes the examples take.
#[test]
fn explanations_are_cut_and_flags_kept() {
    assert_eq!(
        without_explanation("lidarqa overlap s1.laz s2.laz      RMSDz and max |dz| per strip pair"),
        "lidarqa overlap s1.laz s2.laz"
    );
    assert_eq!(
        without_explanation("lidarqa budget --preset czmil    --format json"),
        "lidarqa budget --preset czmil --format json"
    );
    assert_eq!(
        without_explanation("lidarqa run manifest.json   # index from $SLURM_ARRAY_TASK_ID"),
        "lidarqa run manifest.json # index from $SLURM_ARRAY_TASK_ID"
    );
    assert_eq!(
        as_run("lidarqa demo -o /tmp/demo"),
        "lidarqa demo -o tmp-demo --quick"
    );
}
