//! The virtual tie point model (Zhang & Jiang 2011, §2.3–2.4).
//!
//! A tie picked in strip `i` at horizontal position `(x, y)` becomes a *virtual tie point*: the
//! points of strip `i` within [`VtpmOptions::radius_m`] of the pick, their coplanar subset by
//! RANSAC (trimmed of the fringe of a neighbouring surface that its threshold lets in), a
//! Delaunay triangulation of that subset in plan (spade), and the triangle containing the pick,
//! whose three laser points `p1, p2, p3` carry the tie from then on:
//!
//! - **rule 1** (eq. 5): the tie's height is interpolated linearly in the triangle at `(x, y)`;
//! - **rule 2** (eq. 6): when the mounting changes, the three points are re-georeferenced from
//!   their raw observations and the tie moves rigidly with its triangle,
//!   `T₁ = R_rigid T₀ + Δ`, the rigid transform estimated from the old and new triangle
//!   (least squares, Kabsch). As in Zhang & Jiang (2011) step (4), "old" is the state of the
//!   previous accepted iteration, so the tie coordinates are carried from iteration to iteration.

use crate::error::{Error, Result};
use crate::geometry::{Plane, interpolate_z, ransac_plane, rigid_transform, trim_to_plane};
use crate::params::mounting_from_vector;
use crate::strip::{Georeferencing, GridIndex, Strip, TrajectoryOffset, within};
use lidarqa_model::{Ned, fit_plane};
use nalgebra::Vector3;
use rayon::prelude::*;
use spade::{DelaunayTriangulation, HasPosition, Point2, PositionInTriangulation, Triangulation};

/// Largest VTPM search radius, m: a tie is a local surface (Zhang & Jiang 2011: about the point
/// spacing), and the points searched grow with the radius squared.
pub const MAX_RADIUS_M: f64 = 50.0;
/// Most RANSAC iterations per tie and strip.
pub const MAX_RANSAC_ITERATIONS: usize = 100_000;

/// Options of the virtual tie point model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VtpmOptions {
    /// Search radius around a pick, m (Zhang & Jiang 2011: "e.g. 1 m, from the mean point
    /// spacing").
    pub radius_m: f64,
    /// RANSAC inlier threshold, point-to-plane distance, m.
    pub ransac_threshold_m: f64,
    /// RANSAC iterations (random triples tried).
    pub ransac_iterations: usize,
    /// Seed of RANSAC's random triples (each tie/strip derives its own from it).
    pub seed: u64,
    /// Carry each tie by every coplanar point of its window instead of Zhang & Jiang's (2011) one
    /// triangle: rule 1's height from their least-squares plane, rule 2's rigid motion fitted to
    /// all of them. Same model, √(n/3) less of the points' noise in every tie.
    pub patch: bool,
}

impl Default for VtpmOptions {
    fn default() -> Self {
        VtpmOptions {
            radius_m: 1.0,
            ransac_threshold_m: 0.05,
            ransac_iterations: 200,
            seed: 1,
            patch: false,
        }
    }
}

impl VtpmOptions {
    pub(crate) fn check(&self) -> Result<()> {
        let bad = |name, expected, value| {
            Err(Error::InvalidOption {
                name,
                expected,
                value,
            })
        };
        if !(self.radius_m.is_finite() && self.radius_m > 0.0 && self.radius_m <= MAX_RADIUS_M) {
            return bad(
                "radius_m",
                "a finite number > 0 and at most 50 m",
                self.radius_m,
            );
        }
        if !(self.ransac_threshold_m.is_finite() && self.ransac_threshold_m > 0.0) {
            return bad(
                "ransac_threshold_m",
                "a finite number > 0",
                self.ransac_threshold_m,
            );
        }
        if !(1..=MAX_RANSAC_ITERATIONS).contains(&self.ransac_iterations) {
            return bad(
                "ransac_iterations",
                "1 to 100000",
                self.ransac_iterations as f64,
            );
        }
        Ok(())
    }
}

/// How a tie observes the strips.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TieKind {
    /// A feature located in every strip (a road marking corner picked on the intensity image,
    /// Zhang & Jiang 2011, step 1): all three coordinates are observations.
    Feature,
    /// A point on a planar surface with no feature to fix it within the plane (a roof face found
    /// by the automatic search): only the component along the plane normal is an observation
    /// (a weight matrix `P = n nᵀ` in Zhang & Jiang (2011) eq. 4).
    Surface,
    /// A point on a linear marking (a centre line, one zebra stripe): located across the line and
    /// in height, but not along it, where a pick only reflects where the window was. The field is
    /// the horizontal unit vector across the line, local (north, east).
    Line([f64; 2]),
}

/// The pick of a tie in one strip, local frame.
#[derive(Debug, Clone, PartialEq)]
pub struct TiePick {
    /// The strip's id ([`Strip::id`]).
    pub strip: String,
    /// Local north, m.
    pub north_m: f64,
    /// Local east, m.
    pub east_m: f64,
}

/// A tie point: the same feature picked in two or more strips (SPEC §7 `tie,strip,x,y`, converted
/// to the local frame by the caller). Heights come from the VTPM, never from the picks.
#[derive(Debug, Clone, PartialEq)]
pub struct Tie {
    /// Identifier, unique.
    pub id: String,
    /// One pick per strip.
    pub picks: Vec<TiePick>,
    /// What the tie observes.
    pub kind: TieKind,
}

