//! Boresight from the point-to-plane misfit of overlapping strips over 3-D surfaces: the
//! calibration of dense strips where no tie patch of [`crate::auto_ties`] qualifies (a UAV pass
//! over a car or a tent: walls, a roof, rough ground, no flat patch with paint).
//!
//! Every strip is sampled evenly (at most [`SurfaceOptions::samples_per_strip`] points); each
//! sample point `p` of strip `a` takes its [`SurfaceOptions::neighbours`] nearest points in 3-D
//! of every other strip `b` (all within [`SurfaceOptions::max_neighbour_m`], their own plane no
//! rougher than [`SurfaceOptions::max_roughness_m`] RMS). The residual is the signed distance of
//! `p` to the least-squares plane of those neighbours, all re-georeferenced with the trial
//! mounting: `r = n · (p − c)`, the plane refitted at every trial and its normal kept on the side
//! of the normal found at the start of the round (a wall's normal is horizontal; its sign must not
//! flip between two evaluations of the Jacobian). Levenberg–Marquardt runs over the boresight
//! angles (the lever arm is held: over one object seen from a few tens of metres a lever-arm
//! change is a shift the angles and the trajectory also make). As the mounting moves the points
//! by decimetres, the neighbours are searched again around the solution for
//! [`SurfaceOptions::rounds`] rounds (iterative closest point in its point-to-plane form; Chen,
//! Y., Medioni, G., "Object modelling by registration of multiple range images", Image and
//! Vision Computing 10(3), 1992). The same idea for the boresight of a laser scanner is the
//! rigorous self-calibration of Skaloud, J., Lichti, D., "Rigorous approach to bore-sight
//! self-calibration in airborne laser scanning", ISPRS Journal of Photogrammetry and Remote
//! Sensing 61(1), 2006, with planes found in the data rather than picked. With
//! [`CalibrationOptions::trajectory_sigma`] the reported σ also carry each strip's navigation
//! error, which the surfaces cannot tell from a boresight error of that strip.
//!
//! Which angles are determined is decided as for the ties ([`crate::calibrate_vtpm`] with a
//! trajectory σ): on the fit's own scatter (σ0, at least [`CalibrationOptions::sigma_floor_m`],
//! and the normal matrix) against [`CalibrationOptions::max_sigma_angle_rad`]; the navigation
//! error is added to the σ afterwards and holds nothing. An angle the overlap hardly sees (yaw
//! between lines flown the same way) is held at the prior; one whose σ is mostly the navigation
//! error is reported with that σ.

use crate::calibrate::{
    Calibration, CalibrationOptions, Method, Solved, TieReport, check_calibration_strips,
    solve_with_observability,
};
use crate::error::{Error, Result};
use crate::lm::LmModel;
use crate::params::{PARAM_COUNT, mounting_from_vector, mounting_to_vector};
use crate::strip::{Georeferencing, Strip, TrajectoryOffset};
use crate::weighting::{TrajectorySigma, gauss_markov_modes};
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use lidarqa_model::{Mounting, fit_plane};
use nalgebra::{DMatrix, DVector, Vector3};
use rayon::prelude::*;
use std::num::NonZero;

/// Options of the point-to-plane calibration over 3-D surfaces (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceOptions {
    /// Most sample points taken from each strip (evenly over its points).
    pub samples_per_strip: usize,
    /// Nearest points of the other strip that define the plane at a sample point.
    pub neighbours: usize,
    /// Farthest of those neighbours from the sample point, m: beyond it the sample point lies
    /// outside the other strip's cover.
    pub max_neighbour_m: f64,
    /// Largest RMS distance of the neighbours from their own plane, m (vegetation, edges and
    /// corners are left out).
    pub max_roughness_m: f64,
    /// Rounds of neighbour search and solution.
    pub rounds: usize,
}

impl Default for SurfaceOptions {
    fn default() -> Self {
        SurfaceOptions {
            samples_per_strip: 4000,
            neighbours: 12,
            max_neighbour_m: 0.5,
            max_roughness_m: 0.05,
            rounds: 4,
        }
    }
}

