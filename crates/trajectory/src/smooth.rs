//! Smoothing: block positions along a weighted local quadratic in time, with the wander the
//! fit does not see.

use crate::attitude::wrap;
use crate::blocks::Block;
use crate::{Epoch, ROLL_SIGMA_RAD};

/// A weighted local polynomial's value at one time ([`local_poly`]).
#[derive(Debug, Clone)]
pub(crate) struct LocalFit {
    pub(crate) value: f64,
    /// Its variance from the samples' σ (Σ aₖ² σₖ²).
    pub(crate) variance: f64,
    /// The first derivative (NaN for a constant).
    pub(crate) slope: f64,
}

/// Weighted local polynomial of degree ≤ 2 at `t0` over (t, value, σ) samples.
pub(crate) fn local_poly(samples: &[(f64, f64, f64)], t0: f64) -> Option<LocalFit> {
    let deg = match samples.len() {
        0 => return None,
        1 => 0,
        2 | 3 => 1,
        _ => 2,
    };
    let m = deg + 1;
    let basis = |t: f64| -> Vec<f64> { (0..m).map(|k| (t - t0).powi(k as i32)).collect() };
    let weight = |s: f64| 1.0 / (s * s).max(1e-24);
    let mut nm = nalgebra::DMatrix::<f64>::zeros(m, m);
    for &(t, _, s) in samples {
        let b = basis(t);
        for r in 0..m {
            for c in 0..m {
                nm[(r, c)] += weight(s) * b[r] * b[c];
            }
        }
    }
    let inv = nm.try_inverse()?;
    // Coefficient c of the polynomial = Σₖ (inv bₖ)_c wₖ yₖ.
    let coefficient = |c: usize| -> Vec<f64> {
        samples
            .iter()
            .map(|&(t, _, s)| {
                let b = basis(t);
                (0..m).map(|r| inv[(c, r)] * b[r]).sum::<f64>() * weight(s)
            })
            .collect()
    };
    let apply = |a: Vec<f64>| a.iter().zip(samples).map(|(a, s)| a * s.1).sum::<f64>();
    Some(LocalFit {
        value: apply(coefficient(0)),
        variance: inv[(0, 0)],
        slope: if m > 1 {
            apply(coefficient(1))
        } else {
            f64::NAN
        },
    })
}

/// The `n` blocks nearest in time to `t`, nearest first (ties in block order).
pub(crate) fn nearest_blocks(blocks: &[Block], t: f64, n: usize) -> Vec<usize> {
    let mut by: Vec<usize> = (0..blocks.len()).collect();
    by.sort_by(|&a, &b| {
        (blocks[a].time_s - t)
            .abs()
            .total_cmp(&(blocks[b].time_s - t).abs())
    });
    by.truncate(n);
    by
}

/// [`local_poly`] at `t` over the blocks `idx`, each giving its (value, σ) by `value`.
pub(crate) fn local_poly_over(
    blocks: &[Block],
    idx: &[usize],
    t: f64,
    value: &dyn Fn(usize) -> (f64, f64),
) -> Option<LocalFit> {
    let samples: Vec<(f64, f64, f64)> = idx
        .iter()
        .map(|&j| {
            let (y, sd) = value(j);
            (blocks[j].time_s, y, sd)
        })
        .collect();
    local_poly(&samples, t)
}

/// The blocks within `window_s` of `t` (the two nearest when fewer are).
pub(crate) fn window_blocks(blocks: &[Block], t: f64, window_s: f64) -> Vec<usize> {
    let near: Vec<usize> = (0..blocks.len())
        .filter(|&j| (blocks[j].time_s - t).abs() <= window_s)
        .collect();
    if near.len() < 2 {
        nearest_blocks(blocks, t, 2)
    } else {
        near
    }
}

/// How far the scanner departs from the curve fitted through the blocks, along axis `k`, m²:
/// turbulence, and any jitter of the path that a local quadratic over seconds and a straight
/// motion within each block cannot follow; the fit's own σ does not see it. Each block is
/// predicted from its neighbours (the same window, without it): the excess of that prediction's
/// squared error over its σ² and the block's is the departure. One block gives one degree of
/// freedom, so the excess is pooled over the strip (clipped at zero). On a random-walk path the
/// left-out prediction's error is close to that of the fit through all blocks.
pub(crate) fn path_wander_m2(blocks: &[Block], window_s: f64, k: usize) -> f64 {
    let (mut excess, mut n) = (0.0, 0usize);
    for (j, b) in blocks.iter().enumerate() {
        let others: Vec<usize> = window_blocks(blocks, b.time_s, window_s)
            .into_iter()
            .filter(|&i| i != j)
            .collect();
        if others.len() < 2 {
            continue;
        }
        let Some(f) = local_poly_over(blocks, &others, b.time_s, &|i| {
            (blocks[i].position[k], blocks[i].cov_position[(k, k)].sqrt())
        }) else {
            continue;
        };
        excess += (b.position[k] - f.value).powi(2) - f.variance - b.cov_position[(k, k)];
        n += 1;
    }
    if n > 0 {
        (excess / n as f64).max(0.0)
    } else {
        0.0
    }
}

