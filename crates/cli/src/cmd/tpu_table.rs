//! The text summary of `lidarqa tpu` and `lidarqa collect` (presentation only; the numbers are
//! lidarqa-products' [`TpuSummaryDocument`]).

use crate::format::cm;
use lidarqa_products::TpuSummaryDocument;
use std::fmt::Write as _;

/// The survey summary as text.
pub(crate) fn table(s: &TpuSummaryDocument) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{} tile(s), {} scanner: {} points read, {} written, {} skipped",
        s.tiles.len(),
        s.scanner,
        s.points_read,
        s.points_written,
        s.skipped.values().sum::<u64>()
    );
    for (reason, n) in s.skipped.iter().filter(|(_, n)| **n > 0) {
        let _ = writeln!(out, "  skipped {reason}: {n}");
    }
    let _ = writeln!(
        out,
        "\n{:<12} {:>9} {:>9} {:>9} {:>9} {:>9}   (cm)",
        "sigma", "min", "median", "p95", "max", "mean"
    );
    for (name, st) in &s.sigma {
        match st {
            Some(st) => {
                let _ = writeln!(
                    out,
                    "{name:<12} {} {} {} {} {}",
                    cm(st.min, 9),
                    cm(st.median, 9),
                    cm(st.p95, 9),
                    cm(st.max, 9),
                    cm(st.mean, 9)
                );
            }
            None => {
                let _ = writeln!(out, "{name:<12} {:>9}", "-");
            }
        }
    }
    let _ = writeln!(out, "\nshare of variance (mean over points):");
    let mut shares: Vec<_> = s.source_share.iter().filter(|(_, v)| **v > 0.0).collect();
    shares.sort_by(|a, b| b.1.total_cmp(a.1));
    for (name, v) in shares {
        let _ = writeln!(out, "  {name:<26} {:>6.1} %", v * 100.0);
    }
    let inc = &s.incidence;
    if inc.total() > 0 {
        let _ = writeln!(
            out,
            "\nincidence term: {} normals from the file, {} planar neighbourhoods ({} of them only \
             when widened), {} across a scan line; the prior (no surface measured): {} planes \
             containing the beam, {} scattered; left out: {} too few points, {} invalid file \
             normals",
            inc.file_normals,
            inc.planar,
            inc.planar_widened,
            inc.linear,
            inc.beam_in_plane,
            inc.scattered,
            inc.too_few_points,
            inc.invalid_file_normals
        );
    }
    if let Some(c) = &s.scan_angle_check {
        let _ = writeln!(
            out,
            "\nscan angle, recovered - LAS field: RMS {:.4}°, max {:.4}° (LAS step {}°, max beyond half a step {:.4}°)",
            c.rms_deg, c.max_deg, c.las_step_deg, c.max_beyond_las_step_deg
        );
    }
    if let Some(q) = &s.recovery_residual_m {
        let _ = writeln!(
            out,
            "recovery residual ({}): RMS {:.4} m, max {:.4} m",
            q.kind, q.rms, q.max_abs
        );
    }
    if let Some(iho) = &s.iho_s44 {
        let _ = writeln!(
            out,
            "
IHO S-44 Ed. 6: {} soundings ({} under their own surface return, {} under a modelled surface); % meeting THU and TVU at 95 %",
            iho.soundings, iho.surface_from_pulse, iho.surface_modelled
        );
        let orders = ["exclusive", "special", "1a", "1b", "2"];
        let _ = write!(out, "{:<14}{:>10}", "depth (m)", "soundings");
        for o in orders {
            let _ = write!(out, "{o:>11}");
        }
        let _ = writeln!(out);
        for b in &iho.bands {
            let to = if b.depth_m[1] < 0.0 {
                "".to_string()
            } else {
                format!("{}", b.depth_m[1])
            };
            let _ = write!(
                out,
                "{:<14}{:>10}",
                format!("{}–{to}", b.depth_m[0]),
                b.soundings
            );
            for o in orders {
                let _ = write!(out, "{:>10.1}%", b.percent_meeting[o]);
            }
            let _ = writeln!(out);
        }
        let _ = write!(out, "{:<14}{:>10}", "all", iho.soundings);
        for o in orders {
            let _ = write!(out, "{:>10.1}%", iho.orders[o].percent_meeting);
        }
        let _ = writeln!(out);
    }
    out
}
