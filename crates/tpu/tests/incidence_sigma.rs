//! Is the incidence term's σ honest where lidarqa judges the surfaces itself? An independent
//! generator (`tests/independent/incidence_sigma.py`, numpy only) casts the pulses of a linear
//! scanner 600 m up onto a 25° slope, gable roofs (35°) on flat ground and tree crowns whose
//! leaves face the beam with probability |cos α|, in one pass and in two crossing passes, and
//! draws each return's footprint error from its *true* incidence (64 draws, plus an independent
//! 2 cm vertical). Here each scene's returns are judged as `lidarqa tpu` judges them
//! ([`judge_surfaces`] with 10 neighbours, then [`judged_incidence`]: the plane, the normal
//! across a line, or the prior where the plane contains the beam or the points are scattered)
//! and σ_up = √(0.02² + (ρ·γ/2·tan α·|u_up|)²) is set against the drawn vertical error: per
//! surface class and pass set, RMS(error/σ) must lie within 0.8–1.25. The footprint error's
//! scale (γ/2, the term's) is the same on both sides; what is checked is the angle lidarqa
//! finds for it. Runs when `LIDARQA_PYTHON` names a Python with numpy.

use lidarqa_tpu::{
    IncidenceClass, MAX_INCIDENCE_RAD, SHARE_STRIDE, judge_surfaces, judge_surfaces_shared,
    judged_incidence,
};
use nalgebra::{Matrix3, Vector3};
use std::collections::BTreeMap;

const GAMMA_RAD: f64 = 0.5e-3;
const SIGMA0_M: f64 = 0.02;

struct Return {
    p: [f64; 3],
    beam_enu: Vector3<f64>,
    range_m: f64,
    scene: String,
    mode: String,
    kind: String,
    mse_up_m2: f64,
}

fn generated() -> Option<Vec<Return>> {
    let python = lidarqa_testkit::python("the incidence sigma's independent generator (numpy)")?;
    let dir = std::env::temp_dir().join(format!("lidarqa-incidence-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let csv = dir.join("returns.csv");
    let script = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/independent/incidence_sigma.py"
    );
    let o = std::process::Command::new(python)
        .arg(script)
        .arg(&csv)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&csv).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    Some(
        text.lines()
            .skip(1)
            .map(|l| {
                let f: Vec<&str> = l.split(',').collect();
                let x = |i: usize| f[i].parse::<f64>().unwrap();
                Return {
                    p: [x(0), x(1), x(2)],
                    beam_enu: Vector3::new(x(3), x(4), x(5)),
                    range_m: x(6),
                    scene: f[7].to_string(),
                    mode: f[8].to_string(),
                    kind: f[9].to_string(),
                    mse_up_m2: x(10),
                }
            })
            .collect(),
    )
}

/// tan of the angle whose |cos| is `c`, capped at 85° as the term caps it.
fn tan_capped(c: f64) -> f64 {
    c.clamp(0.0, 1.0).acos().min(MAX_INCIDENCE_RAD).tan()
}

#[derive(Default, Debug)]
struct Tally {
    n: usize,
    sum_ratio2: f64,
    classes: BTreeMap<u8, usize>,
}

#[test]
fn the_incidence_sigma_with_judged_surfaces_matches_the_drawn_error_per_surface_class() {
    let Some(returns) = generated() else {
        return;
    };
    // East, north, up → north, east, down.
    let to_ned = Matrix3::new(0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0);
    let mut groups: BTreeMap<(String, String, String), Vec<&Return>> = BTreeMap::new();
    for r in &returns {
        groups
            .entry((r.scene.clone(), r.mode.clone(), String::new()))
            .or_default()
            .push(r);
    }
    // As `lidarqa tpu` judges (one judgement shared along the scan, see `SHARE_STRIDE`), and
    // every point on its own neighbourhood: both are held to the bar.
    for stride in [SHARE_STRIDE, 1] {
        check(&groups, &to_ned, stride);
    }
}

type Groups<'a> = BTreeMap<(String, String, String), Vec<&'a Return>>;

fn check(groups: &Groups, to_ned: &Matrix3<f64>, stride: usize) {
    let to_ned = *to_ned;
    let mut tally: BTreeMap<(String, String), Tally> = BTreeMap::new();
    for ((_, mode, _), rs) in groups {
        let o = rs[0].p;
        let rel: Vec<[f64; 3]> = rs
            .iter()
            .map(|r| [r.p[0] - o[0], r.p[1] - o[1], r.p[2] - o[2]])
            .collect();
        let judged = if stride == SHARE_STRIDE {
            judge_surfaces(&rel, &rel, 10)
        } else {
            judge_surfaces_shared(&rel, &rel, 10, stride)
        };
        for (r, s) in rs.iter().zip(&judged) {
            let beam_ned = to_ned * r.beam_enu;
            let (class, cos) = judged_incidence(s, &to_ned, &beam_ned);
            let s_inc = cos.map_or(0.0, |c| r.range_m * GAMMA_RAD / 2.0 * tan_capped(c));
            let sigma2 = SIGMA0_M * SIGMA0_M + (s_inc * r.beam_enu.z.abs()).powi(2);
            let t = tally.entry((r.kind.clone(), mode.clone())).or_default();
            t.n += 1;
            t.sum_ratio2 += r.mse_up_m2 / sigma2;
            *t.classes.entry(class as u8).or_default() += 1;
        }
    }
    let mut report = String::new();
    let mut bad = Vec::new();
    for ((kind, mode), t) in &tally {
        let rms = (t.sum_ratio2 / t.n as f64).sqrt();
        report += &format!(
            "{kind:<11} {mode:<5} n {:>6}  RMS(error/σ) {rms:.3}  classes {:?}\n",
            t.n, t.classes
        );
        // Walls are a few dozen returns at the eaves: reported, not held to the bar.
        if kind != "wall" && !(0.8..=1.25).contains(&rms) {
            bad.push(format!("{kind} {mode}: {rms:.3}"));
        }
    }
    println!("judgement shared by up to {stride} points in a row:\n{report}");
    assert!(
        bad.is_empty(),
        "stride {stride}: outside 0.8-1.25: {bad:?}\n{report}"
    );
    // Every class the generator draws is there in both pass sets.
    for kind in ["slope", "roof", "ground", "vegetation"] {
        for mode in ["one", "multi"] {
            let n = tally
                .get(&(kind.to_string(), mode.to_string()))
                .map_or(0, |t| t.n);
            assert!(n > 500, "{kind} {mode}: {n} returns");
        }
    }
    // The prior is what carries the vegetation: most of its returns are scattered or lie in
    // one scan plane.
    let veg = &tally[&("vegetation".to_string(), "one".to_string())];
    let prior: usize = [IncidenceClass::BeamInPlane, IncidenceClass::Scattered]
        .iter()
        .map(|c| veg.classes.get(&(*c as u8)).copied().unwrap_or(0))
        .sum();
    assert!(prior * 2 > veg.n, "{veg:?}");
}
