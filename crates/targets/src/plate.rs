//! The plate model: find a disc of known radius near a control point and fit its centre from
//! every point around it.
//!
//! A target is a disc of radius R, brighter than the ground around it and, for a raised plate,
//! higher. Every return within R + 0.6 m of the disc obeys one model:
//!
//! * intensity `I = a + b·f(R − |p − c|)`, with `f` the fraction of the laser footprint on the
//!   plate (footprint mixing at the rim: a logistic for a Gaussian beam or the area fraction of
//!   a uniform disc); noise σ_I, plus a share of b·f(1 − f) on mixed returns, Gaussian with a
//!   1 % outlier component so that a stray bright return or the edge of a nearby painted line
//!   cannot dominate; the return's horizontal position error σ_xy is integrated over (it moves
//!   the intensity and the height label together);
//! * for a raised plate, which surface a return came from (a height label: above or below the
//!   middle of the height step), on the plate with probability `σ((R − |p − c|)/τ_z)`.
//!
//! Steps: (1) detection: on a grid over the search disc around the control point, the mean
//! intensity inside a disc of radius R minus that of the ring R + 0.15 … R + 0.6 m, in units of
//! its standard error (a matched filter: a plate scores highest where the disc covers it, a
//! line only a fraction); (2) levels a, b by least squares at the detected centre, σ_I from the
//! MAD of the residuals, the height step by least squares on a sloped ground plane plus a step;
//! (3) the posterior mean and covariance of c under the model's likelihood (flat prior, nested
//! grids, [`grid_posterior`]); the edge shape (ramp, σ_xy, mixed-return share, each ramp with
//! its levels refitted at a first posterior mean) is a nuisance the centre's posterior is
//! averaged over, each shape weighted by its evidence ([`grid_posterior_mixture`]); (4) the
//! elevation from the plate itself: the weighted mean Z of the points inside the fitted circle,
//! each weighted by the probability that it is no mixed rim return, for a raised plate only
//! those on the upper surface; (5) shape checks: the disc must be bright inside and dark in the
//! ring.
//!
//! Written by hand: it is a small model-specific likelihood; the generic parts (k-d tree,
//! least squares) come from kiddo and nalgebra.

use kiddo::{ImmutableKdTree, SquaredEuclidean};
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use crate::point::{LidarPoint, coverage_deg};
use crate::posterior::{grid_posterior, grid_posterior_mixture};

/// Inner edge of the ring the detection compares the disc with, beyond R (m).
const RING_IN_M: f64 = 0.15;
/// Outer edge of that ring, and of the points the fit uses, beyond R (m).
pub(crate) const RING_OUT_M: f64 = 0.6;
/// Detection threshold: the disc-minus-ring contrast in standard errors. Pure noise rarely
/// exceeds 4 over the search grid.
const DETECTION_T: f64 = 5.0;
/// Weight of the outlier component of the intensity and height-label likelihoods.
const OUTLIER_WEIGHT: f64 = 0.01;
/// Horizontal position noises of the returns (m) the fit chooses from by likelihood.
const POSITION_NOISES_M: [f64; 4] = [0.0, 0.01, 0.02, 0.04];
/// Intensity noise of mixed returns, a fraction of b·f(1 − f) (the area-fraction model of a
/// mixed return is only approximate: beam profile, incidence, the plate's bevel).
const MIXED_NOISES: [f64; 4] = [0.0, 0.15, 0.3, 0.6];
/// Half the steps of each posterior grid: 25 × 25, a step of 3.3 cm on the first (±0.4 m) grid
/// and of σ/3 on the second (±4σ).
const GRID_HALF_STEPS: i32 = 12;
/// Half the steps of the first grid of the average over edge shapes (one grid per shape): 13 × 13
/// over ±5σ of the first posterior, enough to weigh the shapes and locate their mixture.
const MIXTURE_FIRST_HALF_STEPS: i32 = 6;
/// Half the steps of its second grid: 17 × 17 over ±4σ of the mixture, a step of σ/2.
const MIXTURE_HALF_STEPS: i32 = 8;
/// Edge shapes whose likelihood at the first posterior mean is more than this below the best
/// (nats) are left out of the average over shapes: their evidence is negligible.
const SHAPE_SPAN_NATS: f64 = 8.0;
/// At most this many edge shapes (the most likely) enter the average (it bounds the runtime).
const MAX_SHAPES: usize = 48;

