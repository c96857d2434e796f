//! The point-to-plane baseline (boresight only), as Leica Attune (Burman 2000;
//! Zhang & Jiang (2011), ref. 10) against which Zhang & Jiang (2011) compare the VTPM, and the
//! check-plane RMS of Zhang & Jiang (2011) eq. (13).
//!
//! A *patch* is a horizontal position; in every strip that covers it the points within
//! [`PlaneOptions::radius_m`] are taken and their coplanar subset kept (RANSAC). At each trial
//! mounting all kept points of the patch, from every strip, are re-georeferenced and one plane is
//! fitted through them by least squares; the residuals are their distances to it. Fitting the
//! plane inside the residual function eliminates its three parameters (variable projection), so
//! Levenberg–Marquardt runs over the mounting only. Flat patches constrain the vertical only;
//! sloped patches of several aspects (roofs) are what make along- and across-track errors
//! visible, which is why the method needs them and the VTPM does not.

use crate::calibrate::{
    Calibration, CalibrationOptions, Method, TieReport, check_calibration_strips,
    solve_with_observability,
};
use crate::error::{Error, Result};
use crate::geometry::ransac_plane;
use crate::lm::LmModel;
use crate::params::{PARAM_COUNT, mounting_from_vector, mounting_to_vector};
use crate::strip::{Georeferencing, Strip, check_strips};
use crate::vtpm::{Indexed, mix_seed};
use lidarqa_model::Mounting;
use lidarqa_model::fit_plane;
use nalgebra::Vector3;

/// Options of the plane patches.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaneOptions {
    /// Patch radius, m.
    pub radius_m: f64,
    /// RANSAC inlier threshold, m.
    pub ransac_threshold_m: f64,
    /// RANSAC iterations.
    pub ransac_iterations: usize,
    /// Minimum coplanar points of one strip in a patch.
    pub min_points: usize,
    /// RANSAC seed.
    pub seed: u64,
}

impl Default for PlaneOptions {
    fn default() -> Self {
        PlaneOptions {
            radius_m: 2.5,
            ransac_threshold_m: 0.06,
            ransac_iterations: 200,
            min_points: 8,
            seed: 3,
        }
    }
}

#[derive(Debug, Clone)]
struct Patch {
    /// (strip index, point indices).
    members: Vec<(usize, Vec<usize>)>,
}

fn build_patches(
    idx: &Indexed<'_>,
    centres: &[[f64; 2]],
    prior: &Mounting,
    opts: &PlaneOptions,
) -> Vec<Patch> {
    let g = Georeferencing::new(prior);
    let mut out = Vec::new();
    for (ci, c) in centres.iter().enumerate() {
        let mut members = Vec::new();
        for s in 0..idx.strips.len() {
            let near = crate::strip::within(
                &idx.grids[s],
                &idx.strips[s].points,
                c[0],
                c[1],
                opts.radius_m,
            );
            if near.len() < opts.min_points {
                continue;
            }
            let pos: Vec<Vector3<f64>> = near
                .iter()
                .map(|&k| g.apply_vector(&idx.strips[s].points[k]))
                .collect();
            let Some((_, inl)) = ransac_plane(
                &pos,
                opts.ransac_threshold_m,
                opts.ransac_iterations,
                mix_seed(opts.seed, ci, s),
            ) else {
                continue;
            };
            if inl.len() >= opts.min_points {
                members.push((s, inl.iter().map(|&i| near[i]).collect()));
            }
        }
        if members.len() >= 2 {
            out.push(Patch { members });
        }
    }
    out
}

#[derive(Clone)]
struct PlaneProblem<'a> {
    strips: &'a [Strip],
    patches: Vec<Patch>,
}

impl PlaneProblem<'_> {
    /// Per patch: the points (all strips) at `x` and the common plane.
    fn distances(&self, x: &[f64; PARAM_COUNT]) -> Vec<Vec<(usize, Vector3<f64>)>> {
        let g = Georeferencing::new(&mounting_from_vector(x));
        self.patches
            .iter()
            .map(|p| {
                let pts: Vec<(usize, Vector3<f64>)> = p
                    .members
                    .iter()
                    .flat_map(|(s, ks)| {
                        ks.iter()
                            .map(move |&k| (*s, g.apply_vector(&self.strips[*s].points[k])))
                    })
                    .collect();
                let only: Vec<Vector3<f64>> = pts.iter().map(|(_, v)| *v).collect();
                match fit_plane(&only) {
                    Some(pl) => pts
                        .iter()
                        .map(|(s, v)| (*s, pl.normal * pl.distance(v)))
                        .collect(),
                    None => Vec::new(),
                }
            })
            .collect()
    }
}