/// A surveyed target or checkpoint, local frame: an absolute observation
/// (tie coordinate − control).
///
/// With a [`Tie`] of the same id, that tie's picks are used and all three coordinates observe the
/// control. Without one, the point is picked at its own horizontal position in every strip that
/// covers it and only its height observes the control (a checkpoint on open flat ground: its plan
/// position in a strip is unknown, its height is not).
#[derive(Debug, Clone, PartialEq)]
pub struct NedControlPoint {
    /// Identifier.
    pub id: String,
    /// Surveyed position in the calibration's frame `L`, m.
    pub position_m: Ned,
    /// Radius of the target the control point marks, m, when it is one (Zhang et al. 2018: 0.8 m,
    /// raised above the ground). The height of a height-only control point is then the mean of the
    /// target's top points within 0.75 × this radius, never the ground around it.
    pub target_radius_m: Option<f64>,
    /// The survey's vertical 1-σ, m, when known (the control CSV's `sigma_v`): weighs the control
    /// against the ties when the trajectory weighting is on.
    pub sigma_vertical_m: Option<f64>,
}

#[derive(Clone, Copy)]
struct Vertex {
    p: Point2<f64>,
    k: usize,
}

impl HasPosition for Vertex {
    type Scalar = f64;
    fn position(&self) -> Point2<f64> {
        self.p
    }
}

/// One tie in one strip: the triangle of three laser points and the tie coordinate.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct VirtualTie {
    pub(crate) strip: usize,
    /// The laser points that carry the tie: Zhang & Jiang's (2011) triangle (3), the whole coplanar
    /// patch ([`VtpmOptions::patch`]) or a control target's top.
    pub(crate) vertices: Vec<usize>,
    /// Those points at the last accepted parameters, local NED.
    pub(crate) carried: Vec<Vector3<f64>>,
    /// The tie at the last accepted parameters, local NED.
    pub(crate) coord: Vector3<f64>,
    /// Unit normal of the coplanar patch, NED, `n_z ≥ 0` ([`lidarqa_model::fit_plane`]).
    pub(crate) normal: Vector3<f64>,
    /// The coplanar points of the window (strip point indices): the surface the tie lies on,
    /// refitted at each accepted state for the direction a surface tie observes along
    /// ([`TieSpec::along_normal`]).
    pub(crate) plane_points: Vec<usize>,
    /// A control target: the tie is the mean of its top points (`vertices`), re-georeferenced,
    /// not one triangle's: its height is observed with √n less range noise, and a target crossed
    /// by one or two scan lines (no triangle around its centre) still counts.
    pub(crate) target_mean: bool,
    /// The window around the pick is one plain level plane: (nearly) every point coplanar, no
    /// intensity edge ([`is_featureless`]), within 5° of level. Nothing there fixes where on
    /// the ground the pick was made.
    pub(crate) featureless: bool,
}

/// Level ground: a plane whose normal is within 5° of the vertical. Only there is a plain
/// window judged to locate nothing horizontally; on a sloped face the height along the slope
/// still ties the pick to the surface's position.
const LEVEL_MIN_COS: f64 = 0.996_194_698; // cos 5°

/// Share of a window's points that must be coplanar for it to be one plain plane.
const FEATURELESS_MIN_COPLANAR: f64 = 0.95;
/// Largest spread of a window's intensities, (p95 − p5) / median, for it to hold no marking: a
/// painted line or a target is several times as bright as the surface it is painted on, while
/// one surface's own intensity varies by tens of per cent.
const FEATURELESS_MAX_INTENSITY_SPREAD: f64 = 0.5;

/// Whether a window (its points' intensities, and how many of them are coplanar) is one plain
/// plane with no edge or marking: a hand pick there locates nothing horizontally, however
/// carefully the same x, y was typed into every strip.
fn is_featureless(intensities: &mut [u16], coplanar: usize) -> bool {
    let n = intensities.len();
    if n == 0 || (coplanar as f64) < FEATURELESS_MIN_COPLANAR * n as f64 {
        return false;
    }
    intensities.sort_unstable();
    let q = |f: f64| f64::from(intensities[((n - 1) as f64 * f).round() as usize]);
    let median = q(0.5);
    median > 0.0 && (q(0.95) - q(0.05)) / median <= FEATURELESS_MAX_INTENSITY_SPREAD
}

/// Strip indices and grids, built once.
pub(crate) struct Indexed<'a> {
    pub(crate) strips: &'a [Strip],
    pub(crate) grids: Vec<GridIndex>,
}

