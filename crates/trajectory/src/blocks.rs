//! Blocks: the scanner's straight, uniform motion fitted to each short time block's lines
//! (IRLS, with the errors-in-variables pull added back).

use crate::attitude::scan_plane;
use crate::pulses::Line;
use crate::{PulseChecks, ReconstructOptions, ReturnPoint, TUKEY_C, VELOCITY_PRIOR_M_PER_S};
use nalgebra::{Matrix3, Matrix6, Vector3, Vector6};

/// One block's estimate.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Block {
    pub(crate) time_s: f64,
    pub(crate) position: Vector3<f64>,
    pub(crate) velocity: Vector3<f64>,
    pub(crate) cov_position: Matrix3<f64>,
    /// Covariance of [S₀, V].
    pub(crate) cov: Matrix6<f64>,
    pub(crate) pitch_rad: f64,
    pub(crate) azimuth_rad: f64,
    pub(crate) sigma_pitch_rad: f64,
    pub(crate) sigma_azimuth_rad: f64,
    pub(crate) lines: usize,
    /// The scan plane's (pitch, azimuth) variance from the fitted scanner motion and from the
    /// returns' noise, rad² ([`ScanPlane::variance_rad2`]).
    pub(crate) plane_variance_rad2: [f64; 2],
    /// The sub-blocks' scatter not explained by their noise, rad²
    /// ([`ScanPlane::wander_excess_rad2`]).
    pub(crate) wander_excess_rad2: [f64; 2],
}

pub(crate) fn fit_blocks(
    lines: &[Line],
    points: &[&ReturnPoint],
    o: &ReconstructOptions,
    checks: &mut PulseChecks,
) -> Vec<Block> {
    let mut out = Vec::new();
    let Some(t0) = lines.first().map(|l| l.time_s) else {
        return out;
    };
    let mut i = 0;
    while i < lines.len() {
        let k = ((lines[i].time_s - t0) / o.block_s).floor();
        let mut j = i;
        while j < lines.len() && ((lines[j].time_s - t0) / o.block_s).floor() == k {
            j += 1;
        }
        let block = &lines[i..j];
        i = j;
        if block.len() < o.min_lines {
            continue;
        }
        checks.lines += block.len() as u64;
        let Some(BlockFit { tc, x, cov, robust }) = fit_block(block) else {
            continue;
        };
        checks.rejected += robust.iter().filter(|w| **w < 0.05).count() as u64;
        let s0 = Vector3::new(x[0], x[1], x[2]);
        let v = Vector3::new(x[3], x[4], x[5]);
        let (lo, hi) = (block[0].time_s, block[block.len() - 1].time_s);
        let a = points.partition_point(|p| p.time_s < lo);
        let b = points.partition_point(|p| p.time_s <= hi);
        let Some(plane) = scan_plane(&points[a..b], tc, &x, &cov) else {
            continue;
        };
        out.push(Block {
            time_s: tc,
            position: s0,
            velocity: v,
            cov_position: cov.fixed_view::<3, 3>(0, 0).into_owned(),
            cov,
            pitch_rad: plane.pitch_rad,
            azimuth_rad: plane.azimuth_rad,
            sigma_pitch_rad: plane.variance_rad2[0].sqrt(),
            sigma_azimuth_rad: plane.variance_rad2[1].sqrt(),
            lines: block.len(),
            plane_variance_rad2: plane.variance_rad2,
            wander_excess_rad2: plane.wander_excess_rad2,
        });
    }
    out
}

/// The attitude's wander within a block is estimated from eight sub-blocks (six degrees of
/// freedom, less their noise): one block's estimate is too noisy to use alone (a block whose
/// wander came out small by chance would claim an error several times its σ), and clipping
/// each at zero would bias it up. The wander is pooled over the strip (the mean excess, then
/// clipped at zero) and added to each block's own fit and noise variance.
pub(crate) fn pool_attitude_sigma(blocks: &mut [Block]) {
    let n = blocks.len().max(1) as f64;
    let wander =
        [0, 1].map(|k| (blocks.iter().map(|b| b.wander_excess_rad2[k]).sum::<f64>() / n).max(0.0));
    for b in blocks.iter_mut() {
        b.sigma_pitch_rad = (b.plane_variance_rad2[0] + wander[0]).sqrt();
        b.sigma_azimuth_rad = (b.plane_variance_rad2[1] + wander[1]).sqrt();
    }
}

/// A block fit ([`fit_block`]).
pub(crate) struct BlockFit {
    /// The lines' mean time, s.
    pub(crate) tc: f64,
    /// [S₀, V].
    pub(crate) x: Vector6<f64>,
    /// Their covariance.
    pub(crate) cov: Matrix6<f64>,
    /// The final robust weights.
    pub(crate) robust: Vec<f64>,
}

