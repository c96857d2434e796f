//! `lidarqa-bench`: each long `lidarqa` command against the physical limit of a streaming tool on
//! this machine, a copy of that command's own output LAZ with the las crate's parallel LAZ codec
//! in 500 000-point chunks (las-rs's `examples/convert_streaming.rs`). ratio = copy time / command
//! time, both measured in the same run; ≥ 1 means the command costs no more than its own I/O.
//!
//! The commands run as child processes of the release `lidarqa` binary (next to this one, or
//! `--lidarqa PATH`), so the times include everything a user waits for; peak memory is the
//! child's maximum resident set size from `/usr/bin/time` (left blank when it is missing).
//!
//! The strip is `scenarios/strip.toml`: the demo's sensor and scene, one 2.75 km line at 300 m,
//! 200 kHz, i.e. 10 M pulses; `--points N` shortens the line to N pulses. Then:
//! `simulate`, `tpu` with and without the incidence term (the sensor file with and without
//! `beam_divergence_mrad`), `correct` with the scenario's injected mounting errors as the
//! calibration, and the conic TPU of `simulate --scenario bathymetry`. Each row shows its bar on
//! the ratio to a parallel LAZ copy of its own output (0.7 for `simulate` and both `tpu` rows; see
//! the rows for the others).
//!
//! ```text
//! cargo build --release -p lidarqa -p lidarqa-bench
//! target/release/lidarqa-bench                      # 10 M pulses (the README's table)
//! target/release/lidarqa-bench --points 1000000     # a quick run
//! ```
//! Other options: `--dir DIR` keeps the files there (default: a temporary directory, removed),
//! `--lidarqa PATH` the binary to measure, `--only LIST` runs only some rows (comma-separated:
//! `simulate`, `tpu`, `correct`, `conic`, `calibrate`), `--calibrate` adds the calibration row,
//! `--repeat N` runs every row N times and shows each one's median ratio (the calibration row's
//! median wall time) and the range: one run of a row near its bar says little on a machine whose
//! timings move by a few per cent from run to run.
//!
//! The calibration row (not in the default run: it simulates 32 M points first) has an
//! absolute bar, ≤ 30 s and ≤ 1 GB: `calibrate --auto-ties --control` on the 24-strip
//! `calibration` scenario, seed 11, with the README's correlation times; its copy is that of
//! the 24 strips it reads.

use anyhow::{Context, Result, bail};
use las::{PointDataBuilder, Reader, Writer};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// The strip scenario (see the module docs).
const SCENARIO: &str = include_str!("../scenarios/strip.toml");
/// The baseline's chunk, as in las-rs's `convert_streaming` example and lidarqa's default.
const COPY_CHUNK: u64 = 500_000;
/// Pulses of the full run (the README's table).
const FULL_POINTS: u64 = 10_000_000;
/// The rows `--only` may name.
const ALL_ROWS: [&str; 5] = ["simulate", "tpu", "correct", "conic", "calibrate"];
/// The rows of the default run.
const DEFAULT_ROWS: [&str; 4] = ["simulate", "tpu", "correct", "conic"];
/// The calibration row's bars: wall seconds and peak MB.
const CALIBRATE_BAR: (f64, f64) = (30.0, 1024.0);

struct Args {
    points: u64,
    /// The rows to run (see the module docs).
    only: Vec<String>,
    dir: Option<PathBuf>,
    lidarqa: PathBuf,
    /// Runs of every row; each row shows its median (by ratio) and the range.
    repeat: usize,
}