/// One sample point and the plane of its neighbours in another strip.
#[derive(Debug, Clone)]
struct SurfacePatch {
    strip: usize,
    point: usize,
    other: usize,
    neighbours: Vec<usize>,
    /// The neighbours' plane normal when the round began (orients the refitted normal).
    normal: Vector3<f64>,
}

#[derive(Clone)]
struct SurfaceProblem<'a> {
    strips: &'a [Strip],
    patches: Vec<SurfacePatch>,
}

impl SurfaceProblem<'_> {
    /// Each patch's signed distance (m) and its normal, at mounting vector `x`.
    fn distances(&self, x: &[f64; PARAM_COUNT]) -> Vec<(f64, Vector3<f64>)> {
        self.distances_offset(x, None)
    }

    /// [`SurfaceProblem::distances`] with the trajectory of strip `offset.0` off by `offset.1`.
    fn distances_offset(
        &self,
        x: &[f64; PARAM_COUNT],
        offset: Option<(usize, &TrajectoryOffset)>,
    ) -> Vec<(f64, Vector3<f64>)> {
        let g = Georeferencing::new(&mounting_from_vector(x));
        let at = |s: usize, k: usize| {
            let p = &self.strips[s].points[k];
            match offset {
                Some((o, off)) if o == s => g.apply_offset(p, off),
                _ => g.apply_vector(p),
            }
        };
        self.patches
            .par_iter()
            .map(|p| {
                let nb: Vec<Vector3<f64>> = p.neighbours.iter().map(|&k| at(p.other, k)).collect();
                match fit_plane(&nb) {
                    Some(pl) => {
                        let n = if pl.normal.dot(&p.normal) < 0.0 {
                            -pl.normal
                        } else {
                            pl.normal
                        };
                        let q = at(p.strip, p.point);
                        (n.dot(&(q - pl.centroid)), n)
                    }
                    None => (0.0, p.normal),
                }
            })
            .collect()
    }
}

impl LmModel for SurfaceProblem<'_> {
    fn residuals(&self, x: &[f64; PARAM_COUNT]) -> Vec<f64> {
        self.distances(x).into_iter().map(|(d, _)| d).collect()
    }
    fn accept(&mut self, _x: &[f64; PARAM_COUNT]) {}
}

/// The patches at `mounting` (module docs).
fn build_patches(
    strips: &[Strip],
    mounting: &Mounting,
    opts: &SurfaceOptions,
) -> Vec<SurfacePatch> {
    let g = Georeferencing::new(mounting);
    let positions: Vec<Vec<[f64; 3]>> = strips
        .iter()
        .map(|s| {
            s.points
                .par_iter()
                .map(|p| g.apply_vector(p).into())
                .collect()
        })
        .collect();
    let trees: Vec<ImmutableKdTree<f64, 3>> = positions
        .iter()
        .map(|p| ImmutableKdTree::new_from_slice(p))
        .collect();
    let k = NonZero::new(opts.neighbours).unwrap_or(NonZero::<usize>::MIN);
    let max2 = opts.max_neighbour_m * opts.max_neighbour_m;
    let mut out = Vec::new();
    for (a, pa) in positions.iter().enumerate() {
        let step = (pa.len() / opts.samples_per_strip.max(1)).max(1);
        for (b, pb) in positions.iter().enumerate() {
            if a == b || pb.len() < opts.neighbours {
                continue;
            }
            let found: Vec<SurfacePatch> = (0..pa.len())
                .step_by(step)
                .collect::<Vec<_>>()
                .par_iter()
                .filter_map(|&i| {
                    let nn = trees[b].nearest_n::<SquaredEuclidean>(&pa[i], k);
                    if nn.len() < opts.neighbours || nn.iter().any(|n| n.distance > max2) {
                        return None;
                    }
                    let neighbours: Vec<usize> = nn.iter().map(|n| n.item as usize).collect();
                    let pts: Vec<Vector3<f64>> =
                        neighbours.iter().map(|&j| Vector3::from(pb[j])).collect();
                    let pl = fit_plane(&pts)?;
                    let rough = (pl.eigenvalues[0].max(0.0) / pts.len() as f64).sqrt();
                    (rough <= opts.max_roughness_m).then_some(SurfacePatch {
                        strip: a,
                        point: i,
                        other: b,
                        neighbours,
                        normal: pl.normal,
                    })
                })
                .collect();
            out.extend(found);
        }
    }
    out
}