/// What the plate model found at one target (serialised as `plate` in the JSON report).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlateModel {
    /// Intensity on the plate (fitted level a + b, sensor units).
    pub plate_intensity: f64,
    /// Intensity of the ground around it (fitted level a).
    pub ground_intensity: f64,
    /// 1σ intensity noise (1.4826 × MAD of the model residuals).
    pub intensity_noise: f64,
    /// 1σ width of the intensity ramp at the edge (footprint mixing) the fit chose, m.
    pub edge_sd_m: f64,
    /// Horizontal position noise of the returns the edge fit chose, m.
    pub position_noise_m: f64,
    /// Height of the plate above the ground plane around it (m).
    pub height_step_m: f64,
    /// Whether the height step was significant, so the height labels took part in the fit.
    pub raised: bool,
    /// Detection statistic: disc-minus-ring contrast in standard errors.
    pub detection_t: f64,
    /// Fraction of the points inside the circle (minus the rim) brighter than mid-contrast.
    pub inside_bright_fraction: f64,
    /// Fraction of the points in the ring R + 0.2 … R + 0.6 m brighter than mid-contrast.
    pub ring_bright_fraction: f64,
    /// Returns of weight ≥ ½ in the elevation: inside the fitted circle (on the upper surface of a
    /// raised plate), each weighted by the probability that it is no mixed return.
    pub n_elevation_points: usize,
    /// Distance inside the fitted edge at which a return's elevation weight is ½ (the footprint
    /// ramp's full reach), m.
    pub rim_m: f64,
}

/// The fit of [`fit_plate`].
pub(crate) struct PlateFit {
    pub centre: [f64; 2],
    pub cov: [[f64; 2]; 2],
    pub z: f64,
    pub var_z: f64,
    pub model: PlateModel,
    /// Indices into the local points classified as plate within R + 0.3 m of the detected
    /// centre (the segmentation the other estimators get).
    pub plate_points: Vec<usize>,
    /// Points within 0.1 m of the fitted edge.
    pub n_edge: usize,
    pub coverage_deg: f64,
    /// Fewer than 3 points inside the circle minus the rim: the elevation used every point
    /// inside the circle.
    pub elevation_fallback: bool,
}

/// The intensity ramp across the plate's edge: the fraction of a return's footprint on the
/// plate at signed distance t (m, > 0 inside) from the edge.
#[derive(Debug, Clone, Copy)]
enum Ramp {
    /// A Gaussian-like beam: the logistic of scale τ (m).
    Logistic(f64),
    /// A uniform disc footprint of radius ρ (m): its area fraction inside a straight edge.
    Footprint(f64),
}

impl Ramp {
    fn f(self, t: f64) -> f64 {
        match self {
            Self::Logistic(tau) => sigmoid(t / tau),
            Self::Footprint(rho) => {
                if t >= rho {
                    1.0
                } else if t <= -rho {
                    0.0
                } else {
                    let u = t / rho;
                    1.0 - (u.acos() - u * (1.0 - u * u).sqrt()) / std::f64::consts::PI
                }
            }
        }
    }

    /// Distance from the edge beyond which the ramp is flat (0 or 1 to 1e-4), m.
    fn reach(self) -> f64 {
        match self {
            Self::Logistic(tau) => 10.0 * tau,
            Self::Footprint(rho) => rho,
        }
    }

    /// Steepest slope of the ramp, 1/m (at the edge).
    fn max_slope(self) -> f64 {
        match self {
            Self::Logistic(tau) => 0.25 / tau,
            Self::Footprint(rho) => 2.0 / (std::f64::consts::PI * rho),
        }
    }