fn parse_args() -> Result<Args> {
    let exe = std::env::current_exe()?;
    let mut args = Args {
        points: FULL_POINTS,
        only: DEFAULT_ROWS.iter().map(|r| r.to_string()).collect(),
        dir: None,
        lidarqa: exe.with_file_name("lidarqa"),
        repeat: 1,
    };
    let mut it = std::env::args().skip(1);
    while let Some(a) = it.next() {
        let mut value = || it.next().with_context(|| format!("{a} needs a value"));
        match a.as_str() {
            "--points" => {
                let v = value()?;
                args.points = v
                    .parse()
                    .ok()
                    .filter(|&n| n >= 10_000)
                    .with_context(|| format!("--points {v}: expected a count ≥ 10000"))?;
            }
            "--dir" => args.dir = Some(PathBuf::from(value()?)),
            "--repeat" => {
                let v = value()?;
                args.repeat = v
                    .parse()
                    .ok()
                    .filter(|n| (1..=20).contains(n))
                    .with_context(|| format!("--repeat {v}: expected 1 to 20"))?;
            }
            "--only" => {
                let v = value()?;
                args.only = v.split(',').map(|r| r.trim().to_string()).collect();
                if let Some(bad) = args.only.iter().find(|r| !ALL_ROWS.contains(&r.as_str())) {
                    bail!(
                        "--only {v}: unknown row {bad} (rows: {})",
                        ALL_ROWS.join(", ")
                    );
                }
            }
            "--calibrate" => args.only.push("calibrate".into()),
            "--lidarqa" => args.lidarqa = PathBuf::from(value()?),
            "-h" | "--help" => {
                println!(
                    "usage: lidarqa-bench [--points N] [--dir DIR] [--lidarqa PATH] [--only LIST] \
                     [--calibrate] [--repeat N]\n\
                     Times simulate, tpu (with/without incidence), correct and the conic TPU \
                     against a parallel LAZ copy of each one's output; --calibrate adds \
                     calibrate on the 24-strip calibration scenario; --only LIST (of {}) runs \
                     only those; --repeat N runs every row N times and shows each one's median \
                     and range.",
                    ALL_ROWS.join(", ")
                );
                std::process::exit(0);
            }
            other => bail!("unknown argument {other} (see --help)"),
        }
    }
    if !args.lidarqa.is_file() {
        bail!(
            "{}: no lidarqa binary (cargo build --release -p lidarqa, or --lidarqa PATH)",
            args.lidarqa.display()
        );
    }
    Ok(args)
}

/// One timed child: wall seconds, and CPU seconds (user + system) and peak resident memory in
/// MB when `/usr/bin/time` exists.
struct Run {
    seconds: f64,
    cpu_s: Option<f64>,
    peak_mb: Option<f64>,
}

fn run(dir: &Path, lidarqa: &Path, args: &[&str]) -> Result<Run> {
    let time = Path::new("/usr/bin/time");
    let rss = dir.join("rss.txt");
    let mut cmd = if time.is_file() {
        let mut c = Command::new(time);
        c.arg("-f").arg("%M %U %S").arg("-o").arg(&rss).arg(lidarqa);
        c
    } else {
        Command::new(lidarqa)
    };
    cmd.args(args);
    let t = Instant::now();
    let out = cmd
        .output()
        .with_context(|| format!("running {}", lidarqa.display()))?;
    let seconds = t.elapsed().as_secs_f64();
    if !out.status.success() {
        bail!(
            "lidarqa {} failed: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    let fields: Vec<f64> = std::fs::read_to_string(&rss)
        .ok()
        .and_then(|s| {
            let line = s.lines().last()?.to_string();
            line.split_whitespace().map(|v| v.parse().ok()).collect()
        })
        .unwrap_or_default();
    let _ = std::fs::remove_file(&rss);
    Ok(Run {
        seconds,
        cpu_s: (fields.len() == 3).then(|| fields[1] + fields[2]),
        peak_mb: fields.first().map(|kb| kb / 1024.0),
    })
}

/// This process's CPU seconds so far (user + system, /proc/self/stat, 100 ticks a second).
fn own_cpu_s() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the command name, which is in parentheses and may hold spaces.
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

/// The baseline: las-rs's streaming copy of `input` to `output`.
fn laz_copy(input: &Path, output: &Path) -> Result<CopyRun> {
    let cpu0 = own_cpu_s();
    let t = Instant::now();
    let mut reader =
        Reader::from_path(input).with_context(|| format!("{}: cannot read", input.display()))?;
    let header = reader.header().clone();
    let mut data = PointDataBuilder::new().for_header(&header).build();
    let mut writer = Writer::from_path(output, header)?;
    let mut n = 0;
    loop {
        let k = reader.fill_points(COPY_CHUNK, &mut data)?;
        if k == 0 {
            break;
        }
        n += k;
        writer.write_points(&data)?;
    }
    writer.close()?;
    let seconds = t.elapsed().as_secs_f64();
    let cpu_s = own_cpu_s().zip(cpu0).map(|(b, a)| b - a);
    std::fs::remove_file(output)?;
    Ok(CopyRun {
        seconds,
        cpu_s,
        points: n,
    })
}

/// The baseline's wall and CPU seconds, and the points it copied.
#[derive(Default)]
struct CopyRun {
    seconds: f64,
    cpu_s: Option<f64>,
    points: u64,
}

/// Copies every LAZ in `dir` (the outputs of a tile run): the totals.
fn copy_dir(dir: &Path, scratch: &Path) -> Result<CopyRun> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "laz"))
        .collect();
    files.sort();
    let mut total = CopyRun {
        cpu_s: Some(0.0),
        ..CopyRun::default()
    };
    for f in files {
        let c = laz_copy(&f, scratch)?;
        total.seconds += c.seconds;
        total.cpu_s = total.cpu_s.zip(c.cpu_s).map(|(a, b)| a + b);
        total.points += c.points;
    }
    Ok(total)
}

