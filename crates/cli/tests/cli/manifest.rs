//! `lidarqa tile` → `plan tpu` → `run --index N` → `collect`, run as the real binary on a small
//! simulated survey: byte-identical tiles and the same summary as `lidarqa tpu DIR`; complete
//! entries skipped; changed inputs refused until planned again, then redone; partial or corrupt
//! outputs and reports redone; one-line errors (SPEC §9).

use crate::binary;
use binary::{lidarqa, s};

use serde_json::Value;
use std::path::{Path, PathBuf};

fn ok(args: &[&str]) -> String {
    let out = lidarqa(args);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{args:?}: {err}");
    err
}

/// Exit 1 with one line `lidarqa: …` containing every needle.
fn fails_with(args: &[&str], needles: &[&str]) {
    binary::fails_with(&lidarqa(args), needles);
}

/// A simulated survey (the demo scenario at 1 kHz: ~36 000 points in four strips) cut into
/// 2 × 2 tiles, with `lidarqa tpu` run over the tile directory as the reference.
struct Survey {
    dir: tempfile::TempDir,
}

impl Survey {
    fn new() -> Survey {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let out = lidarqa(&["simulate", "--scenario", "demo", "--print"]);
        let text = String::from_utf8(out.stdout).unwrap();
        let text = text.replace("pulse_rate_hz = 50000.0", "pulse_rate_hz = 1000.0");
        assert!(
            text.contains("pulse_rate_hz = 1000.0"),
            "the demo's pulse rate moved"
        );
        std::fs::write(d.join("small.toml"), text).unwrap();
        ok(&[
            "simulate",
            "--scenario",
            s(&d.join("small.toml")),
            "-o",
            s(&d.join("sim")),
        ]);
        let strips: Vec<String> = (1..=4)
            .map(|i| d.join(format!("sim/strip_00{i}.laz")).display().to_string())
            .collect();
        let mut args = vec!["tile"];
        args.extend(strips.iter().map(String::as_str));
        let tiles = d.join("tiles");
        args.extend(["--grid", "2x2", "-o", s(&tiles)]);
        ok(&args);
        let sv = Survey { dir };
        let mut args = vec![
            "tpu",
            sv.p("tiles"),
            "-o",
            sv.p("cli"),
            "--summary",
            sv.p("cli.json"),
        ];
        args.extend(sv.shared());
        ok(&args);
        sv
    }

    fn p(&self, rel: &str) -> &'static str {
        // Leaked once per test: keeps the argument lists short.
        Box::leak(
            self.dir
                .path()
                .join(rel)
                .display()
                .to_string()
                .into_boxed_str(),
        )
    }

    fn shared(&self) -> [&'static str; 6] {
        [
            "--trajectory",
            self.p("sim/sbet.out"),
            "--smrmsg",
            self.p("sim/smrmsg.out"),
            "--sensor",
            self.p("sim/sensor.toml"),
        ]
    }

    fn plan(&self) {
        let mut args = vec!["plan", "tpu", "--tiles", self.p("tiles")];
        args.extend(self.shared());
        args.extend([
            "--output-dir",
            self.p("work/tpu"),
            "-o",
            self.p("work/manifest.json"),
        ]);
        ok(&args);
    }

    /// Runs entry `i`; true when it was skipped as complete.
    fn run(&self, i: usize) -> bool {
        let err = ok(&[
            "run",
            self.p("work/manifest.json"),
            "--index",
            &i.to_string(),
        ]);
        assert!(err.contains(&format!("entry {i} ")), "{err}");
        err.contains("skipped (already complete)")
    }

    fn tiles(&self) -> Vec<String> {
        // The point-cloud tiles only (`tile` keeps its own record, `.lidarqa-tiles.json`, beside them).
        let mut v: Vec<String> = std::fs::read_dir(self.dir.path().join("tiles"))
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".las") || n.ends_with(".laz"))
            .collect();
        v.sort();
        v
    }

    fn same_as_cli(&self, name: &str) -> bool {
        let a = std::fs::read(self.dir.path().join("cli").join(name)).unwrap();
        std::fs::read(self.dir.path().join("work/tpu").join(name)).is_ok_and(|b| a == b)
    }

    fn mtime(&self, name: &str) -> std::time::SystemTime {
        std::fs::metadata(self.dir.path().join("work/tpu").join(name))
            .unwrap()
            .modified()
            .unwrap()
    }
}

/// The summary with each tile's paths reduced to file names (the two runs write to different
/// directories; everything else must be equal).
fn normalised(path: &str) -> Value {
    let mut v: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    for t in v["tiles"].as_array_mut().unwrap() {
        for k in ["input", "output"] {
            let name = Path::new(t[k].as_str().unwrap())
                .file_name()
                .unwrap()
                .to_string_lossy()
                .into_owned();
            t[k] = Value::String(name);
        }
    }
    v
}