impl<'a> Indexed<'a> {
    pub(crate) fn new(strips: &'a [Strip], cell_m: f64) -> Indexed<'a> {
        let grids = strips
            .par_iter()
            .map(|s| {
                let xy: Vec<[f64; 2]> = s
                    .points
                    .iter()
                    .map(|p| [p.position_m.north_m(), p.position_m.east_m()])
                    .collect();
                GridIndex::new(&xy, cell_m)
            })
            .collect();
        Indexed { strips, grids }
    }

    pub(crate) fn strip_index(&self, id: &str) -> Option<usize> {
        self.strips.iter().position(|s| s.id == id)
    }

    /// Whether strip `s` has a point within `r` of (x, y).
    pub(crate) fn covers(&self, s: usize, x: f64, y: f64, r: f64) -> bool {
        !within(&self.grids[s], &self.strips[s].points, x, y, r).is_empty()
    }
}

/// A tie coordinate and its triangle, local NED.
pub(crate) type TieAt = (Vector3<f64>, Vec<Vector3<f64>>);

/// How far a VTPM window may grow around a pick no coplanar triangle holds, as a multiple of
/// [`VtpmOptions::radius_m`]: the radius that holds ~20 points on average may hold one scan line
/// only where lines are far apart and points along them close (a sawtooth scanner at 1.36 m by
/// 0.13 m); growing until the pick lies between two lines is the sampling's own answer.
pub(crate) const MAX_WINDOW_GROWTH: f64 = 4.0;

/// How far from a pick, or from a control point with an optional target radius, the tie model
/// reads a strip's points, m: a reader that keeps only the points within this of every pick and
/// control point (plus each strip's extreme points) gets the same ties as from whole strips.
pub fn tie_reach_m(opts: &VtpmOptions, target_radius_m: Option<f64>) -> f64 {
    let window = MAX_WINDOW_GROWTH * opts.radius_m * (1.0 + 1e-9);
    target_radius_m.map_or(window, |r| window.max(r + TARGET_SEARCH_MARGIN_M))
}

/// The coplanar points must be at least 1/this of the window's points.
const MIN_COPLANAR_DENOMINATOR: usize = 3;

/// Each growth step multiplies the window radius by this.
const WINDOW_GROWTH_STEP: f64 = 1.5;

/// One pick of a tie in one strip, as [`build_virtual_tie`] carries it.
#[derive(Clone, Copy)]
pub(crate) struct PickInStrip<'a> {
    /// The strips and their search grids.
    pub(crate) idx: &'a Indexed<'a>,
    /// The strip's index in `idx`.
    pub(crate) strip: usize,
    /// The tie's id, for errors.
    pub(crate) tie_id: &'a str,
    /// The pick, local north, m.
    pub(crate) x: f64,
    /// The pick, local east, m.
    pub(crate) y: f64,
    /// The mounting the points are georeferenced with.
    pub(crate) g: &'a Georeferencing,
    /// Window radius, RANSAC and carrier settings.
    pub(crate) opts: &'a VtpmOptions,
    /// Seed of the RANSAC draws.
    pub(crate) seed: u64,
}

/// Builds the virtual tie of `tie_id` in strip `strip` at the pick (x, y) with the mounting `g`
/// (Zhang & Jiang 2011, step 2, then rule 1 for the initial height).
///
/// The window starts at [`VtpmOptions::radius_m`] and grows by [`WINDOW_GROWTH_STEP`] (up to
/// [`MAX_WINDOW_GROWTH`] times) while RANSAC finds no plane or no Delaunay triangle of the
/// coplanar points holds the pick: the window follows the strip's sampling, however anisotropic,
/// and stays as small as the sampling allows (rule 2's rigid motion is best on a small patch).
pub(crate) fn build_virtual_tie(pick: &PickInStrip<'_>) -> Result<VirtualTie> {
    let opts = pick.opts;
    let mut radius_m = opts.radius_m;
    loop {
        let out = build_virtual_tie_within(pick, radius_m);
        let grown = radius_m * WINDOW_GROWTH_STEP;
        match out {
            Err(Error::NoCoplanarTriangle { .. }) | Err(Error::TieOutsideStrip { .. })
                if grown <= MAX_WINDOW_GROWTH * opts.radius_m * (1.0 + 1e-9) =>
            {
                radius_m = grown;
            }
            _ => return out,
        }
    }
}

