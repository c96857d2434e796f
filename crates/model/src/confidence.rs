//! The 95 % factors of normally distributed errors: one home for the IHO S-44 TVU/THU of
//! lidarqa-tpu and the NSSDA statements of lidarqa-targets, so that they cannot drift apart.

/// 95 % of a one-dimensional normal error, in units of its σ: 1.96 (FGDC NSSDA's vertical factor,
/// IHO S-44 TVU).
pub const NORMAL_95_FACTOR: f64 = 1.96;

/// 95 % radius of a circular bivariate normal error in units of σ_H = √(σ_N² + σ_E²):
/// `√(−2 ln 0.05) / √2 = 2.4477 / √2`, rounded to 1.7308 as NSSDA (FGDC-STD-007.3-1998) and
/// cBLUE's `total_thu` give it.
pub const CIRCULAR_95_FACTOR: f64 = 1.7308;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_factors_are_the_normal_quantiles_rounded() {
        // Φ⁻¹(0.975) = 1.959964; the circular radius √(−2 ln 0.05) / √2 = 1.730818.
        assert!((NORMAL_95_FACTOR - 1.959_964).abs() < 5e-5);
        let circular = (-2.0 * 0.05f64.ln()).sqrt() / 2f64.sqrt();
        assert!((CIRCULAR_95_FACTOR - circular).abs() < 5e-5);
    }
}