#[test]
fn plan_run_collect_equals_tpu_over_the_directory() {
    let sv = Survey::new();
    let tiles = sv.tiles();
    assert_eq!(tiles.len(), 4, "{tiles:?}");
    sv.plan();
    // Not complete yet: collect names the missing entries.
    fails_with(
        &["collect", sv.p("work/manifest.json")],
        &["4 of 4 entries are not complete", "0 (no tile report)"],
    );
    for i in 0..tiles.len() {
        assert!(!sv.run(i), "entry {i} ran");
    }
    for t in &tiles {
        assert!(sv.same_as_cli(t), "{t}: differs from lidarqa tpu's");
    }
    ok(&[
        "collect",
        sv.p("work/manifest.json"),
        "--summary",
        sv.p("collected.json"),
    ]);
    let (a, b) = (
        normalised(sv.p("cli.json")),
        normalised(sv.p("collected.json")),
    );
    assert_eq!(a, b, "collect differs from lidarqa tpu's summary");
    assert!(a["points_written"].as_u64().unwrap() > 20_000);

    // Complete entries are skipped and untouched.
    let before: Vec<_> = tiles.iter().map(|t| sv.mtime(t)).collect();
    for i in 0..tiles.len() {
        assert!(sv.run(i), "entry {i} was redone");
    }
    assert_eq!(
        before,
        tiles.iter().map(|t| sv.mtime(t)).collect::<Vec<_>>()
    );

    // Errors: one line naming the value.
    fails_with(
        &["run", sv.p("work/manifest.json"), "--index", "4"],
        &["no entry 4", "indices 0 to 3"],
    );
    fails_with(
        &["run", sv.p("work/nothing.json"), "--index", "0"],
        &["nothing.json"],
    );
    std::fs::write(sv.p("work/bad.json"), "{\"format\": \"x\"}").unwrap();
    fails_with(
        &["collect", sv.p("work/bad.json")],
        &["bad.json", "not a lidarqa manifest"],
    );
}

#[test]
fn changed_partial_and_corrupt_entries_are_redone() {
    let sv = Survey::new();
    let tiles = sv.tiles();
    sv.plan();
    for i in 0..tiles.len() {
        sv.run(i);
    }
    // A truncated output (as a copy interrupted by hand would leave): redone, equal again.
    let out1 = sv.dir.path().join("work/tpu").join(&tiles[1]);
    let bytes = std::fs::read(&out1).unwrap();
    std::fs::write(&out1, &bytes[..bytes.len() / 2]).unwrap();
    // A corrupt report and a missing report: redone.
    std::fs::write(
        sv.p(&format!("work/tpu/{}.report.json", tiles[2])),
        "{\"trunc",
    )
    .unwrap();
    std::fs::remove_file(sv.p(&format!("work/tpu/{}.report.json", tiles[3]))).unwrap();
    let kept = sv.mtime(&tiles[0]);
    assert!(sv.run(0));
    assert!(!sv.run(1), "a truncated output was taken as complete");
    assert!(!sv.run(2), "a corrupt report was taken as complete");
    assert!(
        !sv.run(3),
        "an entry without a report was taken as complete"
    );
    assert_eq!(sv.mtime(&tiles[0]), kept);
    for t in &tiles {
        assert!(sv.same_as_cli(t), "{t}");
    }

    // A changed input: refused until planned again, then only that entry is redone.
    let changed = sv.dir.path().join("tiles").join(&tiles[0]);
    let other = std::fs::read(sv.dir.path().join("tiles").join(&tiles[1])).unwrap();
    std::fs::write(&changed, other).unwrap();
    fails_with(
        &["run", sv.p("work/manifest.json"), "--index", "0"],
        &[
            &tiles[0],
            "changed since the manifest",
            "run lidarqa plan again",
        ],
    );
    sv.plan();
    assert!(!sv.run(0), "the changed input was not redone");
    for i in 1..tiles.len() {
        assert!(sv.run(i), "entry {i} was redone after a replan");
    }
    // The redone tile is the TPU of its new content: the neighbouring tile's output.
    assert_eq!(
        std::fs::read(sv.dir.path().join("work/tpu").join(&tiles[0])).unwrap(),
        std::fs::read(sv.dir.path().join("cli").join(&tiles[1])).unwrap()
    );
    // No hidden temporary file is left behind by any of this.
    let leftovers: Vec<PathBuf> = std::fs::read_dir(sv.dir.path().join("work/tpu"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}
