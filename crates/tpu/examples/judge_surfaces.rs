//! Judges each point's neighbourhood as `lidarqa tpu` does for its incidence term, for
//! comparisons outside the pipeline (`docs/real-data/titan_normals.py`).
//!
//! `cargo run --release -p lidarqa-tpu --example judge_surfaces -- IN.csv OUT.csv [K]`: IN holds
//! `x,y,z` per line (metres, any Cartesian frame, no header); OUT gets `kind,nx,ny,nz` per point
//! (kind planar, planar_widened, linear, scattered or too_few; a zero normal without a plane).

use lidarqa_tpu::{Surface, judge_surfaces};
use std::fmt::Write as _;
use std::process::ExitCode;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(input), Some(output)) = (args.first(), args.get(1)) else {
        eprintln!("judge_surfaces: usage: judge_surfaces IN.csv OUT.csv [K]");
        return ExitCode::FAILURE;
    };
    match run(input, output, args.get(2).map(String::as_str)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("judge_surfaces: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(input: &str, output: &str, k: Option<&str>) -> Result<(), String> {
    let k: usize = k
        .unwrap_or("10")
        .parse()
        .map_err(|e| format!("bad K: {e}"))?;
    let text = std::fs::read_to_string(input).map_err(|e| format!("{input}: {e}"))?;
    let mut pts = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let v: Result<Vec<f64>, _> = line.split(',').map(|f| f.trim().parse::<f64>()).collect();
        match v {
            Ok(v) if v.len() == 3 => pts.push([v[0], v[1], v[2]]),
            _ => return Err(format!("{input}, line {}: expected x,y,z", i + 1)),
        }
    }
    // Offsets from the first point keep the scatter sums well conditioned.
    let o = pts.first().copied().unwrap_or([0.0; 3]);
    let rel: Vec<[f64; 3]> = pts
        .iter()
        .map(|p| [p[0] - o[0], p[1] - o[1], p[2] - o[2]])
        .collect();
    let mut out = String::new();
    for s in judge_surfaces(&rel, &rel, k) {
        let (kind, n) = match s {
            Surface::Planar(n) => ("planar", n),
            Surface::PlanarWidened(n) => ("planar_widened", n),
            Surface::Linear(_) => ("linear", Default::default()),
            Surface::Scattered => ("scattered", Default::default()),
            _ => ("too_few", Default::default()),
        };
        let _ = writeln!(out, "{kind},{},{},{}", n[0], n[1], n[2]);
    }
    std::fs::write(output, out).map_err(|e| format!("{output}: {e}"))
}