/// [`build_virtual_tie`] with one window radius.
fn build_virtual_tie_within(pick: &PickInStrip<'_>, radius_m: f64) -> Result<VirtualTie> {
    let PickInStrip {
        idx,
        strip: s,
        tie_id,
        x,
        y,
        g,
        opts,
        seed,
    } = *pick;
    let strip = &idx.strips[s];
    let near = within(&idx.grids[s], &strip.points, x, y, radius_m);
    if near.is_empty() {
        return Err(Error::TieOutsideStrip {
            tie: tie_id.to_string(),
            strip: strip.id.clone(),
            radius_m,
            north_m: x,
            east_m: y,
        });
    }
    let no_tri = |reason: String| Error::NoCoplanarTriangle {
        tie: tie_id.to_string(),
        strip: strip.id.clone(),
        reason,
    };
    let pos: Vec<Vector3<f64>> = near
        .iter()
        .map(|&k| g.apply_vector(&strip.points[k]))
        .collect();
    let (plane, inliers): (Plane, Vec<usize>) =
        ransac_plane(&pos, opts.ransac_threshold_m, opts.ransac_iterations, seed)
            .and_then(|(plane, inliers)| trim_to_plane(&pos, inliers, plane))
            .ok_or_else(|| {
                no_tri(format!(
                    "ransac found no plane among {} points within {radius_m:.2} m",
                    pos.len(),
                ))
            })?;
    // A "plane" through a small minority of the window is three random points, not the surface:
    // the pick would be carried by noise.
    if inliers.len() * MIN_COPLANAR_DENOMINATOR < pos.len() {
        return Err(no_tri(format!(
            "only {} of {} points within {radius_m:.2} m are coplanar",
            inliers.len(),
            pos.len()
        )));
    }
    let mut dt: DelaunayTriangulation<Vertex> = DelaunayTriangulation::new();
    for &i in &inliers {
        dt.insert(Vertex {
            p: Point2::new(pos[i].x, pos[i].y),
            k: i,
        })
        .map_err(|e| no_tri(format!("delaunay: {e:?}")))?;
    }
    let face_vertices = |f: spade::handles::FixedFaceHandle<spade::handles::InnerTag>| {
        dt.face(f).vertices().map(|v| v.data().k)
    };
    let local = match dt.locate(Point2::new(x, y)) {
        PositionInTriangulation::OnFace(f) => Some(face_vertices(f)),
        PositionInTriangulation::OnEdge(e) => {
            let e = dt.directed_edge(e);
            e.face()
                .as_inner()
                .or_else(|| e.rev().face().as_inner())
                .map(|f| face_vertices(f.fix()))
        }
        PositionInTriangulation::OnVertex(v) => dt
            .vertex(v)
            .out_edges()
            .find_map(|e| e.face().as_inner())
            .map(|f| face_vertices(f.fix())),
        _ => None,
    }
    .ok_or_else(|| {
        no_tri(format!(
            "the pick is outside the {} coplanar points within {radius_m:.2} m",
            inliers.len()
        ))
    })?;
    let tri = local.map(|i| pos[i]);
    let z = interpolate_z(&tri, x, y)
        .ok_or_else(|| no_tri("the enclosing triangle is degenerate".into()))?;
    let mut intensities: Vec<u16> = near.iter().map(|&k| strip.points[k].intensity).collect();
    let featureless =
        plane.normal.z.abs() >= LEVEL_MIN_COS && is_featureless(&mut intensities, inliers.len());
    if opts.patch {
        let z = (plane.offset() - plane.normal.x * x - plane.normal.y * y) / plane.normal.z;
        if !z.is_finite() {
            return Err(no_tri("the coplanar patch is vertical".into()));
        }
        return Ok(VirtualTie {
            strip: s,
            vertices: inliers.iter().map(|&i| near[i]).collect(),
            carried: inliers.iter().map(|&i| pos[i]).collect(),
            coord: Vector3::new(x, y, z),
            normal: plane.normal,
            plane_points: inliers.iter().map(|&i| near[i]).collect(),
            target_mean: false,
            featureless,
        });
    }
    Ok(VirtualTie {
        strip: s,
        vertices: local.map(|i| near[i]).to_vec(),
        carried: tri.to_vec(),
        coord: Vector3::new(x, y, z),
        normal: plane.normal,
        plane_points: inliers.iter().map(|&i| near[i]).collect(),
        target_mean: false,
        featureless,
    })
}

/// The virtual tie of a control target of radius `radius_m` in strip `s`: its top points.
///
/// The strip's points are still off by the uncalibrated mounting (a boresight error of 0.05° moves
/// them ~0.7 m at 800 m), so the target is first found as the points standing above the local
/// ground (more than [`TARGET_MIN_HEIGHT_M`] above its 20th height percentile) within the radius
/// plus [`TARGET_SEARCH_MARGIN_M`] of the surveyed centre; the tie is those of them within 2 × the
/// RANSAC threshold of their median height and within the radius of their centroid (never a
/// ground point at the rim). `None` when fewer than three remain (the strip does not observe the
/// target).
fn build_target_tie(
    idx: &Indexed<'_>,
    s: usize,
    x: f64,
    y: f64,
    radius_m: f64,
    g: &Georeferencing,
    opts: &VtpmOptions,
) -> Option<VirtualTie> {
    let strip = &idx.strips[s];
    let at = |k: usize| g.apply_vector(&strip.points[k]);
    let around = within(
        &idx.grids[s],
        &strip.points,
        x,
        y,
        radius_m + TARGET_SEARCH_MARGIN_M,
    );
    let placed: Vec<(usize, Vector3<f64>)> = around.iter().map(|&k| (k, at(k))).collect();
    let mut ups: Vec<f64> = placed.iter().map(|(_, p)| -p.z).collect();
    ups.sort_by(f64::total_cmp);
    let ground_up = *ups.get(ups.len() / 5)?;
    let raised: Vec<(usize, Vector3<f64>)> = placed
        .into_iter()
        .filter(|(_, p)| -p.z > ground_up + TARGET_MIN_HEIGHT_M)
        .collect();
    let mut heights: Vec<f64> = raised.iter().map(|(_, p)| p.z).collect();
    heights.sort_by(f64::total_cmp);
    let median = *heights.get(heights.len() / 2)?;
    let level: Vec<(usize, Vector3<f64>)> = raised
        .into_iter()
        .filter(|(_, p)| (p.z - median).abs() <= 2.0 * opts.ransac_threshold_m)
        .collect();
    if level.is_empty() {
        return None;
    }
    let c = level.iter().map(|(_, p)| p).sum::<Vector3<f64>>() / level.len() as f64;
    let (top, pos): (Vec<usize>, Vec<Vector3<f64>>) = level
        .into_iter()
        .filter(|(_, p)| (p.x - c.x).hypot(p.y - c.y) <= radius_m)
        .unzip();
    if top.len() < 3 {
        return None;
    }
    let coord = pos.iter().sum::<Vector3<f64>>() / pos.len() as f64;
    Some(VirtualTie {
        strip: s,
        plane_points: top.clone(),
        vertices: top,
        carried: pos,
        coord,
        normal: Vector3::z(),
        target_mean: true,
        featureless: false,
    })
}

/// How far beyond its radius a control target is looked for, m: more than an uncalibrated
/// mounting displaces it.
const TARGET_SEARCH_MARGIN_M: f64 = 1.5;