/// Boresight by point-to-plane over the strips' 3-D overlap (module docs), starting from and
/// reported against `prior`. The report's ties are one per ordered pair of strips (`a→b`): the
/// RMS of its sample points' distances, east / north / up of the distance along the normal.
///
/// # Errors
/// Invalid strips or options; [`Error::NothingUsable`] when fewer than 100 sample points have a
/// planar neighbourhood in another strip; the solver's errors.
pub fn calibrate_surfaces(
    strips: &[Strip],
    prior: &Mounting,
    options: &CalibrationOptions,
    surfaces: &SurfaceOptions,
) -> Result<Calibration> {
    check_calibration_strips(strips)?;
    if !(surfaces.max_neighbour_m > 0.0
        && surfaces.max_roughness_m > 0.0
        && surfaces.neighbours >= 3
        && surfaces.rounds >= 1)
    {
        return Err(Error::InvalidOption {
            name: "surface options",
            expected: "radii > 0, at least 3 neighbours and 1 round",
            value: surfaces.neighbours as f64,
        });
    }
    let mut opts = *options;
    opts.solve = [false, false, false, true, true, true];
    let x_prior = mounting_to_vector(prior);
    let mut x = x_prior;
    let mut last = None;
    // A parameter the data do not determine is held at the prior (as `calibration.json` says);
    // one held in the last round but free before gets one more round from its prior.
    let mut round = 0;
    while round < surfaces.rounds
        || last
            .as_ref()
            .is_some_and(|(_, s): &(SurfaceProblem<'_>, Solved<_>)| {
                (0..PARAM_COUNT).any(|i| !s.observable[i] && s.x[i] != x_prior[i])
            })
    {
        round += 1;
        if round > surfaces.rounds + 2 {
            break;
        }
        let patches = build_patches(strips, &mounting_from_vector(&x), surfaces);
        if patches.len() < 100 {
            return Err(Error::NothingUsable {
                what: "surface patch",
                reason: format!(
                    "{} sample points have {} neighbours within {} m in another strip on a plane \
                     no rougher than {} m (at least 100 are needed)",
                    patches.len(),
                    surfaces.neighbours,
                    surfaces.max_neighbour_m,
                    surfaces.max_roughness_m
                ),
            });
        }
        let problem = SurfaceProblem { strips, patches };
        // The holds are the ties' rule on the unweighted fit (module docs); the trajectory's
        // share of the σ is added after the last round.
        let solved =
            solve_with_observability(&problem, x, problem.patches.len(), &opts, false, None)?;
        x = solved.x;
        for i in 0..PARAM_COUNT {
            if !solved.observable[i] {
                x[i] = x_prior[i];
            }
        }
        last = Some((problem, solved));
    }
    let Some((problem, solved)) = last else {
        unreachable!("at least one round")
    };
    let before = problem.distances(&x_prior);
    let after = problem.distances(&solved.x);
    let mut pairs: Vec<(usize, usize)> =
        problem.patches.iter().map(|p| (p.strip, p.other)).collect();
    pairs.sort_unstable();
    pairs.dedup();
    let rms = |d: &[(f64, Vector3<f64>)], a: usize, b: usize| -> [f64; 3] {
        let mut acc = [0.0; 3];
        let mut n = 0usize;
        for (p, (v, normal)) in problem.patches.iter().zip(d) {
            if (p.strip, p.other) == (a, b) {
                let e = normal * *v;
                // Local NED → east, north, up.
                for (k, c) in [e.y, e.x, -e.z].into_iter().enumerate() {
                    acc[k] += c * c;
                }
                n += 1;
            }
        }
        acc.map(|s| (s / n.max(1) as f64).sqrt())
    };
    let ties = pairs
        .iter()
        .map(|&(a, b)| TieReport {
            id: format!("surfaces {}→{}", strips[a].id, strips[b].id),
            strips: vec![strips[a].id.clone(), strips[b].id.clone()],
            control: false,
            residual_before_m: rms(&before, a, b),
            residual_after_m: rms(&after, a, b),
        })
        .collect();
    let mut solved = solved;
    if let Some(t) = &options.trajectory_sigma {
        add_trajectory_covariance(&problem, &mut solved, t);
    }
    let mut calibration = solved.into_calibration(Method::Plane, prior, &opts, ties);
    calibration.trajectory_sigma = options.trajectory_sigma;
    Ok(calibration)
}

