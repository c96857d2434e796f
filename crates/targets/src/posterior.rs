//! The grid posterior of a 2-D position under a negative log-likelihood (flat prior, nested
//! grids, optional discrete nuisance models): the centre estimators' edge likelihood and the
//! plate model both integrate their likelihood with it.

/// Posterior mean and covariance of a 2-D position under the negative log-likelihood `loss`
/// with a flat prior, on two nested (2k + 1)² grids: the first ±`half_width` around `c0`, the
/// second ±4σ around the first mean. The grid step's own spread (step²/12) is added to the
/// covariance as the floor of what the grid resolves.
pub(crate) fn grid_posterior(
    loss: impl Fn(f64, f64) -> f64,
    c0: [f64; 2],
    half_width: f64,
    k: i32,
) -> ([f64; 2], [[f64; 2]; 2]) {
    let (mean, cov, _) = grid_posterior_mixture(1, |_, x, y| loss(x, y), c0, half_width, [k, k]);
    (mean, cov)
}

/// [`grid_posterior`] with the position's likelihood depending on one of `models` discrete
/// nuisance models (equal prior): `loss(m, x, y)` is model m's negative log-likelihood, and the
/// two grids have `k[0]` and `k[1]` half-steps (a coarse first grid locates the mixture and
/// weighs the models: a Gaussian sampled every 2σ still sums to its integral within a few %). The
/// posterior of the position is the evidence-weighted mixture of the models' posteriors (the
/// joint posterior over model and position, summed over the models), so a model's weight is
/// its likelihood integrated over the position, not its best value, and the spread of the
/// position between plausible models enters the covariance. Models of negligible weight on the
/// first grid (below [`MIXTURE_MIN_WEIGHT`]) are left out of the second. Also returns the models'
/// posterior weights (on the second grid).
pub(crate) fn grid_posterior_mixture(
    models: usize,
    loss: impl Fn(usize, f64, f64) -> f64,
    c0: [f64; 2],
    half_width: f64,
    k: [i32; 2],
) -> ([f64; 2], [[f64; 2]; 2], Vec<f64>) {
    let grid = |centre: [f64; 2], h: f64, k: i32, active: &[bool]| {
        let step = h / f64::from(k);
        let mut vals = Vec::with_capacity(models * ((2 * k + 1) * (2 * k + 1)) as usize);
        let mut lmin = f64::INFINITY;
        for m in (0..models).filter(|&m| active[m]) {
            for i in -k..=k {
                for j in -k..=k {
                    let (x, y) = (
                        centre[0] + f64::from(i) * step,
                        centre[1] + f64::from(j) * step,
                    );
                    let l = loss(m, x, y);
                    lmin = lmin.min(l);
                    vals.push((m, x, y, l));
                }
            }
        }
        let (mut sw, mut mx, mut my) = (0.0, 0.0, 0.0);
        let mut weights = vec![0.0; models];
        for &(m, x, y, l) in &vals {
            let w = (lmin - l).exp();
            sw += w;
            mx += w * x;
            my += w * y;
            weights[m] += w;
        }
        let (mx, my) = (mx / sw, my / sw);
        let (mut cxx, mut cxy, mut cyy) = (0.0, 0.0, 0.0);
        for &(_, x, y, l) in &vals {
            let w = (lmin - l).exp() / sw;
            cxx += w * (x - mx).powi(2);
            cxy += w * (x - mx) * (y - my);
            cyy += w * (y - my).powi(2);
        }
        for w in &mut weights {
            *w /= sw;
        }
        // A grid cell's own spread (step²/12) is the floor of what the grid resolves.
        let floor = step * step / 12.0;
        ([mx, my], [[cxx + floor, cxy], [cxy, cyy + floor]], weights)
    };
    let (m1, c1, w1) = grid(c0, half_width, k[0], &vec![true; models]);
    let sd = (0.5 * (c1[0][0] + c1[1][1])
        + ((0.5 * (c1[0][0] - c1[1][1])).powi(2) + c1[0][1].powi(2)).sqrt())
    .sqrt();
    let active: Vec<bool> = w1.iter().map(|&w| w >= MIXTURE_MIN_WEIGHT).collect();
    grid(m1, (4.0 * sd).clamp(1e-4, half_width), k[1], &active)
}

/// Posterior weight below which a nuisance model of [`grid_posterior_mixture`] is dropped after
/// its first grid.
const MIXTURE_MIN_WEIGHT: f64 = 1e-3;