/// How far above the local ground a target's top stands at least, m (Zhang et al.'s (2018) targets:
/// 0.5 m).
const TARGET_MIN_HEIGHT_M: f64 = 0.25;

impl VirtualTie {
    /// Rule 2 (eq. 6): the tie coordinate with the mounting `g` (and, when given, strip
    /// `offset.0`'s trajectory off by `offset.1`), and the points that carry it.
    pub(crate) fn at(
        &self,
        strips: &[Strip],
        g: &Georeferencing,
        offset: Option<(usize, &TrajectoryOffset)>,
    ) -> TieAt {
        let pts = &strips[self.strip].points;
        let place = |k: usize| match offset {
            Some((s, o)) if s == self.strip => g.apply_offset(&pts[k], o),
            _ => g.apply_vector(&pts[k]),
        };
        let new: Vec<Vector3<f64>> = self.vertices.iter().map(|&k| place(k)).collect();
        if self.target_mean {
            let mean = new.iter().sum::<Vector3<f64>>() / new.len() as f64;
            return (mean, new);
        }
        let (r, t) = rigid_transform(&self.carried, &new);
        (r * self.coord + t, new)
    }
}

/// A tie with its virtual ties (one per strip) and what it observes.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct TieSpec {
    pub(crate) id: String,
    pub(crate) virtuals: Vec<VirtualTie>,
    /// Unit directions (NED) along which the tie observes; 3 for a feature.
    pub(crate) directions: Vec<Vector3<f64>>,
    /// The tie observes along its surface's normal only (a roof face, a plain level patch):
    /// `directions` is that normal at the last accepted state, refitted by [`TieModel::accept`].
    /// The picks of such a tie are one place in every strip as delivered, so at the true mounting
    /// its virtual ties lie on the one true surface but up to the mounting's displacement apart
    /// along it (~1 m at 800 m); projected on a normal that kept the prior's tilt (~0.001 rad)
    /// that spacing reads as a residual of a millimetre that no mounting removes.
    pub(crate) along_normal: bool,
    /// Surveyed position when the tie is also a control point.
    pub(crate) control: Option<Vector3<f64>>,
    /// The control point's own 1-σ (its vertical σ), m, when known.
    pub(crate) control_sigma_m: Option<f64>,
}

impl TieSpec {
    /// Independent scalar observations this tie gives.
    pub(crate) fn observations(&self) -> usize {
        self.per_direction() * self.directions.len()
    }

    /// Independent observations along each direction: one per strip, less the tie's mean
    /// unless a control point is the reference.
    fn per_direction(&self) -> usize {
        let s = self.virtuals.len();
        if self.control.is_some() { s } else { s - 1 }
    }

    /// The noise group of the rows along `dir` ([`NoiseGroup`]).
    fn group(&self, dir: &Vector3<f64>) -> NoiseGroup {
        if self.along_normal || dir.z.abs() >= 0.5 {
            NoiseGroup::Surface
        } else {
            NoiseGroup::Horizontal
        }
    }
}

/// Where a residual row's own noise comes from, so each kind is weighted by its own σ.
///
/// Why: a tie's horizontal position in a strip is where the feature was picked (or its centroid
/// found), its height is the strip's surface under it (rule 1): a hand pick's centimetre and the
/// points' millimetres are different noises. One pooled σ0 for both averages them, and the
/// parameters the horizontal rows determine (yaw) get a σ too small by the share of nearly
/// exact height rows in the pool.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum NoiseGroup {
    /// Horizontal rows of a feature or line: the pick's (or centroid's) position.
    Horizontal = 0,
    /// Heights and surface normals: the strip's points.
    Surface = 1,
}

/// How many [`NoiseGroup`]s there are.
pub(crate) const NOISE_GROUPS: usize = 2;

/// A pick left out of the adjustment because no virtual tie could be formed from it in its strip
/// (SPEC §8 `dropped_picks`); the rest of the tie still counts when two strips (or one and a
/// control point) remain.
#[derive(Debug, Clone, PartialEq)]
pub struct DroppedPick {
    /// The tie's id.
    pub tie: String,
    /// The strip's id.
    pub strip: String,
    /// Why, lowercase.
    pub reason: String,
}

/// The tie set as the adjustment sees it (Zhang & Jiang 2011, steps 4–6).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct TieModel {
    pub(crate) ties: Vec<TieSpec>,
    /// Picks no virtual tie could be formed from, in input order.
    pub(crate) dropped_picks: Vec<DroppedPick>,
    /// Feature ties whose picks lie on one plain plane in every strip: observed across that
    /// plane only (as a [`TieKind::Surface`] tie), in input order.
    pub(crate) plain_ties: Vec<String>,
    /// Control points inside the strips that no strip could triangulate (a target seen by a scan
    /// line or two only): left out of the adjustment and reported.
    pub(crate) skipped_control: Vec<String>,
}

impl TieModel {
    /// Tie coordinates of every virtual tie at the parameter vector `x` (rule 2).
    pub(crate) fn coords_at(&self, strips: &[Strip], x: &[f64; 6]) -> Vec<Vec<TieAt>> {
        self.coords_at_offset(strips, x, None)
    }

