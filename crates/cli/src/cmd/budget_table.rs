//! The text tables of `lidarqa budget` (presentation only; the numbers come from lidarqa-tpu).

use crate::format::{axes_cm, cm};
use lidarqa_model::Source;
use lidarqa_tpu::{Evaluation, GeometryFacts, MonteCarlo, SweepEvaluation};
use std::fmt::Write as _;

fn geometry_line(e: &Evaluation) -> String {
    match e.geometry {
        GeometryFacts::Linear {
            scan_angle_deg,
            range_m,
            height_m,
        } => {
            format!("scan angle {scan_angle_deg:.3}°, range {range_m:.3} m, height {height_m:.3} m")
        }
        GeometryFacts::Conic {
            azimuth_deg,
            prism_slope_deg,
            exit_angle_deg,
            water_angle_deg,
            range_air_m,
            range_water_m,
            time_air_ns,
            time_water_ns,
            ..
        } => format!(
            "azimuth {azimuth_deg:.3}°, prism slope {prism_slope_deg:.4}°, incidence {exit_angle_deg:.3}° → {water_angle_deg:.3}° in water\n          ρ1 {range_air_m:.3} m (Δt1 {time_air_ns:.3} ns), ρ2 {range_water_m:.3} m (Δt2 {time_water_ns:.3} ns)"
        ),
    }
}

/// Sources of bathymetric soundings only (water surface and refraction index).
const WATER_SURFACE_SOURCES: [Source; 4] = [
    Source::WaterSurfaceHeight,
    Source::WaterSurfaceSlopeNorth,
    Source::WaterSurfaceSlopeEast,
    Source::NWater,
];

/// Li et al. (2016), Table 4 layout: one row per source, cm, totals at the bottom, geometry on top.
pub fn table(label: &str, e: &Evaluation) -> String {
    let mut t = String::new();
    let _ = writeln!(
        t,
        "lidarqa budget: {} scanner{}, {label}",
        e.scanner,
        e.refraction
            .map(|r| format!(" ({r} refraction)"))
            .unwrap_or_default()
    );
    let _ = writeln!(t, "geometry: {}", geometry_line(e));
    let _ = writeln!(
        t,
        "footprint from GNSS/INS point: north {:.3} m, east {:.3} m, up {:.3} m",
        e.footprint.north, e.footprint.east, e.footprint.up
    );
    let _ = writeln!(t);
    // The water-surface sources (not in Li et al. 2016) are listed only when they have a σ, so the
    // czmil preset prints the rows of Li et al. (2016), Table 4 exactly; JSON lists every source.
    let rows: Vec<_> = e
        .sources
        .iter()
        .filter(|s| s.sigma_si > 0.0 || !WATER_SURFACE_SOURCES.contains(&s.source))
        .collect();
    let name_w = rows
        .iter()
        .map(|s| s.source.name().len() + 1)
        .max()
        .unwrap_or(0)
        .max(16);
    let _ = writeln!(
        t,
        "{:<name_w$}{:>12}{:>8}{:>8}{:>8}{:>8}{:>8}{:>8}",
        "source", "1σ", "north", "east", "up", "horiz", "vert", "3-D"
    );
    let _ = writeln!(t, "{:<w$}{:>48}", "", "(cm)", w = name_w + 12);
    for s in rows {
        let shown = s.sigma_si / s.source.unit().config_to_si();
        let unit = s.source.unit().config_suffix().trim_start_matches('_');
        let _ = writeln!(
            t,
            "{:<name_w$}{:>12}{}",
            s.source.name(),
            format!("{} {unit}", trim_number(shown)).trim_end(),
            axes_cm(&s.effect, 8),
        );
    }
    let x = e.total;
    let _ = writeln!(t, "{}", "-".repeat(name_w + 60));
    let _ = writeln!(t, "{:<w$}{}", "total", axes_cm(&x, 8), w = name_w + 12);
    if let (Some(b), Some(f)) = (e.bias, e.bias_first_order) {
        let _ = writeln!(t);
        let _ = writeln!(
            t,
            "{:<28}{:>8}{:>8}{:>8}{:>8}{:>8}",
            "bias (lidar − true, cm)", "north", "east", "up", "along", "across"
        );
        for (name, d) in [("exact", b), ("first order", f)] {
            let _ = writeln!(
                t,
                "{:<28}{}{}{}{}{}",
                name,
                cm(d.north, 8),
                cm(d.east, 8),
                cm(d.up, 8),
                cm(d.along_track, 8),
                cm(d.across_track, 8)
            );
        }
    }
    t
}

/// One row per value of the sweep: the total σ and, with `--bias`, the displacement, in cm.
pub fn sweep_table(label: &str, result: &SweepEvaluation) -> String {
    let mut t = String::new();
    let first = &result.points[0].evaluation;
    let _ = writeln!(
        t,
        "lidarqa budget sweep over {} ({}): {} scanner, {label}",
        result.sweep, result.unit, first.scanner
    );
    let has_bias = first.bias.is_some();
    let _ = write!(
        t,
        "{:>10}{:>8}{:>8}{:>8}{:>8}{:>8}{:>8}",
        result.unit, "north", "east", "up", "horiz", "vert", "3-D"
    );
    if has_bias {
        let _ = write!(t, "   bias{:>7}{:>8}{:>8}", "along", "across", "up");
    }
    let _ = writeln!(t, "   (σ and bias in cm)");
    for p in &result.points {
        let (at, e) = (p.at, &p.evaluation);
        let x = e.total;
        let _ = write!(t, "{:>10.3}{}", at, axes_cm(&x, 8),);
        if let Some(b) = e.bias {
            let _ = write!(
                t,
                "       {}{}{}",
                cm(b.along_track, 7),
                cm(b.across_track, 8),
                cm(b.up, 8)
            );
        }
        let _ = writeln!(t);
    }
    t
}

/// A σ in config units without float noise (0.0028, not 0.0027999999999999995).
fn trim_number(v: f64) -> String {
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s.is_empty() {
        "0".into()
    } else {
        s.to_string()
    }
}

/// The Monte Carlo σ as one more row under [`table`]'s totals.
pub fn monte_carlo_row(mc: &MonteCarlo) -> String {
    let s = mc.sigma;
    format!(
        "{:<28}{}\n",
        format!("monte carlo ({})", mc.samples),
        axes_cm(&s, 8),
    )
}
