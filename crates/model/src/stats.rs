//! Order statistics shared by the estimators: the median, and the σ a median absolute deviation
//! stands for. One home, so that the outlier cuts of targets, calib and QC agree.

/// σ of a normal error from the median of its absolute deviations: `1 / Φ⁻¹(0.75)` = 1.4826,
/// the usual rounding (the robust σ of an outlier cut).
pub const MAD_TO_SIGMA: f64 = 1.4826;

/// The median of `values` (sorted in place; the mean of the two middle values when their count
/// is even); `None` when there are none.
pub fn median(values: &mut [f64]) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    values.sort_by(f64::total_cmp);
    let n = values.len();
    Some(if n % 2 == 1 {
        values[n / 2]
    } else {
        0.5 * (values[n / 2 - 1] + values[n / 2])
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_median_takes_the_middle_or_the_mean_of_the_two_middles() {
        assert_eq!(median(&mut []), None);
        assert_eq!(median(&mut [3.0, -1.0, 2.0]), Some(2.0));
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), Some(2.5));
    }

    #[test]
    fn the_mad_factor_is_the_inverse_normal_quartile() {
        // Φ⁻¹(0.75) = 0.6744898.
        assert!((MAD_TO_SIGMA - 1.0 / 0.674_489_8).abs() < 5e-5);
    }
}