    /// Distance inside the edge beyond which a return's footprint lies wholly on the plate (to
    /// 1 %), m.
    fn full_reach(self) -> f64 {
        match self {
            Self::Logistic(tau) => 99f64.ln() * tau,
            Self::Footprint(rho) => rho,
        }
    }

    /// 1σ width of the ramp (m).
    fn sd(self) -> f64 {
        match self {
            Self::Logistic(tau) => tau * std::f64::consts::PI / 3f64.sqrt(),
            Self::Footprint(rho) => 0.5 * rho,
        }
    }
}

/// An edge shape with its levels: (loss at the first posterior mean, ramp, (σ_xy, mixed-return
/// share), a, b, σ_I).
type Shape = (f64, Ramp, (f64, f64), f64, f64, f64);

/// The ramps the fit chooses from by likelihood.
const RAMPS: [Ramp; 9] = [
    Ramp::Logistic(0.005),
    Ramp::Logistic(0.01),
    Ramp::Logistic(0.02),
    Ramp::Logistic(0.04),
    Ramp::Logistic(0.08),
    Ramp::Footprint(0.05),
    Ramp::Footprint(0.075),
    Ramp::Footprint(0.1),
    Ramp::Footprint(0.15),
];

/// Half-width of the position-error quadrature, in σ_xy.
const POSITION_REACH_SD: f64 = 4.0;
/// Most nodes of that quadrature (a very sharp candidate ramp at very low noise is resolved
/// less finely; the likelihood then disfavours it).
const MAX_POSITION_NODES: usize = 97;

/// Nodes and weights (summing to 1) of the integral over a radial position error N(0, σ_xy²):
/// evenly spaced over ±4σ_xy at most σ_xy / 2 and `peak_m` apart (`peak_m`: the 1σ width of the
/// narrowest intensity peak the integrand can have; Gaussians one σ apart sum to a smooth
/// curve), weighted by the Gaussian density.
fn position_nodes(sxy: f64, peak_m: f64) -> Vec<(f64, f64)> {
    if sxy <= 0.0 {
        return vec![(0.0, 1.0)];
    }
    let h = (0.5 * sxy).min(peak_m);
    let half = ((POSITION_REACH_SD * sxy / h).ceil() as usize).clamp(2, MAX_POSITION_NODES / 2);
    let h = POSITION_REACH_SD * sxy / half as f64;
    let mut nodes: Vec<(f64, f64)> = (0..=2 * half)
        .map(|k| {
            let e = (k as f64 - half as f64) * h;
            (e, (-0.5 * (e / sxy).powi(2)).exp())
        })
        .collect();
    let total: f64 = nodes.iter().map(|n| n.1).sum();
    for n in &mut nodes {
        n.1 /= total;
    }
    nodes
}

/// Standard normal CDF (the logistic approximation Φ(x) ≈ σ(1.702 x), within 0.01: enough for a
/// weight).
fn normal_cdf(x: f64) -> f64 {
    sigmoid(1.702 * x)
}

fn sigmoid(x: f64) -> f64 {
    1.0 / (1.0 + (-x).exp())
}

