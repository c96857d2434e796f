//! The text summary of `lidarqa calibrate` (presentation only; the numbers come from
//! lidarqa-calib).

use lidarqa_calib::{Calibration, Method, Param, TrajectorySigma};

/// The calibrated mounting, one row per parameter with its σ, prior σ and observability, then
/// the trajectory weighting, the dropped picks and the tie residuals before and after.
pub fn table(cal: &Calibration) -> String {
    let x = lidarqa_calib::mounting_to_vector(&cal.mounting);
    let mut s = format!(
        "method {}  iterations {}  ({})  sigma0 {:.4} m\n{:<22} {:>12} {:>12} {:>12}  observable\n",
        cal.method.name(),
        cal.iterations,
        cal.termination.name(),
        cal.sigma0_m,
        "parameter",
        "value",
        "sigma",
        "prior sigma"
    );
    for p in Param::ALL {
        let i = p.index();
        let sig = cal.sigma[i].map_or("-".to_string(), |v| format!("{:.5}", p.to_display(v)));
        let prior_sig =
            cal.prior_sigma[i].map_or("-".to_string(), |v| format!("{:.5}", p.to_display(v)));
        s += &format!(
            "{:<22} {:>12.5} {:>12} {:>12}  {}\n",
            p.key(),
            p.to_display(x[i]),
            sig,
            prior_sig,
            if cal.observable[i] {
                "yes".to_string()
            } else {
                format!("no: {}", cal.held_because[i])
            }
        );
    }
    if let Some(t) = &cal.trajectory_sigma {
        s += &format!(
            "sigma includes each strip's trajectory error (GNSS {:.3}/{:.3}/{:.3} m, roll/pitch/heading {:.4}/{:.4}/{:.4} deg, {}; {})\n",
            t.position_m[0],
            t.position_m[1],
            t.position_m[2],
            t.attitude_rad[0].to_degrees(),
            t.attitude_rad[1].to_degrees(),
            t.attitude_rad[2].to_degrees(),
            correlation_phrase(t),
            // The surface fit (method plane) stays unweighted; its σ propagate the error.
            if cal.method == Method::Vtpm {
                "the ties are weighted by it"
            } else {
                "propagated through the unweighted surface fit"
            },
        );
    }
    for d in &cal.dropped_picks {
        s += &format!(
            "dropped pick: tie {} in strip {}: {}\n",
            d.tie, d.strip, d.reason
        );
    }
    let ((h0, v0), (h1, v1)) = cal.tie_rms_m();
    s += &format!(
        "tie residual RMS: horizontal {:.3} -> {:.3} m, vertical {:.3} -> {:.3} m ({} ties)\n",
        h0,
        h1,
        v0,
        v1,
        cal.ties.len()
    );
    s
}

/// How the trajectory errors are taken to vary over a strip, for the summary.
fn correlation_phrase(t: &TrajectorySigma) -> String {
    let one = |what: &str, tau: Option<f64>| match tau {
        Some(v) => format!("{what} correlated over {v} s"),
        None => format!("{what} constant over each strip"),
    };
    format!(
        "{}, {}",
        one("GNSS", t.position_correlation_s),
        one("attitude", t.attitude_correlation_s)
    )
}