/// IRLS fit of `S₀`, `V` to a block's lines.
pub(crate) fn fit_block(block: &[Line]) -> Option<BlockFit> {
    let n = block.len() as f64;
    let tc = block.iter().map(|l| l.time_s).sum::<f64>() / n;
    let mut robust = vec![1.0; block.len()];
    let mut x = Vector6::zeros();
    let mut scale2 = 1.0;
    let mut cov = Matrix6::zeros();
    let mut base = vec![1.0; block.len()];
    let mut resid = Vec::with_capacity(block.len());
    // The errors-in-variables force ([`eiv_force`]) of the previous iteration.
    let mut force = Vector6::<f64>::zeros();
    for iter in 0..12 {
        let mut nm = Matrix6::<f64>::zeros();
        let mut rhs = Vector6::<f64>::zeros();
        for ((l, w_r), w_b) in block.iter().zip(&robust).zip(&base) {
            let w = w_r * w_b;
            if w <= 0.0 {
                continue;
            }
            let tau = l.time_s - tc;
            let p = Matrix3::identity() - l.d * l.d.transpose();
            let pa = p * l.a;
            for (r, c, m) in [(0, 0, 1.0), (0, 3, tau), (3, 0, tau), (3, 3, tau * tau)] {
                let mut v = nm.fixed_view_mut::<3, 3>(r, c);
                v += p * (w * m);
            }
            let mut top = rhs.fixed_rows_mut::<3>(0);
            top += pa * w;
            let mut bot = rhs.fixed_rows_mut::<3>(3);
            bot += pa * (w * tau);
        }
        // Weak zero-mean prior on V, in the units of the unit-weight variance.
        for k in 3..6 {
            nm[(k, k)] += scale2 / VELOCITY_PRIOR_M_PER_S.powi(2);
        }
        let inv = nm.try_inverse()?;
        x = inv * (rhs + force);
        let s = Vector3::new(x[0], x[1], x[2]);
        let v = Vector3::new(x[3], x[4], x[5]);
        // Miss distances, normalised by each line's lever (range / separation).
        resid.clear();
        for (l, b) in block.iter().zip(base.iter_mut()) {
            let pos = s + v * (l.time_s - tc);
            let e = pos - l.a;
            let miss = (e - l.d * l.d.dot(&e)).norm();
            let range = e.norm().max(l.separation_m);
            *b = (l.separation_m / range).powi(2);
            resid.push(miss * l.separation_m / range);
        }
        let mut sorted: Vec<f64> = resid.clone();
        sorted.sort_by(f64::total_cmp);
        // A 2-D Gaussian miss of σ per axis has a median norm of σ √(2 ln 2).
        let sigma = (sorted[sorted.len() / 2] / (2.0 * 2f64.ln()).sqrt()).max(1e-9);
        if iter >= 1 {
            for (w, r) in robust.iter_mut().zip(&resid) {
                let u = r / (TUKEY_C * sigma);
                *w = if u < 1.0 { (1.0 - u * u).powi(2) } else { 0.0 };
            }
        }
        let (mut chi2, mut wsum) = (0.0, 0.0);
        for (w, r) in robust.iter().zip(&resid) {
            chi2 += w * r * r;
            wsum += w;
        }
        let dof = (2.0 * wsum - 6.0).max(1.0);
        scale2 = (chi2 / dof).max(1e-18);
        cov = inv * scale2;
        force = eiv_force(block, tc, &x, &robust, &base, &resid);
    }
    Some(BlockFit { tc, x, cov, robust })
}

/// Errors in variables: a line's direction error ε (its returns' noise) moves the closest
/// point of approach along the line towards its returns, E[P (a − S)] = −E|ε|² (range −
/// sep / 2) d, and near-vertical lines determine the height weakly: the block's height comes
/// out low, growing with the square of the noise (found with the independent generator,
/// tests/trajectory_generator.py; numbers in the README). This is the sum of those
/// expectations over the lines with the fit's weights, each line's |ε|² estimated by its own
/// (normalised miss / sep)²; added to the normal equations' right side, it cancels the bias.
/// Inside the iterations, so that the robust weights are taken about the corrected point
/// (applied once after them, it left part of the bias).
pub(crate) fn eiv_force(
    block: &[Line],
    tc: f64,
    x: &Vector6<f64>,
    robust: &[f64],
    base: &[f64],
    resid: &[f64],
) -> Vector6<f64> {
    let s = Vector3::new(x[0], x[1], x[2]);
    let v = Vector3::new(x[3], x[4], x[5]);
    let mut force = Vector6::<f64>::zeros();
    for (((l, w_r), w_b), r) in block.iter().zip(robust).zip(base).zip(resid) {
        let tau = l.time_s - tc;
        let range = (s + v * tau - l.a).norm();
        let g = l.d * (w_r * w_b * (r / l.separation_m).powi(2) * (range - 0.5 * l.separation_m));
        let mut top = force.fixed_rows_mut::<3>(0);
        top += g;
        let mut bot = force.fixed_rows_mut::<3>(3);
        bot += g * tau;
    }
    force
}