/// Epochs at the block centres and at the strip's first and last return (so that every point
/// of the strip lies within the trajectory), each from a local fit over the blocks within
/// `window_s` (the two nearest when none is).
pub(crate) fn smooth(blocks: &[Block], strip: u32, window_s: f64, span_s: [f64; 2]) -> Vec<Epoch> {
    let mut out = Vec::with_capacity(blocks.len() + 2);
    let (Some(first), Some(last)) = (blocks.first(), blocks.last()) else {
        return out;
    };
    // Unwrapped azimuths, so that the fit never straddles ±π.
    let mut az = Vec::with_capacity(blocks.len());
    for b in blocks {
        let a = match az.last() {
            Some(&prev) => prev + wrap(b.azimuth_rad - prev),
            None => b.azimuth_rad,
        };
        az.push(a);
    }
    let mut times: Vec<f64> = Vec::with_capacity(blocks.len() + 2);
    if span_s[0] < first.time_s {
        times.push(span_s[0]);
    }
    times.extend(blocks.iter().map(|b| b.time_s));
    if span_s[1] > last.time_s {
        times.push(span_s[1]);
    }
    let wander = [0, 1, 2].map(|k| path_wander_m2(blocks, window_s, k));
    for t in times {
        let near = window_blocks(blocks, t, window_s);
        let nearest = near
            .iter()
            .copied()
            .min_by(|&a, &b| {
                (blocks[a].time_s - t)
                    .abs()
                    .total_cmp(&(blocks[b].time_s - t).abs())
            })
            .unwrap_or(0);
        let b = &blocks[nearest];
        let fit = |value: &dyn Fn(usize) -> (f64, f64)| local_poly_over(blocks, &near, t, value);
        let mut pos = [0.0; 3];
        let mut sig = [0.0; 3];
        let mut vel = [b.velocity.x, b.velocity.y, b.velocity.z];
        if blocks.len() == 1 {
            // One block: its own straight motion, S₀ + V τ, with σ from [S₀, V]'s covariance.
            let tau = t - b.time_s;
            let mut j = nalgebra::Matrix3x6::<f64>::zeros();
            for k in 0..3 {
                j[(k, k)] = 1.0;
                j[(k, k + 3)] = tau;
            }
            let c = j * b.cov * j.transpose();
            for k in 0..3 {
                pos[k] = b.position[k] + tau * vel[k];
                sig[k] = c[(k, k)].sqrt();
            }
            out.push(Epoch {
                time_s: t,
                strip,
                position_m: pos,
                velocity_m_per_s: vel,
                pitch_rad: b.pitch_rad,
                azimuth_rad: b.azimuth_rad,
                sigma_position_m: sig,
                sigma_attitude_rad: [ROLL_SIGMA_RAD, b.sigma_pitch_rad, b.sigma_azimuth_rad],
                lines: b.lines,
            });
            continue;
        }
        for k in 0..3 {
            // The fit's own σ and the scanner's departure from the fitted curve.
            let sd = |j: usize| blocks[j].cov_position[(k, k)].sqrt();
            match fit(&|j| (blocks[j].position[k], sd(j))) {
                Some(f) => {
                    pos[k] = f.value;
                    sig[k] = (f.variance + wander[k]).sqrt();
                    if f.slope.is_finite() {
                        vel[k] = f.slope;
                    }
                }
                None => {
                    pos[k] = b.position[k] + vel[k] * (t - b.time_s);
                    sig[k] = (sd(nearest).powi(2) + wander[k]).sqrt();
                }
            }
        }
        // The attitude from the block at `t` itself, or a line through the two nearest blocks
        // (the strip's ends): see the module docs for why it is not smoothed.
        let two_nearest = nearest_blocks(blocks, t, 2);
        let attitude =
            |value: &dyn Fn(usize) -> (f64, f64)| local_poly_over(blocks, &two_nearest, t, value);
        let (pitch, sp) = attitude(&|j| (blocks[j].pitch_rad, blocks[j].sigma_pitch_rad.max(1e-7)))
            .map_or((b.pitch_rad, b.sigma_pitch_rad), |f| {
                (f.value, f.variance.sqrt())
            });
        let (a, sa) = attitude(&|j| (az[j], blocks[j].sigma_azimuth_rad.max(1e-7)))
            .map_or((az[nearest], b.sigma_azimuth_rad), |f| {
                (f.value, f.variance.sqrt())
            });
        out.push(Epoch {
            time_s: t,
            strip,
            position_m: pos,
            velocity_m_per_s: vel,
            pitch_rad: pitch,
            azimuth_rad: wrap(a),
            sigma_position_m: sig,
            sigma_attitude_rad: [ROLL_SIGMA_RAD, sp, sa],
            lines: b.lines,
        });
    }
    out
}