/// Adds each strip's trajectory error (`t` at 1 σ) to the σ and correlations of the solved
/// parameters: `C += Σ d dᵀ` over every strip, component (north, east, up, roll, pitch,
/// heading) and mode `e` of it, with `d = −N⁻¹ Jᵀ ∂r/∂e` how the point-to-plane fit answers that
/// error. A component is constant over the strip, or with a correlation time the Karhunen–Loève
/// modes of its Gauss–Markov process over the strip's time span; strips are independent. The
/// same model of the trajectory as [`crate::weighting`]'s, which weights the ties with it.
///
/// Why: over a strip's seconds the navigation error is nearly constant, so the surfaces see it
/// as a boresight error of that strip, which σ0 of the point-to-plane scatter knows nothing of.
/// The fit stays unweighted, so this is the sandwich covariance of that estimator.
fn add_trajectory_covariance(
    problem: &SurfaceProblem<'_>,
    solved: &mut Solved<SurfaceProblem<'_>>,
    t: &TrajectorySigma,
) {
    let free: Vec<usize> = (0..PARAM_COUNT).filter(|&i| !solved.held[i]).collect();
    let j = &solved.jacobian;
    let k = free.len();
    if k == 0 || j.ncols() != k {
        return;
    }
    let mut extra = DMatrix::<f64>::zeros(k, k);
    for (s, strip) in problem.strips.iter().enumerate() {
        let (lo, hi) = strip
            .points
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p.time_s), hi.max(p.time_s))
            });
        for (unit, sigma, tau) in t.unit_offsets() {
            if sigma.is_nan() || sigma <= 0.0 {
                continue;
            }
            let profiles = match tau {
                Some(tau) if hi > lo => gauss_markov_modes(lo, hi, tau)
                    .into_iter()
                    .map(Some)
                    .collect(),
                _ => vec![None],
            };
            for profile in profiles {
                let offset = |sign: f64| TrajectoryOffset {
                    position_m: unit.position_m * sigma * sign,
                    attitude_rad: unit.attitude_rad.map(|v| v * sigma * sign),
                    profile: profile.clone(),
                };
                let rp = problem.distances_offset(&solved.x, Some((s, &offset(1.0))));
                let rm = problem.distances_offset(&solved.x, Some((s, &offset(-1.0))));
                let mut jt_a = DVector::<f64>::zeros(k);
                for (row, ((a, _), (b, _))) in rp.iter().zip(&rm).enumerate() {
                    jt_a += j.row(row).transpose() * (0.5 * (a - b));
                }
                let d = -(&solved.inverse_normal * jt_a);
                extra += &d * d.transpose();
            }
        }
    }
    let cov = |a: usize, b: usize| -> f64 {
        let (ia, ib) = (free[a], free[b]);
        let fit = match (
            solved.sigma[ia],
            solved.sigma[ib],
            solved.correlation[ia][ib],
        ) {
            (Some(sa), Some(sb), Some(r)) => sa * sb * r,
            _ => 0.0,
        };
        fit + extra[(a, b)]
    };
    let total = DMatrix::from_fn(k, k, cov);
    for (a, &ia) in free.iter().enumerate() {
        solved.sigma[ia] = Some(total[(a, a)].sqrt());
        for (b, &ib) in free.iter().enumerate() {
            solved.correlation[ia][ib] =
                Some(total[(a, b)] / (total[(a, a)] * total[(b, b)]).sqrt());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::strip::RawPoint;
    use lidarqa_model::{Attitude, LinearObservation, Ned, rotation_zyx};

    /// Height (m, up) of the test scene: flat ground and a tent-like ridge along north, 2 m high,
    /// its faces sloped 45°.
    fn height(_n: f64, e: f64) -> f64 {
        (2.0 - e.abs()).max(0.0)
    }

    /// One pass at 20 m over the scene, heading north (`sign` 1) or south (−1), 5 m east of the
    /// ridge times `sign`, with a head on its side firing channels 20° and 10° to either side of
    /// its spin plane; the points made with `truth` and delivered with `nominal` (module docs).
    fn pass(id: &str, sign: f64, truth: &Mounting, nominal: &Mounting) -> Strip {
        let (r_true, r_nom) = (truth.scanner_to_body(), nominal.scanner_to_body());
        let mut points = Vec::new();
        for k in 0..120 {
            let origin = Vector3::new(sign * (-15.0 + 0.25 * f64::from(k)), 5.0 * sign, -20.0);
            let attitude = Attitude::from_degrees(1.0, -0.5, if sign > 0.0 { 0.0 } else { 180.0 });
            let r_l = rotation_zyx(attitude.roll_rad, attitude.pitch_rad, attitude.heading_rad);
            for el in [-20.0f64, -10.0, 10.0, 20.0] {
                for a in 0..61 {
                    let (el, az) = (el.to_radians(), (-60.0 + 2.0 * f64::from(a)).to_radians());
                    let d = Vector3::new(el.sin(), el.cos() * az.sin(), el.cos() * az.cos());
                    // March along the true beam to the scene (1 cm steps, then halving).
                    let at = |rho: f64| origin + r_l * (r_true * d * rho + truth.lever_arm_m);
                    let below = |rho: f64| {
                        let p = at(rho);
                        -p.z <= height(p.x, p.y)
                    };
                    let Some(mut hi) = (1..6000).map(|i| f64::from(i) * 0.01).find(|r| below(*r))
                    else {
                        continue;
                    };
                    let mut lo = hi - 0.01;
                    for _ in 0..40 {
                        let mid = 0.5 * (lo + hi);
                        if below(mid) { hi = mid } else { lo = mid }
                    }
                    let s = d * hi;
                    points.push(RawPoint {
                        position_m: Ned::from_vector(
                            origin + r_l * (r_nom * s + nominal.lever_arm_m),
                        ),
                        origin_m: Ned::from_vector(origin),
                        attitude,
                        observation: LinearObservation {
                            range_m: hi,
                            scan_angle_rad: s.y.atan2(s.z),
                        },
                        out_of_plane_m: s.x,
                        time_s: f64::from(k) * 0.1,
                        intensity: 0,
                    });
                }
            }
        }
        Strip {
            id: id.into(),
            points,
        }
    }

    #[test]
    fn recovers_an_injected_boresight_of_a_multibeam_head() {
        let nominal = Mounting {
            lever_arm_m: Vector3::new(0.161, 0.0, -0.016),
            ..Mounting::default()
        };
        let truth = Mounting {
            boresight_roll_rad: 0.3f64.to_radians(),
            boresight_pitch_rad: (-0.2f64).to_radians(),
            boresight_yaw_rad: 0.4f64.to_radians(),
            ..nominal
        };
        let strips = [
            pass("n", 1.0, &truth, &nominal),
            pass("s", -1.0, &truth, &nominal),
        ];
        let c = calibrate_surfaces(
            &strips,
            &nominal,
            &CalibrationOptions::default(),
            // The test's beams are 0.25 m apart along track and 0.7 m across.
            &SurfaceOptions {
                max_neighbour_m: 2.5,
                ..SurfaceOptions::default()
            },
        )
        .unwrap();
        let got = mounting_to_vector(&c.mounting);
        let want = mounting_to_vector(&truth);
        for i in 3..6 {
            assert!(
                (got[i] - want[i]).abs().to_degrees() < 0.02,
                "parameter {i}: {}° against {}°",
                got[i].to_degrees(),
                want[i].to_degrees()
            );
        }
    }
}