/// 1.4826 × the median absolute deviation from the median.
fn mad_sigma(v: &[f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let med = s[s.len() / 2];
    let mut d: Vec<f64> = s.iter().map(|x| (x - med).abs()).collect();
    d.sort_by(f64::total_cmp);
    lidarqa_model::MAD_TO_SIGMA * d[d.len() / 2]
}

/// Least squares `y ≈ X β`, with one pass of rejecting residuals beyond 3.5 robust σ.
fn robust_lstsq(rows: &[Vec<f64>], y: &[f64]) -> Option<(Vec<f64>, f64)> {
    let np = rows.first()?.len();
    let mut keep = vec![true; y.len()];
    let mut out = None;
    for _pass in 0..2 {
        let idx: Vec<usize> = (0..y.len()).filter(|&i| keep[i]).collect();
        if idx.len() <= np {
            return out;
        }
        let x = DMatrix::from_fn(idx.len(), np, |r, c| rows[idx[r]][c]);
        let yy = DVector::from_iterator(idx.len(), idx.iter().map(|&i| y[i]));
        let beta = x.clone().svd(true, true).solve(&yy, 1e-12).ok()?;
        let res: Vec<f64> = (0..y.len())
            .map(|i| y[i] - (0..np).map(|c| rows[i][c] * beta[c]).sum::<f64>())
            .collect();
        let kept: Vec<f64> = idx.iter().map(|&i| res[i]).collect();
        let sigma = mad_sigma(&kept);
        for (i, r) in res.iter().enumerate() {
            keep[i] = r.abs() <= 3.5 * sigma.max(1e-12);
        }
        out = Some((beta.iter().copied().collect(), sigma));
    }
    out
}

/// Local intensity levels (a, b) of `I ≈ a + b f` at centre `c`, and the noise σ_I.
fn intensity_levels(
    pts: &[LidarPoint],
    c: [f64; 2],
    radius: f64,
    ramp: Ramp,
) -> Option<(f64, f64, f64)> {
    let rows: Vec<Vec<f64>> = pts
        .iter()
        .map(|p| vec![1.0, ramp.f(radius - (p.x - c[0]).hypot(p.y - c[1]))])
        .collect();
    let y: Vec<f64> = pts.iter().map(|p| p.intensity).collect();
    let (beta, sigma) = robust_lstsq(&rows, &y)?;
    Some((beta[0], beta[1], sigma))
}

/// Finds and fits the plate of radius `radius` whose centre lies within `search_m` of `seed`.
/// `local` must hold the points within `search_m + radius + 0.6` m of `seed`. `None` when no
/// disc brighter than its surroundings is there.
pub(crate) fn fit_plate(
    local: &[LidarPoint],
    seed: [f64; 2],
    radius: f64,
    search_m: f64,
    edge_width_m: f64,
) -> Option<PlateFit> {
    if local.len() < 6 {
        return None;
    }
    let xy: Vec<[f64; 2]> = local.iter().map(|p| [p.x, p.y]).collect();
    let tree: ImmutableKdTree<f64, 2> = ImmutableKdTree::new_from_slice(&xy);
    let intensities: Vec<f64> = local.iter().map(|p| p.intensity).collect();
    let scale = intensities.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let sigma0 = mad_sigma(&intensities).max(1e-9 * scale.max(1.0));

    // (1) Detection: disc-minus-ring contrast over a grid on the search disc.
    let step = (radius / 8.0).min(0.1);
    let k = (search_m / step).ceil() as i32;
    let outer = radius + RING_OUT_M;
    let mut best: Option<([f64; 2], f64)> = None;
    for i in -k..=k {
        for j in -k..=k {
            let (dx, dy) = (f64::from(i) * step, f64::from(j) * step);
            if dx.hypot(dy) > search_m {
                continue;
            }
            let c = [seed[0] + dx, seed[1] + dy];
            let (mut si, mut ni, mut sr, mut nr) = (0.0, 0usize, 0.0, 0usize);
            for nb in tree.within_unsorted::<SquaredEuclidean>(&c, outer * outer) {
                let d = nb.distance.sqrt();
                let v = intensities[nb.item as usize];
                if d < radius {
                    si += v;
                    ni += 1;
                } else if d > radius + RING_IN_M {
                    sr += v;
                    nr += 1;
                }
            }
            if ni < 3 || nr < 3 {
                continue;
            }
            let (ni, nr) = (ni as f64, nr as f64);
            let t = (si / ni - sr / nr) / (sigma0 * (1.0 / ni + 1.0 / nr).sqrt());
            if best.is_none_or(|(_, bt)| t > bt) {
                best = Some((c, t));
            }
        }
    }
    let (c0, detection_t) = best?;
    if detection_t < DETECTION_T {
        return None;
    }

    // The fit's points: within R + 0.6 m of the detected centre, plus the 0.45 m the posterior
    // grid may move it.
    let reach = outer + 0.45;
    let near: Vec<usize> = tree
        .within_unsorted::<SquaredEuclidean>(&c0, reach * reach)
        .into_iter()
        .map(|nb| nb.item as usize)
        .collect();
    let pts: Vec<LidarPoint> = near.iter().map(|&i| local[i]).collect();

    // (2) Height step: z ≈ g0 + gx·dx + gy·dy + h·[inside], the ground a plane.
    let inside0 = |p: &LidarPoint| (p.x - c0[0]).hypot(p.y - c0[1]) < radius;
    let rows: Vec<Vec<f64>> = pts
        .iter()
        .map(|p| {
            vec![
                1.0,
                p.x - c0[0],
                p.y - c0[1],
                if inside0(p) { 1.0 } else { 0.0 },
            ]
        })
        .collect();
    let zs: Vec<f64> = pts.iter().map(|p| p.z).collect();
    let (zb, sigma_z) = robust_lstsq(&rows, &zs)?;
    let height_step_m = zb[3];
    let raised = height_step_m > 0.05 && height_step_m > 8.0 * sigma_z;
    // Height labels: above the middle of the step over the ground plane.
    let on_top: Vec<bool> = pts
        .iter()
        .map(|p| p.z - (zb[0] + zb[1] * (p.x - c0[0]) + zb[2] * (p.y - c0[1])) > 0.5 * zb[3])
        .collect();
    let tau_z = (edge_width_m * 3f64.sqrt() / std::f64::consts::PI).max(1e-3);

    // (3) Posterior of the centre under the model. A return's horizontal position error σ_xy
    // moves it across the edge in both channels at once (its intensity and its height label are
    // not independent): the likelihood integrates over the radial component of that error. Near
    // the edge the integrand is a narrow peak where the intensity pins the return's true
    // distance (σ_I / (b·f′), far below σ_xy at low noise); a coarse rule would turn each
    // return's likelihood into a comb and the posterior would be too narrow, so the nodes are
    // spaced finer than both that peak and σ_xy. Away from the edge nothing depends on the
    // error and one node suffices.
    let label_reach = if raised { 10.0 * tau_z } else { 0.0 };
    let loss_at = |c: [f64; 2], a: f64, b: f64, s: f64, ramp: Ramp, (sxy, kappa): (f64, f64)| {
        let nodes = position_nodes(sxy, s / (b.abs() * ramp.max_slope()).max(1e-12));
        let band = ramp.reach().max(label_reach) + POSITION_REACH_SD * sxy;
        let mut l = 0.0;
        for (p, &top) in pts.iter().zip(&on_top) {
            let t0 = radius - (p.x - c[0]).hypot(p.y - c[1]);
            let here: &[(f64, f64)] = if t0.abs() < band {
                &nodes
            } else {
                &[(0.0, 1.0)]
            };
            let mut lik = 0.0;
            for &(e, w) in here {
                let f = ramp.f(t0 - e);
                let mixed = kappa * b * f * (1.0 - f);
                let v = s * s + mixed * mixed;
                let mut term = w * (-0.5 * (p.intensity - a - b * f).powi(2) / v).exp() / v.sqrt();
                if raised {
                    let g = sigmoid((t0 - e) / tau_z);
                    term *= if top { g } else { 1.0 - g };
                }
                lik += term;
            }
            let floor =
                OUTLIER_WEIGHT * (-8.0f64).exp() / s * if raised { OUTLIER_WEIGHT } else { 1.0 };
            l -= ((1.0 - OUTLIER_WEIGHT) * lik + floor).ln();
        }
        l
    };
    let floor = 1e-9 * scale.max(1.0);
    let (mut ramp, mut sxy) = (Ramp::Logistic(0.02), (0.02, 0.0));
    let (mut a, mut b, mut s) = intensity_levels(&pts, c0, radius, ramp)?;
    s = s.max(floor);
    let (c1, cov1) = grid_posterior(
        |x, y| loss_at([x, y], a, b, s, ramp, sxy),
        c0,
        0.4,
        GRID_HALF_STEPS,
    );
    // The edge shape (ramp, σ_xy, mixed-return share), each ramp with its own levels, is a
    // nuisance: a dozen edge returns cannot pin it, and the one that fits best at one centre is
    // sharper than the truth, with a posterior too narrow. The centre's posterior is averaged
    // over the shapes, each weighted by its evidence (its likelihood integrated over the centre,
    // [`grid_posterior_mixture`]); shapes far below the best at c1 carry no weight and are left
    // out before the grid.
    let mut shapes: Vec<Shape> = Vec::new();
    for t in RAMPS {
        if let Some((at, bt, st)) = intensity_levels(&pts, c1, radius, t) {
            let st = st.max(floor);
            for sx in POSITION_NOISES_M {
                for kappa in MIXED_NOISES {
                    let l = loss_at(c1, at, bt, st, t, (sx, kappa));
                    if l.is_finite() {
                        shapes.push((l, t, (sx, kappa), at, bt, st));
                    }
                }
            }
        }
    }
    shapes.sort_by(|p, q| p.0.total_cmp(&q.0));
    let lbest = shapes.first().map_or(f64::INFINITY, |v| v.0);
    shapes.retain(|v| v.0 - lbest < SHAPE_SPAN_NATS);
    shapes.truncate(MAX_SHAPES);
    if shapes.is_empty() {
        shapes.push((0.0, ramp, sxy, a, b, s));
    }
    // The second posterior spans ±5σ of the first (never narrower than 5 cm): a sparse target's
    // posterior can be 10 cm wide and must not be cut by the grid.
    let sd1 = (0.5 * (cov1[0][0] + cov1[1][1])).sqrt();
    let (centre, cov, weights) = grid_posterior_mixture(
        shapes.len(),
        |m, x, y| {
            let (_, t, sk, at, bt, st) = shapes[m];
            loss_at([x, y], at, bt, st, t, sk)
        },
        c1,
        (5.0 * sd1).clamp(0.05, 0.5),
        [MIXTURE_FIRST_HALF_STEPS, MIXTURE_HALF_STEPS],
    );
    // The model reported (and the rim band) is the shape of most weight.
    let top = (0..shapes.len())
        .max_by(|&i, &j| weights[i].total_cmp(&weights[j]))
        .unwrap_or(0);
    (_, ramp, sxy, a, b, s) = shapes[top];
    let (sxy, _) = sxy;
    let sd_c = (0.5 * (cov[0][0] + cov[1][1])).sqrt();

    // (4) Elevation from the plate: every return inside the circle (on the upper surface of a
    // raised plate) weighted by the probability that it is no mixed return, i.e. that its
    // footprint lies wholly on the plate: its true distance from the true centre, about
    // N(d, σ_c² + σ_xy²), is below R − the ramp's full reach. A hard rim band several σ wide
    // would drop most of a sparse plate's returns; returns beyond R never take part.
    let edge_sd = ramp.sd().hypot(sxy);
    let core_rim_m = (3.0 * edge_sd + 2.0 * sd_c).max(0.1);
    let dist = |p: &LidarPoint| (p.x - centre[0]).hypot(p.y - centre[1]);
    let unmixed_sd = sd_c.hypot(sxy).max(1e-3);
    let on_surface: Vec<(f64, f64)> = pts
        .iter()
        .zip(&on_top)
        .filter(|(p, top)| dist(p) < radius && (!raised || **top))
        .map(|(p, _)| {
            let w = normal_cdf((radius - ramp.full_reach() - dist(p)) / unmixed_sd);
            (p.z, w)
        })
        .collect();
    let n_eff = |v: &[(f64, f64)]| {
        let (s1, s2) = v
            .iter()
            .fold((0.0, 0.0), |(s1, s2), &(_, w)| (s1 + w, s2 + w * w));
        if s2 > 0.0 { s1 * s1 / s2 } else { 0.0 }
    };
    let mut zs_core = on_surface.clone();
    let elevation_fallback = n_eff(&zs_core) < 3.0;
    if elevation_fallback {
        for v in &mut zs_core {
            v.1 = 1.0;
        }
    }
    if zs_core.is_empty() {
        return None;
    }
    // Gate stray returns (a bird, a person on the plate) at 5 robust σ, never tighter than 3 cm.
    let core_z: Vec<f64> = zs_core.iter().filter(|v| v.1 >= 0.5).map(|v| v.0).collect();
    let core_z = if core_z.is_empty() {
        zs_core.iter().map(|v| v.0).collect()
    } else {
        core_z
    };
    let mut sorted = core_z.clone();
    sorted.sort_by(f64::total_cmp);
    let med = sorted[sorted.len() / 2];
    let gate = (5.0 * mad_sigma(&core_z)).max(0.03);
    zs_core.retain(|v| (v.0 - med).abs() <= gate && v.1 > 0.0);
    if zs_core.is_empty() {
        return None;
    }
    let sw: f64 = zs_core.iter().map(|v| v.1).sum();
    let z = zs_core.iter().map(|v| v.0 * v.1).sum::<f64>() / sw;
    let ne = n_eff(&zs_core);
    let var_sample = if ne > 1.5 {
        zs_core.iter().map(|v| v.1 * (v.0 - z).powi(2)).sum::<f64>() / sw * ne / (ne - 1.0)
    } else {
        sigma_z * sigma_z
    };
    let var_z = var_sample.max(sigma_z * sigma_z * 0.25) / ne;
    let n_elevation_points = zs_core.iter().filter(|v| v.1 >= 0.5).count();

    // (5) Shape: bright inside, dark in the ring.
    let mid = a + 0.5 * b;
    // Bright fraction and count of the points at distance lo..hi from the centre.
    let frac = |lo: f64, hi: f64| {
        let sel: Vec<&LidarPoint> = pts.iter().filter(|p| (lo..hi).contains(&dist(p))).collect();
        let bright = sel
            .iter()
            .filter(|p| (p.intensity > mid) == (b > 0.0))
            .count();
        (bright as f64 / sel.len() as f64, sel.len())
    };
    // The core (inside minus the rim) of a sparse plate can be empty: judge the whole circle
    // then (its returns are more than half on the plate).
    let (mut inside_bright_fraction, n_core) = frac(0.0, radius - core_rim_m.min(0.5 * radius));
    if n_core < 3 {
        inside_bright_fraction = frac(0.0, radius).0;
    }
    let ring_bright_fraction = frac(radius + 0.2, outer).0;
    // A disc mostly dark inside is no plate: the contrast came from a few glints.
    if inside_bright_fraction.is_nan() || inside_bright_fraction < 0.5 {
        return None;
    }

    // Segmentation for the other estimators: plate labels within R + 0.3 m of the detected
    // centre (height labels on a raised plate, intensity elsewhere).
    let plate_points: Vec<usize> = pts
        .iter()
        .zip(&on_top)
        .enumerate()
        .filter(|(_, (p, top))| {
            (p.x - c0[0]).hypot(p.y - c0[1]) < radius + 0.3
                && if raised {
                    **top
                } else {
                    (p.intensity > mid) == (b > 0.0)
                }
        })
        .map(|(k, _)| near[k])
        .collect();
    let edge_zone: Vec<[f64; 2]> = plate_points
        .iter()
        .map(|&i| [local[i].x, local[i].y])
        .filter(|q| (q[0] - centre[0]).hypot(q[1] - centre[1]) > radius - 0.3)
        .collect();
    let n_edge = pts
        .iter()
        .filter(|p| (dist(p) - radius).abs() < 0.1)
        .count();
    Some(PlateFit {
        centre,
        cov,
        z,
        var_z,
        model: PlateModel {
            plate_intensity: a + b,
            ground_intensity: a,
            intensity_noise: s,
            edge_sd_m: ramp.sd(),
            position_noise_m: sxy,
            height_step_m,
            raised,
            detection_t,
            inside_bright_fraction,
            ring_bright_fraction,
            n_elevation_points,
            rim_m: ramp.full_reach(),
        },
        plate_points,
        n_edge,
        coverage_deg: coverage_deg(&edge_zone, centre),
        elevation_fallback,
    })
}