    /// [`TieModel::coords_at`] with strip `offset.0`'s trajectory off by `offset.1`.
    fn coords_at_offset(
        &self,
        strips: &[Strip],
        x: &[f64; 6],
        offset: Option<(usize, &TrajectoryOffset)>,
    ) -> Vec<Vec<TieAt>> {
        let g = Georeferencing::new(&mounting_from_vector(x));
        self.ties
            .iter()
            .map(|t| {
                t.virtuals
                    .iter()
                    .map(|v| v.at(strips, &g, offset))
                    .collect()
            })
            .collect()
    }

    /// The residuals at `x` with strip `offset.0`'s trajectory off by `offset.1`: how a strip's
    /// navigation error moves the residuals (the trajectory weighting's sensitivity).
    pub(crate) fn residuals_offset(
        &self,
        strips: &[Strip],
        x: &[f64; 6],
        offset: (usize, &TrajectoryOffset),
    ) -> Vec<f64> {
        self.residuals_from(&self.coords_at_offset(strips, x, Some(offset)))
    }

    /// Residuals (Zhang & Jiang 2011, eq. 8 with the eq. 7 mean): per tie and strip, the tie
    /// coordinate minus the mean over its strips (or minus the control), projected on the tie's
    /// directions.
    pub(crate) fn residuals_from(&self, coords: &[Vec<TieAt>]) -> Vec<f64> {
        let mut r = Vec::new();
        for (t, c) in self.ties.iter().zip(coords) {
            let reference = t.control.unwrap_or_else(|| {
                c.iter().map(|(p, _)| *p).sum::<Vector3<f64>>() / c.len() as f64
            });
            for (p, _) in c {
                let d = p - reference;
                for dir in &t.directions {
                    r.push(dir.dot(&d));
                }
            }
        }
        r
    }

    /// Accepts the state at `x`: triangles and tie coordinates move to it (Zhang & Jiang 2011,
    /// step 4), and a surface tie's direction becomes its surface's normal there
    /// ([`TieSpec::along_normal`]).
    pub(crate) fn accept(&mut self, strips: &[Strip], x: &[f64; 6]) {
        let coords = self.coords_at(strips, x);
        let g = Georeferencing::new(&mounting_from_vector(x));
        for (t, c) in self.ties.iter_mut().zip(coords) {
            for (v, (p, tri)) in t.virtuals.iter_mut().zip(c) {
                v.coord = p;
                v.carried = tri;
            }
            if t.along_normal {
                let v = &t.virtuals[0];
                let pts: Vec<Vector3<f64>> = v
                    .plane_points
                    .iter()
                    .map(|&k| g.apply_vector(&strips[v.strip].points[k]))
                    .collect();
                if let Some(pl) = fit_plane(&pts) {
                    t.directions = vec![pl.normal];
                }
            }
        }
    }

    pub(crate) fn observations(&self) -> usize {
        self.ties.iter().map(TieSpec::observations).sum()
    }

    /// The noise group of every residual row, in the order of [`TieModel::residuals_from`].
    pub(crate) fn row_groups(&self) -> Vec<NoiseGroup> {
        let mut g = Vec::new();
        for t in &self.ties {
            for _ in &t.virtuals {
                g.extend(t.directions.iter().map(|d| t.group(d)));
            }
        }
        g
    }

    /// Independent observations per noise group (they sum to [`TieModel::observations`]).
    pub(crate) fn group_observations(&self) -> [usize; NOISE_GROUPS] {
        let mut n = [0; NOISE_GROUPS];
        for t in &self.ties {
            for d in &t.directions {
                n[t.group(d) as usize] += t.per_direction();
            }
        }
        n
    }
}

/// Seed-mixing for per-tie RANSAC seeds.
pub(crate) fn mix_seed(seed: u64, a: usize, b: usize) -> u64 {
    let mut h = seed ^ 0x9E37_79B9_7F4A_7C15;
    for v in [a as u64, b as u64] {
        h = (h ^ v).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        h ^= h >> 31;
    }
    h
}