/// The scenario cut to `points` pulses: the line keeps its start, speed and rate.
fn scenario(points: u64) -> Result<String> {
    let mut t: toml::Table = SCENARIO.parse()?;
    let rate = t["scanner"]["pulse_rate_hz"]
        .as_float()
        .context("pulse_rate_hz")?;
    let line = t["lines"]
        .as_array_mut()
        .and_then(|l| l.first_mut())
        .and_then(|l| l.as_table_mut())
        .context("[[lines]]")?;
    let speed = line["speed_m_per_s"].as_float().context("speed_m_per_s")?;
    let x0 = line["start_m"][0].as_float().context("start_m")?;
    let y0 = line["start_m"][1].as_float().context("start_m")?;
    let length_m = points as f64 / rate * speed;
    line.insert(
        "end_m".into(),
        toml::Value::Array(vec![(x0 + length_m).into(), y0.into()]),
    );
    Ok(toml::to_string(&t)?)
}

struct Row {
    what: &'static str,
    command: Run,
    copy: CopyRun,
    /// The bar on the ratio to the LAZ copy; `None` for a row with an absolute bar instead (the
    /// calibration row).
    bar: Option<f64>,
}

/// Runs `[command, input, trajectory, sensor]` with `extra` flags writing into the directory
/// `out`, copies what it wrote, and removes it.
fn measure_dir(
    dir: &Path,
    bin: &Path,
    (what, bar): (&'static str, Option<f64>),
    [command, input, trajectory, sensor]: [&str; 4],
    extra: &[&str],
    out: &Path,
) -> Result<Row> {
    let mut args = vec![
        command,
        input,
        "--trajectory",
        trajectory,
        "--sensor",
        sensor,
        "-o",
        s(out),
    ];
    args.extend(extra);
    let command = run(dir, bin, &args)?;
    let copy = copy_dir(out, &dir.join("copy.laz"))?;
    std::fs::remove_dir_all(out)?;
    Ok(Row {
        what,
        command,
        copy,
        bar,
    })
}

fn load() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "?".into())
}

fn s(p: &Path) -> &str {
    p.to_str().expect("temporary paths are UTF-8")
}

