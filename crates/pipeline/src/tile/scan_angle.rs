//! The scan angle recovered from the points against the file's own field: the warnings.

use lidarqa_model::Source;
use std::path::Path;

/// The warning when the scan angle recovered from the points and the trajectory disagrees with
/// the file's scan-angle field beyond what the field's step and the angles' σ explain: RMS of
/// the difference above the step plus 3 σ of √(σ_scan² + σ_roll² + σ_boresight_roll²).
/// Likely causes: the trajectory is not the one the points were georeferenced with (or lacks
/// roll), a mounting (boresight, lever arm) far from the one used, or a scanner whose field is
/// not an angle in the scan plane.
pub(crate) fn scan_angle_disagreement(
    input: &Path,
    check: &crate::summary::AngleCheck,
    sensor: &lidarqa_model::Sensor,
    format: lidarqa_io::TrajectoryFormat,
) -> Vec<lidarqa_model::Warning> {
    if check.n == 0 {
        return Vec::new();
    }
    let rms_deg = (check.sum_sq_deg2 / check.n as f64).sqrt();
    let sigma_deg = [Source::ScanAngle, Source::Roll, Source::BoresightRoll]
        .iter()
        .map(|s| sensor.sigma.get(*s).powi(2))
        .sum::<f64>()
        .sqrt()
        .to_degrees();
    // Capped: σ of tens of degrees (a unit slip in the sensor file) must not silence a
    // disagreement of 160–180°, which no sensor noise explains.
    let bound_deg = (check.step_deg + 3.0 * sigma_deg).min(SCAN_ANGLE_MAX_BOUND_DEG);
    // Beyond the RMS: single points whose field disagrees by tens of degrees (up to 180°: a
    // field of the wrong sign convention, a flipped or corrupted record) are outliers the RMS of
    // a large tile hides; any disagreement past this many degrees beyond the step is one.
    let outlier_deg = (SCAN_ANGLE_OUTLIER_DEG + 5.0 * sigma_deg).min(3.0 * SCAN_ANGLE_OUTLIER_DEG);
    let outliers = (rms_deg <= bound_deg && check.max_beyond_step_deg > outlier_deg).then(|| {
        lidarqa_model::Warning::new(
            "scan_angle_outliers",
            format!(
                "{}: the scan angle recovered from the points and the trajectory ({}) differs \
                 from the file's scan-angle field by up to {:.1}° (beyond the field's step {}°), \
                 past the {outlier_deg:.1}° no sensor noise explains, although it agrees to \
                 {rms_deg:.2}° RMS over {} points: some records carry a wrong scan angle or a \
                 wrong position (corrupted records, or a field with another sign convention)",
                input.display(),
                format.describe(),
                check.max_beyond_step_deg,
                check.step_deg,
                check.n
            ),
        )
    });
    let rms = (rms_deg > bound_deg).then(|| {
        lidarqa_model::Warning::new(
            "scan_angle_disagrees",
            format!(
                "{}: the scan angle recovered from the points and the trajectory ({}) differs \
                 from the file's scan-angle field by {rms_deg:.2}° RMS ({:.2}° at most) over {} \
                 points, beyond the {bound_deg:.3}° that the field's step {}° and 3 σ ({:.3}°) of \
                 the angles explain (at most {SCAN_ANGLE_MAX_BOUND_DEG}°): likely the \
                 trajectory is not the one the points were made with, the mounting (boresight, \
                 lever arm) is not the one used, or the field is not the angle in the scan plane",
                input.display(),
                format.describe(),
                check.max_deg,
                check.n,
                check.step_deg,
                3.0 * sigma_deg
            ),
        )
    });
    rms.into_iter().chain(outliers).collect()
}

/// Degrees beyond the LAS field's step (plus 5 σ of the angles) past which a single point's scan
/// angle disagreement is warned about: a scanner's field is its beam angle to within its
/// rounding, and the recovery adds the attitude's and boresight's errors (hundredths of a
/// degree); ten degrees is a wrong record, not noise.
pub(crate) const SCAN_ANGLE_OUTLIER_DEG: f64 = 10.0;

/// The largest RMS scan-angle disagreement, degrees, that the angles' σ may explain, however
/// large the sensor file says they are: beyond it the field and the recovery describe different
/// beams.
pub(crate) const SCAN_ANGLE_MAX_BOUND_DEG: f64 = 5.0;