impl LmModel for PlaneProblem<'_> {
    fn residuals(&self, x: &[f64; PARAM_COUNT]) -> Vec<f64> {
        self.distances(x)
            .into_iter()
            .flatten()
            // Signed distance, positive upwards whichever sense the normal has: d = −sign(v.z)·|v| in NED.
            .map(|(_, v)| -(v.norm() * v.z.signum()))
            .collect()
    }
    fn accept(&mut self, _x: &[f64; PARAM_COUNT]) {}
}

fn rms_enu(d: &[(usize, Vector3<f64>)]) -> [f64; 3] {
    let mut acc = [0.0; 3];
    for (_, v) in d {
        let e = [v.y, v.x, -v.z];
        for k in 0..3 {
            acc[k] += e[k] * e[k];
        }
    }
    acc.map(|a| (a / d.len().max(1) as f64).sqrt())
}

/// The point-to-plane baseline (module docs): boresight angles only by default
/// (`options.solve` is overridden to the three angles; the lever arm stays at `prior`, as
/// Attune, whose results Zhang & Jiang (2011) apply with a zero lever arm).
///
/// # Errors
/// As [`crate::calibrate_vtpm`]; [`Error::NothingUsable`] when no patch has coplanar points in two
/// strips.
pub fn calibrate_plane(
    strips: &[Strip],
    patch_centres: &[[f64; 2]],
    prior: &Mounting,
    options: &CalibrationOptions,
    plane: &PlaneOptions,
) -> Result<Calibration> {
    check_calibration_strips(strips)?;
    check_plane_options(plane)?;
    let idx = Indexed::new(strips, plane.radius_m);
    let patches = build_patches(&idx, patch_centres, prior, plane);
    if patches.is_empty() {
        return Err(Error::NothingUsable {
            what: "plane patch",
            reason: format!(
                "none of {} patch centres has at least {} coplanar points in two strips",
                patch_centres.len(),
                plane.min_points
            ),
        });
    }
    let observations: usize = patches
        .iter()
        .map(|p| p.members.iter().map(|(_, k)| k.len()).sum::<usize>() - 3)
        .sum();
    let mut opts = *options;
    opts.solve = [false, false, false, true, true, true];
    let x0 = mounting_to_vector(prior);
    let problem = PlaneProblem { strips, patches };
    let solved = solve_with_observability(&problem, x0, observations, &opts, false, None)?;
    let before = problem.distances(&x0);
    let after = problem.distances(&solved.x);
    let ties = problem
        .patches
        .iter()
        .enumerate()
        .zip(before.iter().zip(&after))
        .map(|((k, p), (b, a))| TieReport {
            id: format!("p{k}"),
            strips: p
                .members
                .iter()
                .map(|(s, _)| strips[*s].id.clone())
                .collect(),
            control: false,
            residual_before_m: rms_enu(b),
            residual_after_m: rms_enu(a),
        })
        .collect();
    Ok(solved.into_calibration(Method::Plane, prior, &opts, ties))
}

fn check_plane_options(plane: &PlaneOptions) -> Result<()> {
    if !(plane.radius_m.is_finite() && plane.radius_m > 0.0) {
        return Err(Error::InvalidOption {
            name: "radius_m",
            expected: "a finite number > 0",
            value: plane.radius_m,
        });
    }
    if plane.min_points < 3 {
        return Err(Error::InvalidOption {
            name: "min_points",
            expected: "at least 3",
            value: plane.min_points as f64,
        });
    }
    Ok(())
}

/// Check-plane RMS (Zhang & Jiang 2011, eq. 13, Table 3): for each check plane (a patch centre),
/// the points of every covering strip selected at `prior`, re-georeferenced with `mounting`, one
/// plane fitted through all of them, and `√(Σ d² / n)` of their distances to it, m. `None` for a
/// centre with fewer than two covering strips.
///
/// # Errors
/// Invalid strips or options.
pub fn check_plane_rms(
    strips: &[Strip],
    centres: &[[f64; 2]],
    prior: &Mounting,
    mounting: &Mounting,
    plane: &PlaneOptions,
) -> Result<Vec<Option<f64>>> {
    check_strips(strips)?;
    check_plane_options(plane)?;
    let idx = Indexed::new(strips, plane.radius_m);
    let x = mounting_to_vector(mounting);
    Ok(centres
        .iter()
        .map(|c| {
            let p = build_patches(&idx, std::slice::from_ref(c), prior, plane);
            let problem = PlaneProblem { strips, patches: p };
            let d = problem.distances(&x);
            d.first().filter(|v| !v.is_empty()).map(|v| {
                (v.iter().map(|(_, r)| r.norm_squared()).sum::<f64>() / v.len() as f64).sqrt()
            })
        })
        .collect())
}