/// Builds the tie model: virtual ties for every pick and every control point.
pub(crate) fn build_tie_model(
    idx: &Indexed<'_>,
    ties: &[Tie],
    control: &[NedControlPoint],
    prior: &[f64; 6],
    opts: &VtpmOptions,
) -> Result<TieModel> {
    let g = Georeferencing::new(&mounting_from_vector(prior));
    let axes = vec![Vector3::x(), Vector3::y(), Vector3::z()];
    let mut out = Vec::new();
    let mut dropped = Vec::new();
    let mut plain_ties = Vec::new();
    for (ti, tie) in ties.iter().enumerate() {
        if ties[..ti].iter().any(|o| o.id == tie.id) {
            return Err(Error::InvalidTie {
                tie: tie.id.clone(),
                message: "the id is used twice".into(),
            });
        }
        let mut virtuals = Vec::new();
        for (pi, pick) in tie.picks.iter().enumerate() {
            if !(pick.north_m.is_finite() && pick.east_m.is_finite()) {
                return Err(Error::InvalidTie {
                    tie: tie.id.clone(),
                    message: format!("the pick in strip {} is not finite", pick.strip),
                });
            }
            let s = idx
                .strip_index(&pick.strip)
                .ok_or_else(|| Error::UnknownStrip {
                    tie: tie.id.clone(),
                    strip: pick.strip.clone(),
                })?;
            if tie.picks[..pi].iter().any(|o| o.strip == pick.strip) {
                return Err(Error::InvalidTie {
                    tie: tie.id.clone(),
                    message: format!("picked twice in strip {}", pick.strip),
                });
            }
            match build_virtual_tie(&PickInStrip {
                idx,
                strip: s,
                tie_id: &tie.id,
                x: pick.north_m,
                y: pick.east_m,
                g: &g,
                opts,
                seed: mix_seed(opts.seed, ti, pi),
            }) {
                Ok(v) => virtuals.push(v),
                Err(Error::NoCoplanarTriangle { reason, .. }) => dropped.push(DroppedPick {
                    tie: tie.id.clone(),
                    strip: pick.strip.clone(),
                    reason: format!("no coplanar triangle around the pick: {reason}"),
                }),
                Err(Error::TieOutsideStrip { radius_m, .. }) => dropped.push(DroppedPick {
                    tie: tie.id.clone(),
                    strip: pick.strip.clone(),
                    reason: format!("no point of the strip within {radius_m:.2} m of the pick"),
                }),
                Err(e) => return Err(e),
            }
        }
        let c = control.iter().find(|c| c.id == tie.id);
        if tie.picks.len() < 2 && c.is_none() {
            return Err(Error::InvalidTie {
                tie: tie.id.clone(),
                message: format!(
                    "picked in {} strip(s); a tie needs at least 2",
                    tie.picks.len()
                ),
            });
        }
        if virtuals.is_empty() || (virtuals.len() < 2 && c.is_none()) {
            // What is left observes nothing: the remaining pick goes too, and says why.
            for v in &virtuals {
                dropped.push(DroppedPick {
                    tie: tie.id.clone(),
                    strip: idx.strips[v.strip].id.clone(),
                    reason: "the tie's picks in the other strips were dropped".into(),
                });
            }
            continue;
        }
        // A "feature" picked where every strip shows one plain plane fixes nothing along the
        // plane: the same x, y typed into each strip would tie the strips horizontally where the
        // data say nothing, and the horizontal parameters would follow the typing.
        let plain = matches!(tie.kind, TieKind::Feature)
            && virtuals.iter().all(|v| v.featureless && !v.target_mean);
        if plain {
            plain_ties.push(tie.id.clone());
        }
        let directions = match tie.kind {
            TieKind::Feature if plain => vec![virtuals[0].normal],
            TieKind::Feature => axes.clone(),
            TieKind::Surface => vec![virtuals[0].normal],
            TieKind::Line([n, e]) => vec![Vector3::new(n, e, 0.0), Vector3::z()],
        };
        out.push(TieSpec {
            id: tie.id.clone(),
            virtuals,
            along_normal: plain || matches!(tie.kind, TieKind::Surface),
            directions,
            control: c.map(|c| c.position_m.vector()),
            control_sigma_m: c.and_then(|c| c.sigma_vertical_m),
        });
    }
    let mut skipped_control = Vec::new();
    for (ci, c) in control.iter().enumerate() {
        if ties.iter().any(|t| t.id == c.id) {
            continue;
        }
        if !c.position_m.vector().iter().all(|v| v.is_finite()) {
            return Err(Error::InvalidTie {
                tie: c.id.clone(),
                message: "control coordinates are not finite".into(),
            });
        }
        let (x, y) = (c.position_m.north_m(), c.position_m.east_m());
        let target_radius = c.target_radius_m.filter(|r| r.is_finite() && *r > 0.0);
        let cover_radius = target_radius.map_or(opts.radius_m, |r| 0.75 * r);
        let mut virtuals = Vec::new();
        let mut covered = false;
        for s in 0..idx.strips.len() {
            if !idx.covers(s, x, y, cover_radius) {
                continue;
            }
            covered = true;
            if let Some(r) = target_radius {
                virtuals.extend(build_target_tie(idx, s, x, y, r, &g, opts));
                continue;
            }
            // A checkpoint with no coplanar triangle around it in one strip is not observed
            // there (the others still do).
            match build_virtual_tie(&PickInStrip {
                idx,
                strip: s,
                tie_id: &c.id,
                x,
                y,
                g: &g,
                opts,
                seed: mix_seed(opts.seed ^ 0xC0, ci, s),
            }) {
                Ok(v) => virtuals.push(v),
                Err(Error::NoCoplanarTriangle { .. }) => continue,
                Err(e) => return Err(e),
            }
        }
        if virtuals.is_empty() && covered {
            skipped_control.push(c.id.clone());
            continue;
        }
        if virtuals.is_empty() {
            return Err(Error::OutsideEveryStrip {
                what: "control point",
                id: c.id.clone(),
                north_m: x,
                east_m: y,
            });
        }
        out.push(TieSpec {
            id: c.id.clone(),
            virtuals,
            directions: vec![Vector3::z()],
            along_normal: false,
            control: Some(c.position_m.vector()),
            control_sigma_m: c.sigma_vertical_m,
        });
    }
    Ok(TieModel {
        ties: out,
        dropped_picks: dropped,
        plain_ties,
        skipped_control,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use lidarqa_model::Mounting;

    /// A point whose georeferencing is its own origin (zero range, level, no lever arm).
    fn at(x: f64, y: f64, up: f64) -> crate::strip::RawPoint {
        crate::strip::RawPoint::own_origin(Ned::new(x, y, -up), 0)
    }

    #[test]
    fn a_displaced_target_is_found_and_observed_by_its_top_only() {
        // Flat ground at 0 m, a 0.8 m disc 0.5 m high centred 1.35 m from where the control
        // says (as an uncalibrated strip would put it), points every 0.25 m.
        let (cx, cy, r) = (1.0, 0.9, 0.8);
        let mut points = Vec::new();
        for i in -16..=16 {
            for j in -16..=16 {
                let (x, y) = (i as f64 * 0.25, j as f64 * 0.25);
                let on_disc = (x - cx).hypot(y - cy) <= r;
                points.push(at(x, y, if on_disc { 0.5 } else { 0.0 }));
            }
        }
        let on_disc = points.iter().filter(|p| p.position_m.up_m() > 0.25).count();
        let strips = [Strip {
            id: "1".into(),
            points,
        }];
        let idx = Indexed::new(&strips, 1.0);
        let g = Georeferencing::new(&Mounting::default());
        let v = build_target_tie(&idx, 0, 0.0, 0.0, r, &g, &VtpmOptions::default()).unwrap();
        assert_eq!(v.vertices.len(), on_disc);
        assert!((v.coord.z + 0.5).abs() < 1e-12, "{}", v.coord.z);
        assert!((v.coord.x - cx).abs() < 0.05 && (v.coord.y - cy).abs() < 0.05);
        // Rule 2 for a target: the mean moves with its points (here: a 0.1 m lever arm down).
        let lowered = Georeferencing::new(&Mounting {
            lever_arm_m: Vector3::new(0.0, 0.0, 0.1),
            ..Mounting::default()
        });
        assert!((v.at(&strips, &lowered, None).0.z + 0.4).abs() < 1e-12);
        // Too far from the surveyed centre: not observed.
        assert!(build_target_tie(&idx, 0, -3.5, -3.5, r, &g, &VtpmOptions::default()).is_none());
    }

    /// Flat ground sampled as a sawtooth scanner does: lines `line_m` apart along north, points
    /// `point_m` apart along each line.
    fn scan_lines(id: &str, line_m: f64, point_m: f64) -> Strip {
        let mut points = Vec::new();
        for i in -6..=6 {
            for j in -40..=40 {
                points.push(at(i as f64 * line_m, j as f64 * point_m, 0.0));
            }
        }
        Strip {
            id: id.into(),
            points,
        }
    }

    #[test]
    fn the_window_grows_until_a_triangle_between_two_scan_lines_holds_the_pick() {
        // Lines 1.36 m apart, points 0.13 m apart: a pick half-way between two lines has no
        // point within 0.5 m; the window grows to reach both lines and a triangle holds it.
        let strips = [scan_lines("1", 1.36, 0.13)];
        let idx = Indexed::new(&strips, 0.5);
        let g = Georeferencing::new(&Mounting::default());
        let opts = VtpmOptions {
            radius_m: 0.5,
            ..VtpmOptions::default()
        };
        assert!(within(&idx.grids[0], &strips[0].points, 0.68, 0.05, 0.5).is_empty());
        let pick = |opts| PickInStrip {
            idx: &idx,
            strip: 0,
            tie_id: "M01",
            x: 0.68,
            y: 0.05,
            g: &g,
            opts,
            seed: 1,
        };
        let v = build_virtual_tie(&pick(&opts)).unwrap();
        assert_eq!(v.vertices.len(), 3);
        assert!(v.coord.z.abs() < 1e-12);
        let xs: Vec<f64> = v
            .vertices
            .iter()
            .map(|&k| strips[0].points[k].position_m.north_m())
            .collect();
        assert!(xs.iter().any(|x| x.abs() < 1e-9) && xs.iter().any(|x| (x - 1.36).abs() < 1e-9));
        // Beyond the growth limit: still an error for this one strip.
        let far = VtpmOptions {
            radius_m: 0.1,
            ..VtpmOptions::default()
        };
        assert!(matches!(
            build_virtual_tie(&pick(&far)),
            Err(Error::TieOutsideStrip { .. })
        ));
    }

    #[test]
    fn a_pick_off_its_strip_is_dropped_and_listed_and_the_rest_of_the_tie_kept() {
        let strips = [
            scan_lines("1", 1.36, 0.13),
            scan_lines("2", 1.36, 0.13),
            scan_lines("3", 1.36, 0.13),
        ];
        let idx = Indexed::new(&strips, 1.0);
        let pick = |strip: &str, n: f64, e: f64| TiePick {
            strip: strip.into(),
            north_m: n,
            east_m: e,
        };
        let ties = [
            Tie {
                id: "M01".into(),
                picks: vec![
                    pick("1", 0.3, 0.2),
                    pick("2", 1000.0, 0.2),
                    pick("3", 0.3, 0.2),
                ],
                kind: TieKind::Feature,
            },
            Tie {
                id: "M02".into(),
                picks: vec![pick("1", 2.0, 1.0), pick("2", 2.0, 900.0)],
                kind: TieKind::Feature,
            },
        ];
        let model = build_tie_model(&idx, &ties, &[], &[0.0; 6], &VtpmOptions::default()).unwrap();
        assert_eq!(model.ties.len(), 1);
        assert_eq!(model.ties[0].virtuals.len(), 2);
        let listed: Vec<(&str, &str)> = model
            .dropped_picks
            .iter()
            .map(|d| (d.tie.as_str(), d.strip.as_str()))
            .collect();
        assert_eq!(listed, [("M01", "2"), ("M02", "2"), ("M02", "1")]);
        assert!(
            model.dropped_picks[0]
                .reason
                .contains("no point of the strip")
        );
        assert!(
            model.dropped_picks[2]
                .reason
                .contains("other strips were dropped")
        );
    }
}