fn main() -> Result<()> {
    let args = parse_args()?;
    let temp = tempfile::tempdir()?;
    let dir = args
        .dir
        .clone()
        .unwrap_or_else(|| temp.path().to_path_buf());
    std::fs::create_dir_all(&dir)?;
    let bin = &args.lidarqa;
    let scratch = dir.join("copy.laz");
    println!(
        "lidarqa-bench: {} pulses, {} threads, load average {} (1/5/15 min)",
        args.points,
        std::thread::available_parallelism().map_or(0, |n| n.get()),
        load()
    );
    // Each row's median over the repeats (by ratio), with the range.
    let runs = (0..args.repeat)
        .map(|_| measure_all(&args, &dir, bin, &scratch))
        .collect::<Result<Vec<_>>>()?;
    let median_of = |rows: Vec<(Row, f64)>| -> (Row, f64, f64, f64) {
        let mut rows = rows;
        rows.sort_by(|a, b| a.1.total_cmp(&b.1));
        let (lo, hi) = (rows[0].1, rows[rows.len() - 1].1);
        let (row, ratio) = rows.swap_remove(rows.len() / 2);
        (row, ratio, lo, hi)
    };
    let mut columns: Vec<Vec<(Row, f64)>> = Vec::new();
    let mut calibrations: Vec<(Row, f64)> = Vec::new();
    for (rows, calibration) in runs {
        for (i, r) in rows.into_iter().enumerate() {
            let ratio = r.copy.seconds / r.command.seconds;
            if columns.len() <= i {
                columns.push(Vec::new());
            }
            columns[i].push((r, ratio));
        }
        // The calibration row's median is by wall time, its bar.
        calibrations.extend(calibration.map(|r| {
            let seconds = r.command.seconds;
            (r, seconds)
        }));
    }
    let rows: Vec<(Row, f64, f64, f64)> = columns.into_iter().map(median_of).collect();
    let calibration_row = (!calibrations.is_empty()).then(|| median_of(calibrations).0);
    let range = |lo: f64, hi: f64| {
        if args.repeat > 1 {
            format!(" ({lo:.2}–{hi:.2} over {})", args.repeat)
        } else {
            String::new()
        }
    };

    println!();
    println!(
        "| command | points | command s | copy s | ratio | bar | command CPU s | copy CPU s | peak MB |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    let secs = |v: Option<f64>| v.map_or("?".into(), |v| format!("{v:.2}"));
    for (r, ratio, lo, hi) in &rows {
        let ratio = *ratio;
        println!(
            "| {} | {} | {:.2} | {:.2} | {:.2}{} | {} | {} | {} | {} |",
            r.what,
            r.copy.points,
            r.command.seconds,
            r.copy.seconds,
            ratio,
            range(*lo, *hi),
            r.bar.map_or("none".into(), |bar| format!(
                "≥ {bar} {}",
                if ratio >= bar { "✓" } else { "✗" }
            )),
            secs(r.command.cpu_s),
            secs(r.copy.cpu_s),
            r.command.peak_mb.map_or("?".into(), |m| format!("{m:.0}")),
        );
    }
    if let Some(r) = calibration_row {
        let (seconds, mb) = CALIBRATE_BAR;
        let peak = r.command.peak_mb;
        let met = r.command.seconds <= seconds && peak.is_some_and(|m| m <= mb);
        println!(
            "\n| {} | {} | {:.2} | {:.2} | {:.2} | ≤ {seconds} s, ≤ {mb} MB {} | {} | {} | {} |",
            r.what,
            r.copy.points,
            r.command.seconds,
            r.copy.seconds,
            r.copy.seconds / r.command.seconds,
            if met { "✓" } else { "✗" },
            secs(r.command.cpu_s),
            secs(r.copy.cpu_s),
            peak.map_or("?".into(), |m| format!("{m:.0}")),
        );
    }
    println!("\nload average at the end: {}", load());
    Ok(())
}

/// One pass over the rows `args.only` names: their runs, and the calibration row's.
fn measure_all(
    args: &Args,
    dir: &Path,
    bin: &Path,
    scratch: &Path,
) -> Result<(Vec<Row>, Option<Row>)> {
    let mut rows = Vec::new();

    let wants = |row: &str| args.only.iter().any(|r| r == row);
    if ["simulate", "tpu", "correct"].into_iter().any(wants) {
        let scen = dir.join("strip.toml");
        std::fs::write(&scen, scenario(args.points)?)?;
        let sim = dir.join("sim");
        let command = run(
            dir,
            bin,
            &["simulate", "--scenario", s(&scen), "-o", s(&sim)],
        )?;
        let strip = sim.join("strip_001.laz");
        if wants("simulate") {
            let copy = laz_copy(&strip, scratch)?;
            rows.push(Row {
                what: "simulate",
                command,
                copy,
                bar: Some(0.7),
            });
        }

        // `simulate` writes the nominal sensor without the beam divergence the scene was traced
        // with: the incidence run gets the scenario's value added, the other has none.
        let plain = sim.join("sensor.toml");
        let sensor = dir.join("sensor-incidence.toml");
        let text = std::fs::read_to_string(&plain)?;
        if text.contains("beam_divergence_mrad") {
            bail!("{}: expected no beam_divergence_mrad", plain.display());
        }
        let divergence = SCENARIO
            .parse::<toml::Table>()?
            .get("scanner")
            .and_then(|s| s.get("beam_divergence_mrad"))
            .and_then(toml::Value::as_float)
            .context("the scenario's [scanner] beam_divergence_mrad")?;
        let with = text.replacen(
            "[scanner]\n",
            &format!("[scanner]\nbeam_divergence_mrad = {divergence}\n"),
            1,
        );
        if with == text {
            bail!("{}: no [scanner] table", plain.display());
        }
        std::fs::write(&sensor, with)?;
        let sbet = sim.join("sbet.out");
        let tpu_runs = [
            ("tpu (incidence term)", &sensor, Some(0.7)),
            ("tpu (no incidence term)", &plain, Some(0.7)),
        ];
        for (what, sensor, bar) in tpu_runs.into_iter().filter(|_| wants("tpu")) {
            let out = dir.join("tpu.laz");
            let cmd = [
                "tpu",
                s(&strip),
                "--trajectory",
                s(&sbet),
                "--sensor",
                s(sensor),
                "-o",
                s(&out),
            ];
            let command = run(dir, bin, &cmd)?;
            let copy = laz_copy(&out, scratch)?;
            rows.push(Row {
                what,
                command,
                copy,
                bar,
            });
            std::fs::remove_file(&out)?;
        }

        // The scenario's injected mounting errors, as a calibration would return them.
        let cal = dir.join("calibration.json");
        std::fs::write(
            &cal,
            r#"{"parameters": {"lever_x_m": 0.05, "lever_y_m": -0.03, "lever_z_m": 0.02,
    "boresight_roll_deg": 0.05, "boresight_pitch_deg": -0.03, "boresight_yaw_deg": 0.04}}"#,
        )?;
        let corrected = dir.join("corrected");
        let calibration = ["--calibration", s(&cal)];
        if wants("correct") {
            rows.push(measure_dir(
                dir,
                bin,
                ("correct", Some(0.8)),
                ["correct", s(&strip), s(&sbet), s(&sensor)],
                &calibration,
                &corrected,
            )?);
        }
    }

    if wants("conic") {
        let bathy = dir.join("bathymetry");
        run(
            dir,
            bin,
            &["simulate", "--scenario", "bathymetry", "-o", s(&bathy)],
        )?;
        let (bathy_sbet, bathy_sensor) = (bathy.join("sbet.out"), bathy.join("sensor.toml"));
        rows.push(measure_dir(
            dir,
            bin,
            ("tpu, conic (bathymetry scenario)", Some(0.7)),
            ["tpu", s(&bathy), s(&bathy_sbet), s(&bathy_sensor)],
            &[],
            &dir.join("bathymetry-tpu"),
        )?);
    }
    let calibration_row = if wants("calibrate") {
        Some(measure_calibrate(dir, bin)?)
    } else {
        None
    };
    Ok((rows, calibration_row))
}

