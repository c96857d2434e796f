//! The seed papers' published numbers, reproduced (with SPEC §3's documented exceptions).

use lidarqa_model::Source;
use lidarqa_tpu::{Evaluation, GeometryFacts, Preset, Sweep, evaluate, evaluate_monte_carlo};

fn term(e: &Evaluation, s: Source) -> &lidarqa_tpu::SourceTerm {
    e.sources.iter().find(|t| t.source == s).unwrap()
}

/// |a − b| ≤ tol, with a message.
fn close(what: &str, got: f64, want: f64, tol: f64) {
    assert!(
        (got - want).abs() <= tol,
        "{what}: got {got:.6}, want {want:.6} ± {tol}"
    );
}

#[test]
fn zhang_2018_table1_budget_at_30_deg_scan_80_m_below() {
    let e = evaluate(
        &Preset::Zhang2018.sensor(),
        &Preset::Zhang2018.geometry(),
        None,
    )
    .unwrap();
    close("footprint north", e.footprint.north, 0.0, 1e-9);
    close("footprint east", e.footprint.east, 46.188, 5e-4);
    close("footprint up", e.footprint.up, -80.0, 1e-9);
    match e.geometry {
        GeometryFacts::Linear { range_m, .. } => close("range", range_m, 92.376, 5e-4),
        _ => panic!("linear expected"),
    }
    // Per-source values (cm) from the closed forms: boresight pitch ρcosθ·σ = 80 m · 0.008° north;
    // boresight roll: ρcosθ·σ east and ρsinθ·σ up; range: sinθ·σ east, cosθ·σ up.
    let bp = term(&e, Source::BoresightPitch);
    close("boresight_pitch north", bp.effect.north, 0.01117, 5e-6);
    close("boresight_pitch east", bp.effect.east, 0.0, 1e-12);
    let br = term(&e, Source::BoresightRoll);
    close("boresight_roll east", br.effect.east, 0.01117, 5e-6);
    close("boresight_roll up", br.effect.up, 0.00645, 5e-6);
    let r = term(&e, Source::Range);
    close("range east", r.effect.east, 0.0025, 1e-9);
    close("range up", r.effect.up, 0.004330, 1e-6);
    close("boresight_pitch sigma rad", bp.sigma_si, 1.396e-4, 1e-7);
    // Totals (SPEC §3): 0.0527 / 0.0519 / 0.1004 m. The paper's 0.133 / 0.147 / 0.119 m cannot come
    // from its Table 1 (see the lidarqa-tpu crate docs).
    close("total north", e.total.north, 0.0527, 5e-5);
    close("total east", e.total.east, 0.0519, 5e-5);
    close("total up", e.total.up, 0.1004, 5e-5);
    close("total horizontal", e.total.horizontal, 0.0740, 5e-5);
    // SPEC §6's example shows 0.1248, which is √(0.0740² + 0.1004²) of the rounded parts.
    close("total three_d", e.total.three_d, 0.12474, 1e-5);
}

/// The non-GNSS part of Zhang et al.'s (2018) budget stays below ~3 cm anywhere in the paper's
/// envelope, so its published 0.133 / 0.147 / 0.119 m are out of reach of its own Table 1.
#[test]
fn zhang_2018_published_sigmas_are_out_of_reach() {
    let mut sensor = Preset::Zhang2018.sensor();
    for s in [Source::GnssNorth, Source::GnssEast, Source::GnssUp] {
        sensor.sigma.set(s, 0.0).unwrap();
    }
    let mut worst: f64 = 0.0;
    for h in [-4.0f64, 0.0, 4.0] {
        for p in [-3.0f64, 0.0, 3.0] {
            for r in [-3.0f64, 0.0, 3.0] {
                for theta in [-30.0f64, 0.0, 30.0] {
                    let g = lidarqa_tpu::Geometry::Linear {
                        attitude: lidarqa_model::Attitude::from_degrees(r, p, h),
                        scan_angle_rad: theta.to_radians(),
                        range: lidarqa_tpu::LinearRange::Height(80.0),
                    };
                    let e = evaluate(&sensor, &g, None).unwrap();
                    worst = worst.max(e.total.north.max(e.total.east).max(e.total.up));
                }
            }
        }
    }
    assert!(worst < 0.03, "non-GNSS part {worst} m");
    // Even with GNSS added in full, each axis is far below the published figures.
    let e = evaluate(
        &Preset::Zhang2018.sensor(),
        &Preset::Zhang2018.geometry(),
        None,
    )
    .unwrap();
    assert!(e.total.north < 0.133 / 2.0 && e.total.east < 0.147 / 2.0 && e.total.up < 0.119);
}

/// Li et al. (2016) Table 4 (cm), columns σxy, σz, σxyz, at azimuth 0.
const TABLE4: [(Source, f64, f64, f64); 18] = [
    (Source::PrismSlope, 2.37, 0.84, 2.51),
    (Source::PrismX, 0.24, 0.0, 0.24),
    (Source::PrismY, 0.42, 0.15, 0.44),
    (Source::PrismZ, 1.39, 0.0, 1.39),
    (Source::ScanAzimuth, 1.39, 0.0, 1.39),
    (Source::EmitterZenith, 3.39, 2.00, 3.94),
    (Source::EmitterAzimuth, 0.0, 0.0, 0.0),
    (Source::TimeAir, 0.51, 1.41, 1.50),
    (Source::TimeWater, 2.55, 9.67, 10.00),
    (Source::BoresightRoll, 2.20, 0.0, 2.20),
    (Source::BoresightPitch, 2.20, 0.78, 2.33),
    (Source::BoresightYaw, 2.30, 0.0, 2.30),
    (Source::Roll, 1.96, 0.0, 1.96),
    (Source::Pitch, 1.96, 0.69, 2.08),
    (Source::Heading, 1.39, 0.0, 1.39),
    (Source::GnssNorth, 5.0, 0.0, 5.0),
    (Source::GnssEast, 5.0, 0.0, 5.0),
    (Source::GnssUp, 0.0, 7.5, 7.5),
];

#[test]
fn li_2016_table4_at_azimuth_0() {
    let e = evaluate(&Preset::Czmil.sensor(), &Preset::Czmil.geometry(), None).unwrap();
    match e.geometry {
        GeometryFacts::Conic {
            prism_slope_deg,
            exit_angle_deg,
            time_water_ns,
            ..
        } => {
            close("prism slope", prism_slope_deg, 39.16, 5e-3);
            close("exit angle", exit_angle_deg, 20.0, 1e-9);
            close("time water ns", time_water_ns, 459.1, 0.1);
        }
        _ => panic!("conic expected"),
    }
    for (source, xy, z, xyz) in TABLE4 {
        let t = term(&e, source);
        let cm = |v: f64| v * 100.0;
        let (mut want_xy, mut want_z, mut want_xyz) = (xy, z, xyz);
        match source {
            // No consistent geometry gives the paper's φls σz = 2.00 cm: with the emitter tilted by
            // 0.005° the in-air ray turns by ~1.1e-4 rad, which moves the footprint about 1.2 cm up at
            // this incidence (the horizontal 3.39 cm agrees). The paper's σxyz 3.94 follows from
            // its 2.00; ours is √(3.39² + 1.21²).
            Source::EmitterZenith => {
                want_z = 1.21;
                want_xyz = 3.60;
            }
            // 0.9 ns in water is ρ2 σ = c·0.9 ns / (2·1.33) = 10.14 cm, not the paper's 10.00 cm
            // (which implies σ = 0.888 ns); its split 2.55 / 9.67 scales the same way.
            Source::TimeWater => {
                want_xy = 2.61;
                want_z = 9.79;
                want_xyz = 10.14;
            }
            _ => {}
        }
        let tol = 0.01 + 1e-9;
        close(
            &format!("{source} σxy cm"),
            cm(t.effect.horizontal),
            want_xy,
            tol,
        );
        close(
            &format!("{source} σz cm"),
            cm(t.effect.vertical),
            want_z,
            tol,
        );
        close(
            &format!("{source} σxyz cm"),
            cm(t.effect.three_d),
            want_xyz,
            tol,
        );
    }
    // Totals of the paper: 10.13 (text) / 10.14 / 12.55 / 16.13 cm.
    close(
        "total horizontal cm",
        e.total.horizontal * 100.0,
        10.14,
        0.01,
    );
    close("total vertical cm", e.total.vertical * 100.0, 12.55, 0.01);
    close("total three_d cm", e.total.three_d * 100.0, 16.13, 0.01);
}

#[test]
fn li_2016_fig4_azimuth_sweep_is_180_deg_periodic_in_antiphase() {
    let sensor = Preset::Czmil.sensor();
    let sweep: Sweep = "azimuth=0:360:5".parse().unwrap();
    let base = Preset::Czmil.geometry();
    let (mut h, mut v) = (Vec::new(), Vec::new());
    for az in sweep.values() {
        let e = evaluate(&sensor, &sweep.apply(&base, az).unwrap(), None).unwrap();
        h.push(e.total.horizontal);
        v.push(e.total.vertical);
    }
    // Period 180° (36 steps of 5°).
    for i in 0..h.len() - 36 {
        close("horizontal periodic", h[i], h[i + 36], 1e-9);
        close("vertical periodic", v[i], v[i + 36], 1e-9);
    }
    // It does vary, and horizontal and vertical move in antiphase: the correlation of their
    // deviations over the sweep is close to −1.
    let span = |x: &[f64]| {
        x.iter().cloned().fold(f64::MIN, f64::max) - x.iter().cloned().fold(f64::MAX, f64::min)
    };
    assert!(
        span(&h) > 1e-4 && span(&v) > 1e-4,
        "{} {}",
        span(&h),
        span(&v)
    );
    let mean = |x: &[f64]| x.iter().sum::<f64>() / x.len() as f64;
    let (mh, mv) = (mean(&h), mean(&v));
    let cov: f64 = h.iter().zip(&v).map(|(a, b)| (a - mh) * (b - mv)).sum();
    let sh: f64 = h.iter().map(|a| (a - mh).powi(2)).sum::<f64>().sqrt();
    let sv: f64 = v.iter().map(|b| (b - mv).powi(2)).sum::<f64>().sqrt();
    let corr = cov / (sh * sv);
    assert!(corr < -0.95, "correlation {corr}");
}

#[test]
fn monte_carlo_agrees_with_linear_propagation_within_2_percent() {
    for preset in Preset::ALL {
        let sensor = preset.sensor();
        let g = preset.geometry();
        let lin = evaluate(&sensor, &g, None).unwrap().total;
        let mc = evaluate_monte_carlo(&sensor, &g, 100_000, 42).unwrap();
        for (axis, l, m) in [
            ("north", lin.north, mc.sigma.north),
            ("east", lin.east, mc.sigma.east),
            ("up", lin.up, mc.sigma.up),
        ] {
            let rel = (m / l - 1.0).abs();
            assert!(
                rel < 0.02,
                "{} {axis}: linear {l}, monte carlo {m}",
                preset.name()
            );
        }
    }
}