/// The calibration row: simulates the `calibration` scenario (seed 11, not timed), then times
/// `calibrate --auto-ties --control` on its 24 strips and copies the strips as the baseline.
fn measure_calibrate(dir: &Path, bin: &Path) -> Result<Row> {
    let sim = dir.join("calibration");
    run(
        dir,
        bin,
        &[
            "simulate",
            "--scenario",
            "calibration",
            "--seed",
            "11",
            "-o",
            s(&sim),
        ],
    )?;
    let mut strips: Vec<PathBuf> = std::fs::read_dir(&sim)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "laz"))
        .collect();
    strips.sort();
    let out = dir.join("calibration-out");
    std::fs::create_dir_all(&out)?;
    let (sbet, sensor, control, json) = (
        sim.join("sbet.out"),
        sim.join("sensor.toml"),
        sim.join("control.csv"),
        out.join("calibration.json"),
    );
    let mut args = vec!["calibrate"];
    args.extend(strips.iter().map(|p| s(p)));
    args.extend([
        "--trajectory",
        s(&sbet),
        "--sensor",
        s(&sensor),
        "--auto-ties",
        "--control",
        s(&control),
        "--gnss-correlation-s",
        "200",
        "--attitude-correlation-s",
        "30",
        "-o",
        s(&json),
    ]);
    let command = run(dir, bin, &args)?;
    let copy = copy_dir(&sim, &dir.join("copy.laz"))?;
    std::fs::remove_dir_all(&sim)?;
    std::fs::remove_dir_all(&out)?;
    Ok(Row {
        what: "calibrate (24 strips, auto ties, control)",
        command,
        copy,
        bar: None,
    })
}
