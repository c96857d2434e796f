//! Local surface normals from a plane fit to each point's k nearest neighbours, for the
//! `incidence` term of the per-point TPU.
//!
//! # Is there a surface at all?
//! A plane through any k points always exists; whether it means anything depends on the shape of
//! the neighbourhood. [`judge_surfaces`] sorts each one by the dimensionality features of
//! Demantke et al. (2011, "Dimensionality based scale selection in 3D lidar point clouds"):
//! with σᵢ = √λᵢ of the scatter matrix (σ₁ ≥ σ₂ ≥ σ₃), linearity (σ₁ − σ₂)/σ₁, planarity
//! (σ₂ − σ₃)/σ₁ and scattering σ₃/σ₁ sum to 1, and the largest names the neighbourhood:
//! [`Surface::Planar`] (a normal is defined), [`Surface::Linear`] (e.g. k neighbours along one
//! scan line: the "plane" is any plane through the line, and its normal is noise — the fit that
//! put real strips at the 85° cap), [`Surface::Scattered`] (vegetation, noise) or
//! [`Surface::TooFew`] (fewer than [`MIN_NEIGHBOURS`] points). Only planar neighbourhoods get an
//! incidence term.
//!
//! # Widening
//! Airborne scanners put points much closer together along a scan line than between lines, so
//! the k nearest neighbours of a point on perfectly planar ground often all lie on its own line
//! and are judged linear. The surface is there; the neighbourhood is too small in one direction.
//! [`judge_surfaces`] therefore widens a linear neighbourhood before giving up: it takes the
//! candidates within [`WIDEN_RADIUS_FACTOR`] times the k-th distance, in the same (distance,
//! index) order as the k-nearest search, and judges the nearest 2k, 4k, … of them up to
//! [`MAX_NEIGHBOURS`] (all of them when fewer are that close), keeping the first accepted as
//! [`Surface::PlanarWidened`]. Growing k in the scan order of the data is a form of Demantke et
//! al.'s scale selection restricted to the one failure it has to fix: their eigen-entropy
//! minimum over radii would also move the neighbourhoods that are already planar, and with them
//! every σ measured so far, and would need a full range of radii per point. A widened
//! neighbourhood is accepted only when
//! - it is planar and flat (σ₂ ≥ [`WIDEN_FLATNESS`] · σ₃): scattered points (vegetation) stay
//!   scattered however many are taken, and a scattered prefix stops the widening;
//! - the points off the first line lie as other scan lines of that plane would (in the plane,
//!   or spanning the same plane, [`WIDEN_ALIGNMENT_RAD`]): a line and any blob beside it fit
//!   some plane, so a wire above the ground would otherwise borrow the ground's patch; a line
//!   with nothing beside it within the radius stays linear.
//!
//! The radius bound keeps the widening local (a multiple of the first neighbourhood's size,
//! enough to reach scan lines tens of point spacings apart) and the k bound keeps memory and
//! time per point bounded. Both searches are exact and each point's answer depends only on the
//! candidates (and, where it shares a judgement, on its seed's: see "Sharing"), so the result is
//! the same whatever the number of threads. One case geometry
//! cannot settle: returns of one scan plane only (one scan cycle through a tree) are coplanar
//! whatever they hit, and are judged planar with the scan plane's normal, as the k nearest
//! alone already judge them where they are not one line.
//!
//! # Sharing
//! Judging every point's neighbourhood (a k-nearest search, an eigen-decomposition, and for
//! the points of one scan line a widened one) costs several times the reading and writing of
//! the point. Targets come in scan order, and a point's neighbours along its scan line lie in
//! the neighbourhood already judged for the point a few places before it, so
//! [`judge_surfaces`] judges the first target of each group of [`SHARE_STRIDE`] (the seed:
//! index a multiple of it) and gives the next ones the seed's judgement (its class and its
//! plane's normal or its line's direction) where they lie within the neighbourhood the
//! judgement rests on: the k nearest, or the accepted widened one. A target outside it (the
//! next return of a pulse through a tree, the far side of a gap, a point past the k/2
//! neighbours a seed's k nearest reach along its scan line) is judged on its own and seeds
//! the rest of the group in its turn, so a judgement is taken over as long as the scan stays
//! within the last judged neighbourhood. A plane reaches farther: a target beyond a planar
//! neighbourhood (the k nearest or a widened one) but within [`SHARE_REACH`] times its radius
//! takes the plane's judgement where it lies on the plane, within [`PLANE_TOLERANCE`] times
//! the RMS distance of the neighbourhood's points from it (the surface's roughness and the
//! ranging noise): the surface is still that plane there. A roof's far side, the foot of a
//! wall, a kerb or a crown lie off the plane and are judged on their own; only a well-defined
//! plane reaches ([`REACH_FLATNESS`]: a neighbourhood straddling a ridge is judged a plane but
//! is neither side's), and a line or a scattered neighbourhood reaches no farther than its own
//! points. The
//! incidence itself is still each point's own: the angle between its own beam and the shared
//! normal ([`judged_incidence`]). [`judge_surfaces_shared`] with a stride of 1 judges every
//! point; the crate's `tests/incidence_sigma.rs` holds both to the same bar.
//!
//! The seeds are fixed by the targets' indices alone (counted from the first target of the
//! call, and [`SHARE_STRIDE`] divides the block of targets a thread takes), so the result does
//! not depend on the number of threads, and a caller that judges its targets in pieces
//! (lidarqa-pipeline's chunks) gets the same judgements as in one call when every piece starts
//! at a multiple of [`SHARE_STRIDE`]. On a scan line a seed's k nearest reach about k/2 points
//! either side and a widened neighbourhood farther, so most targets lie within the last judged
//! neighbourhood (the share judged in full on the benchmark strip is in the performance docs).
//!
//! # Beam-aware incidence
//! A surface the footprint lies on must be one the beam meets. [`judged_incidence`] turns a
//! point's judgement and its beam into the incidence term's `|cos α|` and an
//! [`IncidenceClass`] (written per point by `lidarqa tpu` as `incidence_class`):
//! - a plane (k nearest or widened) whose normal is within 90° − 85° of perpendicular to the
//!   beam *contains* the beam (`|cos α| ≤ cos 85°`, the term's cap): that is what the returns of
//!   one scan plane give whatever they hit (a tree crossed by one scan cycle), and no surface
//!   seen by that beam; it takes the prior below ([`IncidenceClass::BeamInPlane`]);
//! - a thin line (σ₁ ≥ [`FLATNESS`] · σ₂: one scan line, even widened) lies in its surface: the
//!   normal across the line nearest the local vertical, i.e. the line's own slope and level
//!   across it ([`IncidenceClass::AcrossLine`]); if that normal contains the beam, the prior;
//! - a scattered neighbourhood, a planar one thicker than σ₂ ≥ [`FLATNESS`] · σ₃ (a "plane"
//!   through leaves) and a thick line take the prior ([`IncidenceClass::Scattered`]): facets
//!   oriented at random as the beam meets them, in proportion to their projected area
//!   (the spherical leaf-angle distribution of Ross 1981), `E[tan² α] = −2 ln cos 85°`
//!   ([`prior_cos_incidence`], α = 65.6°);
//! - too few neighbours: the term is left out ([`IncidenceClass::TooFew`]).
//!
//! An independent generator (the crate's `tests/incidence_sigma.rs`: slopes, gable roofs,
//! tree crowns, one and two passes) holds RMS(error/σ_up) within 0.8–1.25 per surface class.
//!
//! The normal is the eigenvector of the smallest eigenvalue of the neighbours' 3 × 3 scatter
//! matrix (total least squares plane, [`lidarqa_model::normal_of_scatter`]), from the closed-form
//! solver of [`lidarqa_model::symmetric_eigen3`] (its docs say why it is not nalgebra's). The
//! caller decides which points are candidates (lidarqa-pipeline gives each chunk plus bounded
//! margins of its neighbours in file order, see its docs).
//!
//! # Neighbour search
//! The k nearest neighbours are exact (the same set as a k-d tree's, up to ties in distance),
//! found in a uniform grid of cells rather than a tree: airborne points lie near a surface, so
//! the candidates are bucketed on the plane of their two principal axes (from a sample's
//! covariance) in cells much smaller than a neighbourhood (about `k/8` points per occupied
//! cell). Targets come in scan order, so a query first scans only the cells within a little
//! more than the previous query's k-th distance (a rectangle of rows, each row's cells
//! contiguous in memory); when fewer than k candidates are that close it scans rings of cells
//! around its own until the k-th distance found is within the distance to the unscanned cells
//! (a 3-D distance is never shorter than its projection on the plane, so both searches stay
//! exact for any point layout, only slower where many points share a cell, e.g. under
//! vegetation). Neighbours are ordered by (distance, index), so ties in distance are settled the
//! same way by both searches. Cells are filled by a counting sort (two passes, no per-cell
//! allocation) into one array per coordinate; a query keeps the distances and indices of its k
//! best in a reused fixed-capacity buffer. Against kiddo's `ImmutableKdTree::nearest_n` (one
//! sorted `Vec` allocated per query) it is several times faster on airborne strips; the tree
//! build was also serial.

use lidarqa_model::{
    normal_of_scatter, symmetric_eigen3, symmetric_eigenvalues3, symmetric_eigenvector3,
};
use nalgebra::{Matrix3, Vector3};

/// Fewest neighbours (the point included) a plane fit uses.
pub const MIN_NEIGHBOURS: usize = 3;

/// Most neighbours a plane fit uses: the fit describes the surface around one footprint, and
/// the search keeps `k` candidates per query, so an unbounded `k` is unbounded memory and time.
pub const MAX_NEIGHBOURS: usize = 256;

/// Targets per parallel work item.
const QUERY_BLOCK: usize = 2048;

/// A query first searches within this many times the previous query's k-th squared distance.
const LIMIT_FACTOR: f64 = 1.25;

/// Candidates per occupied cell per neighbour sought: cells a fraction of a neighbourhood
/// wide, so the window of [`Grid::within`] holds few candidates beyond the k-th distance.
const CELL_FILL: f64 = 0.12;

/// Unit normals (`n_z ≥ 0`) of `targets`, searched among `candidates`, with `k` nearest
/// neighbours each (the point itself is among them when it is a candidate). Coordinates in any
/// Cartesian frame, metres; subtract a nearby origin first so that f64 keeps sub-millimetre
/// resolution in the scatter sums. `None` where fewer than [`MIN_NEIGHBOURS`] candidates exist
/// or the neighbours are collinear (no plane).
///
/// Parallel over targets (rayon).
pub fn plane_normals(
    candidates: &[[f64; 3]],
    targets: &[[f64; 3]],
    k: usize,
) -> Vec<Option<Vector3<f64>>> {
    for_each_neighbourhood(candidates, targets, k, None, normal_of_neighbours)
}

/// What a point's neighbourhood is (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Surface {
    /// Planar: the unit normal (sign arbitrary).
    Planar(Vector3<f64>),
    /// The k nearest were linear, and a wider neighbourhood (see the module docs, "Widening")
    /// is planar: its unit normal (sign arbitrary).
    PlanarWidened(Vector3<f64>),
    /// Points along a line (one scan line, a wire), also when widened: no surface normal, only
    /// the line's unit direction (sign arbitrary), which lies in the surface.
    Linear(Vector3<f64>),
    /// Points spread in 3-D (vegetation, noise): no surface normal.
    Scattered,
    /// Fewer than [`MIN_NEIGHBOURS`] points.
    TooFew,
}

impl Surface {
    /// The normal of a planar neighbourhood.
    pub fn normal(&self) -> Option<Vector3<f64>> {
        match self {
            Surface::Planar(n) | Surface::PlanarWidened(n) => Some(*n),
            _ => None,
        }
    }
}

/// Each target's neighbourhood judged (see the module docs), with the `k` nearest neighbours
/// among `candidates`, widened where those are linear ([`Surface::PlanarWidened`] when a wider
/// one is planar); coordinates as for [`plane_normals`]. One judgement is shared by up to
/// [`SHARE_STRIDE`] targets in a row where they lie within it ([`judge_surfaces_shared`], the
/// module docs' "Sharing"): give the targets in scan order. Parallel over targets (rayon); the
/// result does not depend on the number of threads.
pub fn judge_surfaces(candidates: &[[f64; 3]], targets: &[[f64; 3]], k: usize) -> Vec<Surface> {
    judge_surfaces_shared(candidates, targets, k, SHARE_STRIDE)
}

/// Targets in a row that may share judgements (see the module docs, "Sharing"): target `i`
/// with `i % SHARE_STRIDE == 0` is judged, and the next ones take the last judgement where they
/// lie within its judged neighbourhood. Each target is tested against a judgement made on its
/// own neighbourhood, so a longer stride would not let an error travel; the stride bounds how
/// far a result depends on the targets before it. A divisor of the block of targets searched
/// together (so that the seeds are those of the targets' indices whatever the number of
/// threads) and of lidarqa-pipeline's default chunk of 500 000 points.
pub const SHARE_STRIDE: usize = 32;

/// How far, as a multiple of its radius, a judged plane reaches (see the module docs,
/// "Sharing"): a target outside the neighbourhood but within this many radii takes the plane's
/// judgement where it lies on the plane ([`PLANE_TOLERANCE`]).
pub const SHARE_REACH: f64 = 4.0;

/// A target beyond a judged plane's neighbourhood lies on it when its distance from the plane
/// is within this many times the RMS distance of the neighbourhood's points (the surface's own
/// roughness and the ranging noise), and at least [`PLANE_TOLERANCE_FLOOR_M`].
pub const PLANE_TOLERANCE: f64 = 3.0;

/// The least tolerance of [`PLANE_TOLERANCE`], m: the points of a noise-free plane are on it to
/// rounding, not to zero.
pub const PLANE_TOLERANCE_FLOOR_M: f64 = 1e-3;

/// Only a well-defined plane reaches beyond its neighbourhood: σ₂ ≥ this × σ₃ (its points'
/// spread across the plane against their spread off it). A neighbourhood across a ridge or a
/// kerb is planar enough to be judged a plane, but its plane is neither side's.
pub const REACH_FLATNESS: f64 = 8.0;

// The seeds of one call are the targets whose index is a multiple of the stride only when the
// stride divides the blocks the threads take.
const _: () = assert!(QUERY_BLOCK % SHARE_STRIDE == 0);

/// [`judge_surfaces`] with one judgement shared by up to `stride` targets in a row (1: every
/// target judged on its own neighbourhood). `stride` is clamped to 1..=2048 (the targets
/// searched together); the seeds are the targets whose index is a multiple of it when it divides
/// 2048 (a power of two does), and the result never depends on the number of threads.
pub fn judge_surfaces_shared(
    candidates: &[[f64; 3]],
    targets: &[[f64; 3]],
    k: usize,
    stride: usize,
) -> Vec<Surface> {
    let mut out = Vec::new();
    let mut grid = GridBuffers::default();
    judge_into(
        candidates,
        targets,
        (k, stride),
        (&mut out, &mut grid),
        |s| s,
    );
    out
}

/// [`judge_surfaces`] into `out`, each judgement as `Some`, its search grid built in `grid`:
/// both are cleared and their capacity reused, so a caller judging chunk after chunk does not
/// map (and fault in) fresh vectors of tens of MB for each.
pub fn judge_surfaces_into(
    candidates: &[[f64; 3]],
    targets: &[[f64; 3]],
    k: usize,
    (out, grid): (&mut Vec<Option<Surface>>, &mut GridBuffers),
) {
    judge_into(candidates, targets, (k, SHARE_STRIDE), (out, grid), Some);
}

/// The judgement of [`judge_surfaces_shared`], each answer wrapped by `wrap`, into `out`.
fn judge_into<T: Clone + Send + Sync>(
    candidates: &[[f64; 3]],
    targets: &[[f64; 3]],
    (k, stride): (usize, usize),
    (out, grid): (&mut Vec<T>, &mut GridBuffers),
    wrap: impl Fn(Surface) -> T + Sync,
) {
    let stride = stride.clamp(1, QUERY_BLOCK);
    search_each(
        candidates,
        targets,
        (k, stride),
        (wrap(Surface::TooFew), out, grid),
        |q, nn, grid, wide| {
            if nn.len() < MIN_NEIGHBOURS {
                return (wrap(Surface::TooFew), 0.0, None);
            }
            // The scatter of the k nearest is judged, and reused by the widening.
            let sums = sums_of(q, nn);
            let first = sums.scatter();
            let kth_m2 = nn.last().map_or(0.0, |&(d2, _)| d2);
            let (judged, values) = judge_scatter(&first, FLATNESS, true);
            let (judged, r2, plane) = match judged {
                Surface::Linear(along) => widen(q, nn, (&first, along), grid, wide),
                judged => {
                    let plane = judged
                        .normal()
                        .and_then(|n| Plane::of(q, &sums, (&first, values), n));
                    (judged, kth_m2, plane)
                }
            };
            (wrap(judged), r2, plane)
        },
    );
}

/// How a point's incidence term was taken: the per-point `incidence_class` of `lidarqa tpu`'s
/// output (its `u8` value) and the summary's counts (see the module docs, "Beam-aware
/// incidence").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum IncidenceClass {
    /// No incidence term: no beam divergence, or a bathymetric sounding (its own terms).
    NoTerm = 0,
    /// The file's `NormalX/Y/Z`.
    FileNormal = 1,
    /// The plane of the k nearest neighbours.
    Planar = 2,
    /// The plane of a widened neighbourhood ([`Surface::PlanarWidened`]).
    PlanarWidened = 3,
    /// A linear neighbourhood: the normal across the line nearest the local vertical.
    AcrossLine = 4,
    /// The judged plane (or the normal across a line) contains the beam, so it cannot be the
    /// surface the footprint lies on: the prior of [`prior_cos_incidence`].
    BeamInPlane = 5,
    /// A scattered neighbourhood (vegetation): the prior of [`prior_cos_incidence`].
    Scattered = 6,
    /// Too few neighbours: term left out.
    TooFew = 7,
    /// A zero or non-finite file normal: term left out.
    InvalidFileNormal = 8,
}

impl IncidenceClass {
    /// Whether the term is left out (no incidence variance at all).
    pub fn left_out(self) -> bool {
        matches!(
            self,
            IncidenceClass::TooFew | IncidenceClass::InvalidFileNormal
        )
    }

    /// Whether the term rests on the prior rather than on a measured surface.
    pub fn prior(self) -> bool {
        matches!(
            self,
            IncidenceClass::BeamInPlane | IncidenceClass::Scattered
        )
    }
}

/// The `|cos α|` the incidence term takes where no surface is measured (a scattered
/// neighbourhood, or a plane that contains the beam): that of facets oriented at random
/// (isotropic normals) as the beam meets them, i.e. with probability proportional to their
/// projected area `cos α` (the spherical leaf-angle distribution of radiative transfer, Ross
/// 1981), so `cos α` has density `2c` on [0, 1]. With `tan α` capped at
/// [`crate::MAX_INCIDENCE_RAD`] like every other incidence, `E[tan² α] = −2 ln cos α_max`
/// (4.88 at 85°), and the term takes the angle of that mean square: `cos α = 1/√(1 + E[tan² α])`
/// (α = 65.6°), so its variance is the expected one.
pub fn prior_cos_incidence() -> f64 {
    1.0 / (1.0 - 2.0 * crate::MAX_INCIDENCE_RAD.cos().ln()).sqrt()
}

/// The incidence term at a point whose surface is `surface` (`None`: no term): a file's normal
/// (`from_file`, PDAL's `NormalX/Y/Z` turned into the surface's frame) is used as it is,
/// capped at α_max like any other ([`IncidenceClass::InvalidFileNormal`] where it is zero or
/// not finite); a judged one is checked against the beam ([`judged_incidence`], frames as
/// there).
pub fn incidence_at(
    surface: Option<Surface>,
    from_file: bool,
    to_ned: &Matrix3<f64>,
    beam_ned: &Vector3<f64>,
) -> (IncidenceClass, Option<f64>) {
    let Some(s) = surface else {
        return (IncidenceClass::NoTerm, None);
    };
    if !from_file {
        return judged_incidence(&s, to_ned, beam_ned);
    }
    match s.normal() {
        Some(n) => (
            IncidenceClass::FileNormal,
            Some(cos_incidence(beam_ned, &(to_ned * n))),
        ),
        None => (IncidenceClass::InvalidFileNormal, None),
    }
}

/// The incidence term at a point: how it is taken and the `|cos α|` it uses (`None`: left
/// out), from the point's judged `surface` (any frame), the rotation `to_ned` from that frame
/// to the local level NED frame of the beam, and the beam's direction `beam_ned` there (any
/// length). A plane is used as judged unless the beam lies within 90° − α_max of it
/// (`|cos α| ≤ cos α_max`, [`crate::MAX_INCIDENCE_RAD`]): a plane that (nearly) contains the
/// beam is what one scan plane's returns give whatever they hit, so it takes the prior
/// ([`prior_cos_incidence`]), as a scattered neighbourhood does. A line lies in its surface:
/// the normal across it nearest the vertical (level along the line's own slope), with the
/// same test against the beam.
pub fn judged_incidence(
    surface: &Surface,
    to_ned: &Matrix3<f64>,
    beam_ned: &Vector3<f64>,
) -> (IncidenceClass, Option<f64>) {
    let cap = crate::MAX_INCIDENCE_RAD.cos();
    let seen = |n: &Vector3<f64>, class| {
        let c = cos_incidence(beam_ned, &(to_ned * n));
        if c > cap {
            (class, Some(c))
        } else {
            (IncidenceClass::BeamInPlane, Some(prior_cos_incidence()))
        }
    };
    match surface {
        Surface::Planar(n) => seen(n, IncidenceClass::Planar),
        Surface::PlanarWidened(n) => seen(n, IncidenceClass::PlanarWidened),
        Surface::Linear(d) => {
            // Up in NED is −z: the normal across the line nearest it.
            let d = to_ned * d;
            let up = Vector3::new(0.0, 0.0, -1.0);
            let across = up - d * (d.dot(&up) / d.norm_squared());
            let norm = across.norm();
            if norm > 1e-6 && norm.is_finite() {
                let c = cos_incidence(beam_ned, &across);
                if c > cap {
                    return (IncidenceClass::AcrossLine, Some(c));
                }
            }
            (IncidenceClass::BeamInPlane, Some(prior_cos_incidence()))
        }
        Surface::Scattered => (IncidenceClass::Scattered, Some(prior_cos_incidence())),
        Surface::TooFew => (IncidenceClass::TooFew, None),
    }
}

/// The widest neighbourhood [`judge_surfaces`] widens a linear one to, as a multiple of the
/// first one's radius (its k-th distance): wide enough to reach the next scan lines where they
/// are tens of point spacings apart, and no wider, so that the plane still describes the
/// surface around the point rather than one some way off.
pub const WIDEN_RADIUS_FACTOR: f64 = 12.0;

/// A widened neighbourhood is accepted as planar only when σ₂ ≥ this × σ₃ (the k-nearest rule
/// asks for 2, implied by planarity ≥ scattering): flat, not merely more planar than scattered.
pub const WIDEN_FLATNESS: f64 = 4.0;

/// Largest angle, rad, between the widened plane and the structure of the points off the first
/// neighbourhood's line: their own line must lie in the plane (one or two neighbouring scan
/// lines, short ones first) or their own plane's normal along the widened plane's (scan lines
/// on both sides). A line above a surface (a wire) fails it: a plane fits the wire and a patch
/// of the ground below, but that patch lies flat under the wire, across that plane.
const WIDEN_ALIGNMENT_RAD: f64 = 15.0 * std::f64::consts::PI / 180.0;

/// The judgement of `q`'s widened neighbourhoods, given its k nearest `nn` (nearest first),
/// which were linear: the candidates within [`WIDEN_RADIUS_FACTOR`] times the k-th distance,
/// ordered by (distance, index), are judged by prefixes of 2k, 4k, … up to
/// [`MAX_NEIGHBOURS`] (the last prefix is all of them when fewer are that close). The first
/// prefix that is flat and planar ([`WIDEN_FLATNESS`]) and whose points off the first line
/// agree with the plane ([`WIDEN_ALIGNMENT_RAD`]) is the answer; a scattered one, or none
/// accepted, leaves the point linear.
fn widen(
    q: &[f64; 3],
    nn: &[(f64, [f64; 3])],
    (first, along): (&Matrix3<f64>, Vector3<f64>),
    grid: &Grid,
    wide: &mut Vec<(f64, u32)>,
) -> (Surface, f64, Option<Plane>) {
    let k = nn.len();
    // What the point is when no widened neighbourhood is accepted (`first` is the scatter of
    // the k nearest, [`scatter_of`]): a thin line (σ₁ ≥ [`FLATNESS`] · σ₂, one scan line) lies
    // in its surface; a thick one (a run of leaves in one scan plane) does not define one.
    // Only needed when no prefix is accepted, so decided then.
    let line = || {
        let (vals, axes) = symmetric_eigen3(first);
        if vals[2].max(0.0).sqrt() >= FLATNESS * vals[1].max(0.0).sqrt() {
            Surface::Linear(axes[2])
        } else {
            Surface::Scattered
        }
    };
    let Some(&(kth_m2, _)) = nn.last() else {
        return (line(), 0.0, None);
    };
    let line = || (line(), kth_m2, None);
    if !(kth_m2 > 0.0 && (WIDEN_RADIUS_FACTOR * WIDEN_RADIUS_FACTOR * kth_m2).is_finite())
        || k >= MAX_NEIGHBOURS
    {
        return line();
    }
    // The first neighbourhood's line: its mean (as an offset from q) and direction (the
    // judgement's, `along`). A point farther from it than half the first radius is not on it
    // (the line's own thickness is noise, far smaller).
    let mean = nn.iter().fold(Vector3::zeros(), |m, (_, p)| {
        m + Vector3::new(p[0] - q[0], p[1] - q[1], p[2] - q[2])
    }) / k as f64;
    let off_m2 = kth_m2 / 4.0;
    let (mut all, mut off) = (Sums::default(), Sums::default());
    let (mut size, mut taken) = (k, 0);
    // The farthest point judged so far (squared distance): the accepted neighbourhood's radius.
    let mut far_m2 = kth_m2;
    // The nearest candidates in the total order of (distance, index), as the k-nearest search
    // orders them, so the prefixes do not depend on the order of the cells. Most widened
    // neighbourhoods are accepted within a few times the first radius: the candidates are
    // gathered within growing radii, and a prefix is judged once all of it lies within the
    // radius gathered (the nearest n are exact when n candidates are that close), so the
    // prefixes are those of one gathering within the widest radius.
    let order = |a: &(f64, u32), b: &(f64, u32)| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1));
    for factor in WIDEN_STEPS {
        let widest = factor == WIDEN_RADIUS_FACTOR;
        grid.gather(q, factor * factor * kth_m2, wide);
        // The points already taken first (the same set: the nearest `taken`); each prefix is
        // then selected, not sorted (the sums do not need the order within it).
        if taken > 0 {
            wide.select_nth_unstable_by(taken - 1, order);
        }
        let most = wide.len().min(MAX_NEIGHBOURS);
        loop {
            let mut next = (2 * size).min(MAX_NEIGHBOURS);
            if next > most {
                if !widest {
                    break;
                }
                // The last prefix: all within the widest radius.
                next = most;
            }
            if next <= size {
                return line();
            }
            let rest = &mut wide[taken..];
            if next - taken < rest.len() {
                rest.select_nth_unstable_by(next - taken - 1, order);
            }
            for &(d2, j) in &wide[taken..next] {
                far_m2 = far_m2.max(d2);
                let p = grid.point(j as usize);
                all.add(q, &p);
                let d = Vector3::new(p[0] - q[0], p[1] - q[1], p[2] - q[2]) - mean;
                if d.norm_squared() - d.dot(&along).powi(2) > off_m2 {
                    off.add(q, &p);
                }
            }
            (taken, size) = (next, next);
            let scatter = all.scatter();
            let (judged, values) = judge_scatter(&scatter, WIDEN_FLATNESS, false);
            match judged {
                Surface::Planar(n) if off_line_agrees(&off, &n) => {
                    let plane = Plane::of(q, &all, (&scatter, values), n);
                    return (Surface::PlanarWidened(n), far_m2, plane);
                }
                Surface::Scattered => return line(),
                _ if size == MAX_NEIGHBOURS || (widest && size == most) => {
                    return line();
                }
                _ => {}
            }
        }
    }
    line()
}

/// The radii, as multiples of the first neighbourhood's, within which [`widen`] gathers
/// candidates in turn (the last is [`WIDEN_RADIUS_FACTOR`]). On the bench strip (see
/// `docs/reference/performance.md`) nine in ten widened neighbourhoods are accepted at 4k
/// points, about 2.8 times the first radius away: a first step of 1.5 gathered in vain and was
/// slower. The steps change what is computed, not the answer (the prefixes are those of one
/// gathering within the widest radius).
const WIDEN_STEPS: [f64; 3] = [3.0, 6.0, WIDEN_RADIUS_FACTOR];

/// Whether the points off the first line (their sums `off`) lie as scan lines of the plane of
/// normal `n` would: in the plane when they are elongated, with the plane's normal when they
/// span a plane.
fn off_line_agrees(off: &Sums, n: &Vector3<f64>) -> bool {
    if off.n < MIN_NEIGHBOURS {
        return false;
    }
    let (vals, axes) = symmetric_eigen3(&off.scatter());
    let (s1, s2, s3) = (
        vals[2].max(0.0).sqrt(),
        vals[1].max(0.0).sqrt(),
        vals[0].max(0.0).sqrt(),
    );
    if !(s1 > 0.0 && s1.is_finite()) {
        return false;
    }
    if (s1 - s2) >= (s2 - s3) {
        // Elongated (one line, or two short ones side by side): in the plane.
        axes[2].dot(n).abs() <= WIDEN_ALIGNMENT_RAD.sin()
    } else {
        axes[0].dot(n).abs() >= WIDEN_ALIGNMENT_RAD.cos()
    }
}

/// `f(target, its k nearest candidates as (squared distance, point))` for every target, in parallel over blocks of targets
/// (rayon); `none` for every target when there are fewer than [`MIN_NEIGHBOURS`] candidates.
/// `k` is clamped to [`MIN_NEIGHBOURS`]..=[`MAX_NEIGHBOURS`] and to the candidates, so no caller
/// can make a neighbour buffer larger than the data.
fn for_each_neighbourhood<T: Clone + Send + Sync>(
    candidates: &[[f64; 3]],
    targets: &[[f64; 3]],
    k: usize,
    none: T,
    f: impl Fn(&[f64; 3], &[(f64, [f64; 3])]) -> T + Sync,
) -> Vec<T> {
    let mut out = Vec::new();
    let mut grid = GridBuffers::default();
    search_each(
        candidates,
        targets,
        (k, 1),
        (none, &mut out, &mut grid),
        |q, nn, _, _| (f(q, nn), 0.0, None),
    );
    out
}

/// [`for_each_neighbourhood`], with `f` also given the grid and a buffer reused within a block
/// (for [`widen`]), and returning with its answer the squared radius of the neighbourhood it
/// rests on and, for a plane, the [`Plane`]. With `stride` > 1, target `i` with
/// `i % stride == 0` is a seed: the targets after it, up to the next multiple of `stride`, take
/// the seed's answer without a search where their squared distance to the seed is within that
/// radius (they lie in the seed's judged neighbourhood) or, for a plane, within
/// [`SHARE_REACH`] radii and on the plane, and are searched and answered on their own
/// otherwise, becoming the seed for the rest of the group (seeds restart at each block of
/// [`QUERY_BLOCK`] targets).
fn search_each<T: Clone + Send + Sync>(
    candidates: &[[f64; 3]],
    targets: &[[f64; 3]],
    (k, stride): (usize, usize),
    (none, out, grid_bufs): (T, &mut Vec<T>, &mut GridBuffers),
    f: impl Fn(&[f64; 3], &[(f64, [f64; 3])], &Grid, &mut Vec<(f64, u32)>) -> (T, f64, Option<Plane>)
    + Sync,
) {
    use rayon::prelude::*;
    out.clear();
    // Filled in parallel: the pages of a chunk-sized vector would otherwise fault on one core.
    out.par_extend(targets.par_iter().map(|_| none.clone()));
    if candidates.len() < MIN_NEIGHBOURS {
        return;
    }
    let k = k
        .clamp(MIN_NEIGHBOURS, MAX_NEIGHBOURS)
        .min(candidates.len());
    let grid = Grid::new_in(candidates, k, std::mem::take(grid_bufs));
    out.par_chunks_mut(QUERY_BLOCK)
        .zip(targets.par_chunks(QUERY_BLOCK))
        .for_each(|(out, targets)| {
            let mut best = Best::new(k);
            let mut wide = Vec::new();
            // Targets come in scan order, so a query's k-th distance is close to the previous
            // one's: searching first only the cells within a little more than it skips most
            // candidates, and most insertions of those that would be pushed out later (see
            // `Grid::within`); the ring search without a limit takes the rest.
            let mut limit_m2 = f64::INFINITY;
            // The last seed: its position, its answer's squared radius, its answer's slot.
            let mut seed: Option<([f64; 3], f64, usize, Option<Plane>)> = None;
            for (i, q) in targets.iter().enumerate() {
                if i % stride != 0 {
                    if let Some((s, r2, at, plane)) = seed {
                        let d2 =
                            (q[0] - s[0]).powi(2) + (q[1] - s[1]).powi(2) + (q[2] - s[2]).powi(2);
                        if d2 <= r2
                            || plane
                                .is_some_and(|p| d2 <= SHARE_REACH * SHARE_REACH * r2 && p.holds(q))
                        {
                            out[i] = out[at].clone();
                            continue;
                        }
                    }
                }
                if !grid.within(q, &mut best, limit_m2) {
                    grid.nearest(q, &mut best, f64::INFINITY);
                }
                limit_m2 = if best.full() {
                    LIMIT_FACTOR * best.worst()
                } else {
                    f64::INFINITY
                };
                let (answer, r2, plane) = f(q, best.points(), &grid, &mut wide);
                out[i] = answer;
                // A target judged on its own seeds the rest of its group: on a scan line the
                // next targets lie in its neighbourhood rather than in the first seed's.
                if stride > 1 {
                    seed = Some((*q, r2, i, plane));
                }
            }
        });
    *grid_bufs = grid.into_buffers();
}

/// The neighbourhood of `q` judged by its dimensionality features.
#[cfg(test)]
fn judge_neighbours(q: &[f64; 3], nn: &[(f64, [f64; 3])]) -> Surface {
    if nn.len() < MIN_NEIGHBOURS {
        return Surface::TooFew;
    }
    judge_scatter(&scatter_of(q, nn), FLATNESS, true).0
}

/// The k nearest neighbours are planar only when σ₂ ≥ this × σ₃: a neighbourhood more planar
/// than scattered but thicker than that (a plane through leaves) is judged scattered; see the
/// module docs, "Beam-aware incidence".
pub const FLATNESS: f64 = 3.0;

/// The judgement of a scatter matrix (see the module docs), and its eigenvalues (ascending,
/// for [`Plane::of`]); a planar one must also have σ₂ ≥ `flatness` · σ₃ (planarity ≥
/// scattering alone implies 2).
fn judge_scatter(
    scatter: &Matrix3<f64>,
    flatness: f64,
    thick_scattered: bool,
) -> (Surface, [f64; 3]) {
    let values = symmetric_eigenvalues3(scatter);
    (
        judge_values(scatter, values, flatness, thick_scattered),
        values,
    )
}

/// [`judge_scatter`] given the scatter matrix's eigenvalues `[l3, l2, l1]` (ascending).
fn judge_values(
    scatter: &Matrix3<f64>,
    [l3, l2, l1]: [f64; 3],
    flatness: f64,
    thick_scattered: bool,
) -> Surface {
    // The values alone decide; only a planar neighbourhood needs its smallest one's vector,
    // then well separated from the other two (σ₂ > 2σ₃ and σ₂ ≥ σ₁/2).
    let (s1, s2, s3) = (l1.max(0.0).sqrt(), l2.max(0.0).sqrt(), l3.max(0.0).sqrt());
    if !(s1 > 0.0 && s1.is_finite()) {
        return Surface::TooFew;
    }
    let linearity = (s1 - s2) / s1;
    let planarity = (s2 - s3) / s1;
    let scattering = s3 / s1;
    if linearity >= planarity && linearity >= scattering {
        Surface::Linear(line_direction(scatter, l1))
    } else if scattering > planarity {
        Surface::Scattered
    } else if s2 < flatness * s3 {
        if thick_scattered {
            Surface::Scattered
        } else {
            Surface::Linear(line_direction(scatter, l1))
        }
    } else {
        let n = symmetric_eigenvector3(scatter, l3);
        let norm = n.norm();
        if norm > 0.0 && norm.is_finite() {
            Surface::Planar(n / norm)
        } else {
            Surface::TooFew
        }
    }
}

/// The unit eigenvector of the largest eigenvalue `l1` of a linear neighbourhood's scatter
/// matrix: the line's direction (`x` where it is not defined).
fn line_direction(scatter: &Matrix3<f64>, l1: f64) -> Vector3<f64> {
    let d = symmetric_eigenvector3(scatter, l1);
    let norm = d.norm();
    if norm > 0.0 && norm.is_finite() {
        d / norm
    } else {
        Vector3::x()
    }
}

/// Scatter matrix about the mean of `nn`, from offsets to `q`.
fn scatter_of(q: &[f64; 3], nn: &[(f64, [f64; 3])]) -> Matrix3<f64> {
    sums_of(q, nn).scatter()
}

/// The running sums of `nn`'s offsets to `q` ([`Sums`]).
fn sums_of(q: &[f64; 3], nn: &[(f64, [f64; 3])]) -> Sums {
    let mut sums = Sums::default();
    for (_, p) in nn {
        sums.add(q, p);
    }
    sums
}

/// A judged plane, for the targets beyond its neighbourhood that may take its judgement (see
/// the module docs, "Sharing"): a point of it, its unit normal, and how far off it a target may
/// lie.
#[derive(Clone, Copy, Debug)]
struct Plane {
    centre: [f64; 3],
    normal: [f64; 3],
    tolerance_m: f64,
}

impl Plane {
    /// The plane of unit normal `n` through the mean of the points summed in `sums` (offsets to
    /// `q`, their scatter matrix `scatter` and its ascending eigenvalues), with a tolerance of
    /// [`PLANE_TOLERANCE`] times their RMS distance from it.
    fn of(
        q: &[f64; 3],
        sums: &Sums,
        (scatter, [l3, l2, _]): (&Matrix3<f64>, [f64; 3]),
        n: Vector3<f64>,
    ) -> Option<Plane> {
        if l2.max(0.0) < REACH_FLATNESS * REACH_FLATNESS * l3.max(0.0) {
            return None;
        }
        let count = sums.n.max(1) as f64;
        let centre = [
            q[0] + sums.s[0] / count,
            q[1] + sums.s[1] / count,
            q[2] + sums.s[2] / count,
        ];
        let rms = ((n.transpose() * scatter * n)[0].max(0.0) / count).sqrt();
        Some(Plane {
            centre,
            normal: [n.x, n.y, n.z],
            tolerance_m: (PLANE_TOLERANCE * rms).max(PLANE_TOLERANCE_FLOOR_M),
        })
    }

    /// Whether `q` lies on the plane, within its tolerance.
    fn holds(&self, q: &[f64; 3]) -> bool {
        let d = [
            q[0] - self.centre[0],
            q[1] - self.centre[1],
            q[2] - self.centre[2],
        ];
        dot(&d, &self.normal).abs() <= self.tolerance_m
    }
}

/// Running sums of offsets to a query point and of their products, from which the scatter
/// matrix about the points' mean follows (so a widened neighbourhood adds only its new points).
#[derive(Default)]
struct Sums {
    s: [f64; 3],
    /// The six distinct products of the symmetric matrix, in the order of [`UPPER`].
    o: [f64; 6],
    n: usize,
}

impl Sums {
    fn add(&mut self, q: &[f64; 3], p: &[f64; 3]) {
        let d = [p[0] - q[0], p[1] - q[1], p[2] - q[2]];
        for (s, d) in self.s.iter_mut().zip(&d) {
            *s += d;
        }
        for (o, (i, j)) in self.o.iter_mut().zip(UPPER) {
            *o += d[i] * d[j];
        }
        self.n += 1;
    }

    /// `Σ d dᵀ − s sᵀ / n`, each of the six sums as that formula gives it.
    fn scatter(&self) -> Matrix3<f64> {
        let (s, o, k) = (&self.s, &self.o, self.n as f64);
        let c = |n: usize| o[n] - s[UPPER[n].0] * s[UPPER[n].1] / k;
        let (c00, c01, c02, c11, c12, c22) = (c(0), c(1), c(2), c(3), c(4), c(5));
        Matrix3::new(c00, c01, c02, c01, c11, c12, c02, c12, c22)
    }
}

/// The (row, column) of the upper triangle of a 3 × 3 matrix.
const UPPER: [(usize, usize); 6] = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)];

/// Plane normal from the neighbours of `q` (nearest first).
fn normal_of_neighbours(q: &[f64; 3], nn: &[(f64, [f64; 3])]) -> Option<Vector3<f64>> {
    if nn.len() < MIN_NEIGHBOURS {
        return None;
    }
    // Scatter about the mean from sums of offsets to the query point (offsets of metres keep
    // the sums well conditioned).
    normal_of_scatter(&scatter_of(q, nn))
}

/// The k best (squared distance, candidate index) so far, nearest first, in buffers reused
/// across queries; [`Grid::nearest`] then copies their points out. The k-th distance is kept
/// beside them (most candidates of a scan are farther, and the test against it is all they
/// cost); before k are held it is the query's limit.
struct Best {
    k: usize,
    /// How many of `d2` / `index` are held (≤ k); both have room for k + 1, so an insertion
    /// into a full buffer shifts the k-th out into the spare slot instead of testing for it.
    len: usize,
    d2: Vec<f64>,
    index: Vec<u32>,
    /// The k-th squared distance once k are held, the limit until then.
    worst: f64,
    /// The neighbours found by the last complete search, as (squared distance, point).
    items: Vec<(f64, [f64; 3])>,
}

impl Best {
    fn new(k: usize) -> Best {
        Best {
            k,
            len: 0,
            d2: vec![0.0; k + 1],
            index: vec![0; k + 1],
            worst: f64::INFINITY,
            items: Vec::with_capacity(k),
        }
    }

    /// Empties the buffer for a query that keeps only candidates closer than `limit_m2`.
    fn clear(&mut self, limit_m2: f64) {
        self.len = 0;
        self.worst = limit_m2;
    }

    fn full(&self) -> bool {
        self.len >= self.k
    }

    /// The k-th squared distance (the limit until k are held).
    fn worst(&self) -> f64 {
        self.worst
    }

    /// Keeps candidate `index` at squared distance `d2` if it comes before the k-th in the
    /// order of (squared distance, index): the k kept are then the same whatever order the
    /// candidates are offered in. NaN distances are never kept.
    #[inline]
    fn offer(&mut self, d2: f64, index: u32) {
        let before_kth =
            d2 < self.worst || (d2 == self.worst && self.full() && index < self.index[self.k - 1]);
        if before_kth {
            self.insert(d2, index);
        }
    }

    #[inline]
    fn insert(&mut self, d2: f64, index: u32) {
        let len = self.len;
        let (d, ix) = (&mut self.d2[..=len], &mut self.index[..=len]);
        let mut i = len;
        while i > 0 && (d[i - 1] > d2 || (d[i - 1] == d2 && ix[i - 1] > index)) {
            d[i] = d[i - 1];
            ix[i] = ix[i - 1];
            i -= 1;
        }
        d[i] = d2;
        ix[i] = index;
        if len < self.k {
            self.len = len + 1;
        }
        if self.len == self.k {
            self.worst = self.d2[self.k - 1];
        }
    }

    /// The neighbours of the last complete search (see [`Grid::nearest`]).
    fn points(&self) -> &[(f64, [f64; 3])] {
        &self.items
    }
}

/// Candidates bucketed in square cells on the plane of their two principal axes.
struct Grid {
    /// Unit principal axes (largest variance first), and the plane coordinates of cell (0, 0)'s
    /// corner.
    axes: [[f64; 3]; 2],
    origin: [f64; 2],
    /// Cell side, m, and the grid's size in cells.
    cell: f64,
    nu: usize,
    nv: usize,
    /// `start[c] .. start[c + 1]` indexes the candidates for cell `c = iv · nu + iu`.
    start: Vec<u32>,
    /// The candidates' coordinates in cell order, one array per axis (a row's distances are
    /// then computed side by side).
    xs: Vec<f64>,
    ys: Vec<f64>,
    zs: Vec<f64>,
    /// The building's cell of each candidate and fill counts, kept for [`Grid::into_buffers`].
    spare: (Vec<u32>, Vec<u32>),
}

/// The vectors a grid is built in, handed back after its searches for the next one: a caller
/// judging chunk after chunk then does not map (and fault in) them afresh.
#[derive(Default)]
pub struct GridBuffers {
    ids: Vec<u32>,
    start: Vec<u32>,
    fill: Vec<u32>,
    xs: Vec<f64>,
    ys: Vec<f64>,
    zs: Vec<f64>,
}

impl Grid {
    #[cfg(test)]
    fn new(candidates: &[[f64; 3]], k: usize) -> Grid {
        Grid::new_in(candidates, k, GridBuffers::default())
    }

    /// The grid of `candidates` for searches of `k` neighbours, built in `bufs`.
    fn new_in(candidates: &[[f64; 3]], k: usize, bufs: GridBuffers) -> Grid {
        let GridBuffers {
            mut ids,
            mut start,
            mut fill,
            mut xs,
            mut ys,
            mut zs,
        } = bufs;
        let n = candidates.len();
        let axes = principal_axes(candidates);
        let project = |p: &[f64; 3]| -> [f64; 2] { [dot(&axes[0], p), dot(&axes[1], p)] };
        // Extent from a sample's quantiles (a far outlier must not stretch the grid; points
        // outside are clamped into the border cells, which keeps the search exact).
        let step = (n / 4096).max(1);
        let sample: Vec<[f64; 2]> = candidates.iter().step_by(step).map(project).collect();
        let range = |axis: usize| -> (f64, f64) {
            let mut v: Vec<f64> = sample
                .iter()
                .map(|p| p[axis])
                .filter(|x| x.is_finite())
                .collect();
            if v.is_empty() {
                return (0.0, 0.0);
            }
            v.sort_by(f64::total_cmp);
            let cut = v.len() / 200;
            (v[cut], v[v.len() - 1 - cut])
        };
        let ((u0, u1), (v0, v1)) = (range(0), range(1));
        // About k · CELL_FILL candidates per cell on an evenly covered extent (at least one per
        // two cells); at most ~2 cells per candidate.
        let (du, dv) = ((u1 - u0).max(0.0), (v1 - v0).max(0.0));
        let per_cell = (k as f64 * CELL_FILL).max(0.5);
        let mut cell = (du * dv * per_cell / n as f64).sqrt();
        let floor = (du.max(dv) / (2.0 * n as f64)).max(1e-9);
        if !(cell.is_finite() && cell >= floor) {
            cell = floor.max(du.max(dv) / 64.0).max(1e-6);
        }
        let cells = |d: f64, cell: f64| ((d / cell).floor() as usize).saturating_add(1);
        let (mut nu, mut nv) = (cells(du, cell), cells(dv, cell));
        while nu.saturating_mul(nv) > 2 * n + 64 {
            cell *= 1.5;
            (nu, nv) = (cells(du, cell), cells(dv, cell));
        }
        let origin = [u0, v0];
        let index = |p: &[f64; 3]| -> usize {
            let [u, v] = project(p);
            let iu = clamp_cell((u - origin[0]) / cell, nu);
            let iv = clamp_cell((v - origin[1]) / cell, nv);
            iv * nu + iu
        };
        // Counting sort into cells (the cells found in parallel, the sort serial).
        {
            use rayon::prelude::*;
            candidates
                .par_iter()
                .with_min_len(QUERY_BLOCK)
                .map(|p| index(p) as u32)
                .collect_into_vec(&mut ids);
        }
        start.clear();
        start.resize(nu * nv + 1, 0);
        for &c in &ids {
            start[c as usize + 1] += 1;
        }
        for c in 0..nu * nv {
            start[c + 1] += start[c];
        }
        fill.clear();
        fill.extend_from_slice(&start);
        for v in [&mut xs, &mut ys, &mut zs] {
            v.clear();
            v.resize(n, 0.0);
        }
        for (p, &c) in candidates.iter().zip(&ids) {
            let slot = &mut fill[c as usize];
            let j = *slot as usize;
            (xs[j], ys[j], zs[j]) = (p[0], p[1], p[2]);
            *slot += 1;
        }
        Grid {
            axes,
            origin,
            cell,
            nu,
            nv,
            start,
            xs,
            ys,
            zs,
            spare: (ids, fill),
        }
    }

    /// The grid's vectors, for the next one.
    fn into_buffers(self) -> GridBuffers {
        let (ids, fill) = self.spare;
        GridBuffers {
            ids,
            start: self.start,
            fill,
            xs: self.xs,
            ys: self.ys,
            zs: self.zs,
        }
    }

    /// The columns and rows of cells (inclusive ranges, clamped into the grid) that hold every
    /// candidate within `limit_m2` (squared distance) of `q`: a 3-D distance is never shorter
    /// than its projection on the grid's plane.
    fn window(&self, q: &[f64; 3], limit_m2: f64) -> ((usize, usize), (usize, usize)) {
        // 1 µm for the rounding of the projection, as in `nearest`.
        let r = (limit_m2.sqrt() + 1e-6) / self.cell;
        let (u, v) = (
            (dot(&self.axes[0], q) - self.origin[0]) / self.cell,
            (dot(&self.axes[1], q) - self.origin[1]) / self.cell,
        );
        (
            (clamp_cell(u - r, self.nu), clamp_cell(u + r, self.nu)),
            (clamp_cell(v - r, self.nv), clamp_cell(v + r, self.nv)),
        )
    }

    /// The k nearest candidates of `q` searched among those closer than `limit_m2` (squared
    /// distance) in the cells that can hold them, i.e. the rows and columns of cells within
    /// √limit of `q` on the grid's plane (a distance is never shorter than its projection;
    /// points clamped into the border cells are scanned with them); false when fewer than k
    /// are that close (then the caller searches with [`Grid::nearest`]). The k nearest are all
    /// within the limit exactly when k candidates are, and [`Best`] orders ties by index, so
    /// when it reports k found they are those of [`Grid::nearest`], in the same order.
    fn within(&self, q: &[f64; 3], best: &mut Best, limit_m2: f64) -> bool {
        if !limit_m2.is_finite() {
            return false;
        }
        best.clear(limit_m2);
        let ((u_lo, u_hi), (v_lo, v_hi)) = self.window(q, limit_m2);
        for row in v_lo..=v_hi {
            self.scan(row as isize, u_lo as isize, u_hi as isize, q, best);
        }
        best.full() && self.copy_out(best)
    }

    /// The (up to) k nearest candidates of `q` into `best`, nearest first (ties by index),
    /// searched among those closer than `limit_m2` (squared distance); false when fewer than
    /// k are (then the caller searches again without a limit). With a limit the cells are
    /// scanned in the same order and the search stops at the same ring whenever k are found,
    /// so the neighbours and their order are those of the search without it: the k nearest
    /// are all within the limit exactly when k candidates are.
    fn nearest(&self, q: &[f64; 3], best: &mut Best, limit_m2: f64) -> bool {
        best.clear(limit_m2);
        let (u, v) = (dot(&self.axes[0], q), dot(&self.axes[1], q));
        let (fu, fv) = (
            (u - self.origin[0]) / self.cell,
            (v - self.origin[1]) / self.cell,
        );
        // Ring centre: the query's cell, clamped into the grid.
        let (cu, cv) = (
            clamp_cell(fu, self.nu) as isize,
            clamp_cell(fv, self.nv) as isize,
        );
        let (nu, nv) = (self.nu as isize, self.nv as isize);
        let want = best.k.min(self.xs.len());
        let mut r: isize = 0;
        loop {
            // Scan ring r: rows cv ± r in full, columns cu ± r between them.
            let (u_lo, u_hi) = ((cu - r).max(0), (cu + r).min(nu - 1));
            for row in [cv - r, cv + r] {
                if (0..nv).contains(&row) {
                    self.scan(row, u_lo, u_hi, q, best);
                }
                if r == 0 {
                    break;
                }
            }
            if r > 0 {
                for row in (cv - r + 1).max(0)..=(cv + r - 1).min(nv - 1) {
                    if cu - r >= 0 {
                        self.scan(row, cu - r, cu - r, q, best);
                    }
                    if cu + r < nu {
                        self.scan(row, cu + r, cu + r, q, best);
                    }
                }
            }
            // Unscanned candidates lie beyond the block's sides that are inside the grid (a
            // side on or past the grid's edge has nothing beyond it: outliers were clamped into
            // the border cells). Their distance is at least the projected distance to the
            // nearest such side (less 1 µm for the rounding of the projection).
            let mut bound = f64::INFINITY;
            if cu - r > 0 {
                bound = bound.min(fu - (cu - r) as f64);
            }
            if cu + r < nu - 1 {
                bound = bound.min((cu + r + 1) as f64 - fu);
            }
            if cv - r > 0 {
                bound = bound.min(fv - (cv - r) as f64);
            }
            if cv + r < nv - 1 {
                bound = bound.min((cv + r + 1) as f64 - fv);
            }
            let found = best.len >= want;
            if bound == f64::INFINITY {
                // Every cell scanned.
                return (found || limit_m2 == f64::INFINITY) && self.copy_out(best);
            }
            let b = (bound * self.cell - 1e-6).max(0.0);
            if found && best.worst() < b * b {
                return self.copy_out(best);
            }
            if !found && limit_m2 <= b * b {
                // Nothing unscanned is within the limit.
                return false;
            }
            r += 1;
        }
    }

    /// Every candidate within `limit_m2` (squared distance) of `q`, as (squared distance,
    /// index into the grid's arrays), into `out` (cleared first), in cell order.
    fn gather(&self, q: &[f64; 3], limit_m2: f64, out: &mut Vec<(f64, u32)>) {
        out.clear();
        let ((u_lo, u_hi), (v_lo, v_hi)) = self.window(q, limit_m2);
        for row in v_lo..=v_hi {
            let base = row * self.nu;
            let (a, b) = (
                self.start[base + u_lo] as usize,
                self.start[base + u_hi + 1] as usize,
            );
            let (xs, ys, zs) = (&self.xs[a..b], &self.ys[a..b], &self.zs[a..b]);
            for (j, ((x, y), z)) in xs.iter().zip(ys).zip(zs).enumerate() {
                let (dx, dy, dz) = (x - q[0], y - q[1], z - q[2]);
                let d2 = dx * dx + dy * dy + dz * dz;
                if d2 <= limit_m2 {
                    out.push((d2, (a + j) as u32));
                }
            }
        }
    }

    /// Candidate `j` (an index into the grid's arrays).
    fn point(&self, j: usize) -> [f64; 3] {
        [self.xs[j], self.ys[j], self.zs[j]]
    }

    /// The points of `best`'s neighbours into its `items`; true.
    fn copy_out(&self, best: &mut Best) -> bool {
        best.items.clear();
        for (&d2, &j) in best.d2[..best.len].iter().zip(&best.index) {
            let j = j as usize;
            best.items.push((d2, [self.xs[j], self.ys[j], self.zs[j]]));
        }
        true
    }

    /// Offers the candidates of cells `u_lo ..= u_hi` of row `row` (contiguous in the arrays).
    #[inline]
    fn scan(&self, row: isize, u_lo: isize, u_hi: isize, q: &[f64; 3], best: &mut Best) {
        let base = row as usize * self.nu;
        let (a, b) = (
            self.start[base + u_lo as usize] as usize,
            self.start[base + u_hi as usize + 1] as usize,
        );
        let (xs, ys, zs) = (&self.xs[a..b], &self.ys[a..b], &self.zs[a..b]);
        for (j, ((x, y), z)) in xs.iter().zip(ys).zip(zs).enumerate() {
            let (dx, dy, dz) = (x - q[0], y - q[1], z - q[2]);
            best.offer(dx * dx + dy * dy + dz * dz, (a + j) as u32);
        }
    }
}

/// Cell index of a plane coordinate in cell units, clamped to `0 .. n` (NaN → 0).
fn clamp_cell(f: f64, n: usize) -> usize {
    if f >= 0.0 { (f as usize).min(n - 1) } else { 0 }
}

fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The two principal axes (largest variance first) of a sample of the points; x and y when
/// there is no spread.
fn principal_axes(points: &[[f64; 3]]) -> [[f64; 3]; 2] {
    let step = (points.len() / 4096).max(1);
    let (mut n, mut sum, mut outer) = (0.0, Vector3::zeros(), Matrix3::zeros());
    let first = Vector3::from(points[0]);
    for p in points.iter().step_by(step) {
        let d = Vector3::from(*p) - first;
        if d.iter().all(|x| x.is_finite()) {
            n += 1.0;
            sum += d;
            outer += d * d.transpose();
        }
    }
    let fallback = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    if n < 2.0 {
        return fallback;
    }
    let (vals, vecs) = symmetric_eigen3(&(outer - sum * sum.transpose() / n));
    if !(vals[1] > 0.0 && vals[2].is_finite()) {
        return fallback;
    }
    let axis = |v: &Vector3<f64>| [v.x, v.y, v.z];
    [axis(&vecs[2]), axis(&vecs[1])]
}

/// Normal of the total-least-squares plane through `points` (≥ 3, not collinear), `n_z ≥ 0`
/// ([`lidarqa_model::fit_plane`]).
pub fn fit_normal(points: &[Vector3<f64>]) -> Option<Vector3<f64>> {
    lidarqa_model::fit_plane(points).map(|p| p.normal)
}

/// Angle between a beam direction and a surface normal, rad in [0, π/2] (the sign of either
/// does not matter).
pub fn incidence_angle(beam: &Vector3<f64>, normal: &Vector3<f64>) -> f64 {
    cos_incidence(beam, normal).acos()
}

/// |cos| of the angle between a beam direction and a surface normal, in [0, 1] (the sign of
/// either does not matter): what the incidence term takes ([`crate::Incidence`]).
pub fn cos_incidence(beam: &Vector3<f64>, normal: &Vector3<f64>) -> f64 {
    let c = (beam.dot(normal) / (beam.norm() * normal.norm())).abs();
    c.clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn judge_tells_planes_lines_and_clouds_apart() {
        // A tilted grid (z = 0.2 x), one scan line (x only, 5 cm jitter-free), a 3-D blob.
        let plane: Vec<[f64; 3]> = (0..100)
            .map(|i| {
                let (x, y) = (f64::from(i % 10), f64::from(i / 10));
                [x, y, 0.2 * x]
            })
            .collect();
        let s = judge_surfaces(&plane, &[[4.5, 4.5, 0.9]], 10);
        let n = s[0].normal().expect("planar");
        let expect = Vector3::new(-0.2, 0.0, 1.0).normalize();
        assert_relative_eq!(n.dot(&expect).abs(), 1.0, epsilon = 1e-9);
        // One scan line: points 0.5 m apart with a 1 cm wiggle across.
        let line: Vec<[f64; 3]> = (0..50)
            .map(|i| {
                let x = 0.5 * f64::from(i);
                [x, 0.01 * (x * 3.0).sin(), 0.01 * (x * 5.0).cos()]
            })
            .collect();
        let Surface::Linear(d) = judge_surfaces(&line, &[[10.0, 0.0, 0.0]], 10)[0] else {
            panic!("linear")
        };
        // The line's direction is x, to its 1 cm wiggle over a 5 m neighbourhood.
        assert!(d.x.abs() > 0.999, "{d}");
        // A cube of points: scattered.
        let cube: Vec<[f64; 3]> = (0..125)
            .map(|i| [f64::from(i % 5), f64::from((i / 5) % 5), f64::from(i / 25)])
            .collect();
        assert_eq!(
            judge_surfaces(&cube, &[[2.0, 2.0, 2.0]], 27)[0],
            Surface::Scattered
        );
        assert_eq!(
            judge_surfaces(&cube[..2], &[[0.0, 0.0, 0.0]], 10)[0],
            Surface::TooFew
        );
    }

    #[test]
    fn tilted_plane_normal_and_incidence() {
        // z = 0.5 x: normal ∝ (−0.5, 0, 1).
        let mut pts = vec![];
        for i in 0..20 {
            for j in 0..20 {
                let (x, y) = (f64::from(i) * 0.7, f64::from(j) * 0.6);
                pts.push([x, y, 0.5 * x]);
            }
        }
        let normals = plane_normals(&pts, &pts[100..110], 8);
        let want = Vector3::new(-0.5, 0.0, 1.0).normalize();
        for n in normals {
            let n = n.unwrap();
            assert_relative_eq!(n.dot(&want).abs(), 1.0, epsilon = 1e-12);
        }
        // A vertical beam meets the plane at atan(0.5).
        let a = incidence_angle(&Vector3::new(0.0, 0.0, 1.0), &want);
        assert_relative_eq!(a, 0.5f64.atan(), epsilon = 1e-12);
    }

    /// The implementation this module replaced (kiddo k-d tree, nalgebra's iterative symmetric
    /// eigen-decomposition), kept as the reference.
    fn reference_normals(
        candidates: &[[f64; 3]],
        targets: &[[f64; 3]],
        k: usize,
    ) -> Vec<Option<Vector3<f64>>> {
        use kiddo::{ImmutableKdTree, SquaredEuclidean};
        use std::num::NonZero;
        let k = k.max(MIN_NEIGHBOURS);
        if candidates.len() < MIN_NEIGHBOURS {
            return vec![None; targets.len()];
        }
        let tree: ImmutableKdTree<f64, 3> = ImmutableKdTree::new_from_slice(candidates);
        let qty = NonZero::new(k).unwrap();
        targets
            .iter()
            .map(|q| {
                let nn = tree.nearest_n::<SquaredEuclidean>(q, qty);
                let q = Vector3::from(*q);
                let (mut sum, mut outer) = (Vector3::zeros(), Matrix3::zeros());
                for n in &nn {
                    let d = Vector3::from(candidates[n.item as usize]) - q;
                    sum += d;
                    outer += d * d.transpose();
                }
                let kk = nn.len() as f64;
                if nn.len() < MIN_NEIGHBOURS {
                    return None;
                }
                let scatter = outer - sum * sum.transpose() / kk;
                let eig = scatter.symmetric_eigen();
                let mut order = [0usize, 1, 2];
                order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
                let (l0, l1) = (eig.eigenvalues[order[0]], eig.eigenvalues[order[1]]);
                let planar = l1 > 1e-12 * eig.eigenvalues[order[2]].max(f64::MIN_POSITIVE);
                if !planar || !l0.is_finite() {
                    return None;
                }
                let n: Vector3<f64> = eig.eigenvectors.column(order[0]).into_owned();
                Some(n / n.norm())
            })
            .collect()
    }

    /// An airborne-like strip in a tilted frame (ECEF-like offsets): scan lines across a
    /// wavy surface with millimetre noise, plus a wall, a stack of points in one column,
    /// duplicates and a far outlier.
    fn strip(seed: u64, n: usize) -> Vec<[f64; 3]> {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let r = nalgebra::Rotation3::from_euler_angles(0.4, -0.7, 1.1);
        let mut pts: Vec<[f64; 3]> = (0..n)
            .map(|i| {
                let t = i as f64 / 2000.0; // 2000 points per scan line
                let phase = t.fract();
                let across = 300.0 * (1.0 - 4.0 * (phase - 0.5).abs()) - 150.0;
                let along = 0.3 * i as f64 / 2000.0 + rng.random_range(-0.01..0.01);
                let h = 2.0 * (across / 40.0).sin()
                    + 0.5 * (along / 7.0).cos()
                    + rng.random_range(-0.003..0.003);
                let p = r * Vector3::new(along, across, h);
                [p.x, p.y, p.z]
            })
            .collect();
        for i in 0..200 {
            // A vertical wall and a column of stacked returns.
            let p = r * Vector3::new(5.0, 20.0 + f64::from(i % 20) * 0.1, f64::from(i / 20));
            pts.push([p.x, p.y, p.z]);
            let p = r * Vector3::new(8.0, -40.0, -1.0 + f64::from(i) * 0.05);
            pts.push([p.x, p.y, p.z]);
        }
        let dup = pts[1234];
        pts.extend([dup; 4]);
        pts.push([1e5, -3e4, 2e4]);
        pts
    }

    /// λ2 / (λ1 − λ0) of the scatter of the k nearest neighbours of `q`.
    fn condition(pts: &[[f64; 3]], q: &[f64; 3], k: usize) -> f64 {
        let grid = Grid::new(pts, k);
        let mut best = Best::new(k);
        grid.nearest(q, &mut best, f64::INFINITY);
        let mean = best
            .points()
            .iter()
            .map(|(_, p)| Vector3::from(*p))
            .sum::<Vector3<f64>>()
            / best.points().len() as f64;
        let s: Matrix3<f64> = best
            .points()
            .iter()
            .map(|(_, p)| (Vector3::from(*p) - mean) * (Vector3::from(*p) - mean).transpose())
            .sum();
        let mut e: Vec<f64> = s.symmetric_eigen().eigenvalues.iter().copied().collect();
        e.sort_by(f64::total_cmp);
        e[2] / (e[1] - e[0])
    }

    #[test]
    fn grid_search_equals_the_kd_tree_and_normals_the_previous_implementation() {
        for (seed, k) in [(1, 10), (2, 3), (3, 25)] {
            let pts = strip(seed, 60_000);
            let targets: Vec<[f64; 3]> = pts
                .iter()
                .step_by(7)
                .copied()
                .chain([
                    [0.0, 0.0, 500.0],  // above the strip, not a candidate
                    [-3e5, 1e5, 0.0],   // far outside the grid
                    [1e5, -3e4, 2.0e4], // next to the outlier
                ])
                .collect();
            let new = plane_normals(&pts, &targets, k);
            let old = reference_normals(&pts, &targets, k);
            let mut compared = 0;
            for (i, (a, b)) in new.iter().zip(&old).enumerate() {
                match (a, b) {
                    (Some(a), Some(b)) => {
                        // Same neighbours, same normal to rounding (sign arbitrary).
                        let d = (a - b).norm().min((a + b).norm());
                        // Both solvers are exact to rounding, i.e. to ~ε · λ2 / (λ1 − λ0): that
                        // of the neighbourhood's scatter (near-collinear neighbours, the
                        // outlier's far neighbours).
                        if d >= 1e-9 {
                            let cond = condition(&pts, &targets[i], k);
                            assert!(d < 1e-13 * cond, "target {i}: {a} vs {b} ({cond})");
                        }
                        compared += 1;
                    }
                    (None, None) => {}
                    _ => panic!("target {i}: {a:?} vs {b:?}"),
                }
            }
            // The stacked column has no plane: the rest all compared.
            assert!(
                compared > targets.len() * 99 / 100,
                "{compared} of {}",
                targets.len()
            );
        }
    }

    #[test]
    fn per_point_sigma_with_incidence_is_unchanged_from_the_previous_implementation() {
        // The per-point σ (J Σ Jᵀ + the incidence term) with the normals of this module and
        // with those of the kd-tree + nalgebra implementation: equal to 1e-9 relative wherever
        // the plane fit is well posed (the bench strip in lidarqa-pipeline, with its ten
        // nearest neighbours all on one scan line, is not: there both normals are rounding
        // noise amplified ~1e9 times, and so is the incidence term).
        use crate::{Incidence, PointPropagator, Preset};
        use lidarqa_model::{Attitude, Georeferencer, LinearObservation, LinearScanner, Mounting};
        let pp =
            PointPropagator::new(LinearScanner, &Preset::Zhang2018.sensor(), Some(0.5e-3)).unwrap();
        let pts = strip(5, 40_000);
        let targets: Vec<[f64; 3]> = pts[..40_000].iter().step_by(11).copied().collect();
        let (new, old) = (
            plane_normals(&pts, &targets, 10),
            reference_normals(&pts, &targets, 10),
        );
        let mut compared = 0;
        for (i, (a, b)) in new.iter().zip(&old).enumerate() {
            let (Some(a), Some(b)) = (a, b) else {
                assert_eq!(a.is_some(), b.is_some());
                continue;
            };
            let t = i as f64;
            let att = Attitude::from_degrees((t * 0.1).sin(), 2.0, t % 360.0);
            let obs = LinearObservation {
                range_m: 800.0,
                scan_angle_rad: (t * 0.013).sin() * 0.5,
            };
            let p = LinearScanner.parameters(&att, &Mounting::default(), &obs);
            let beam = Vector3::new(0.3 * (t * 0.7).sin(), 0.2, 1.0).normalize();
            let sigma = |n: &Vector3<f64>| {
                let inc = Incidence {
                    range_m: 800.0,
                    beam_ned: lidarqa_model::Ned::from_vector(beam),
                    cos_incidence: cos_incidence(&beam, n),
                };
                let u = pp.propagate(&p, None, Some(&inc)).unwrap();
                u.covariance_ned.diagonal().map(f64::sqrt)
            };
            let (sa, sb) = (sigma(a), sigma(b));
            for k in 0..3 {
                assert!(
                    (sa[k] - sb[k]).abs() <= 1e-9 * sb[k],
                    "target {i}: {sa} vs {sb}"
                );
            }
            compared += 1;
        }
        assert!(compared > 3500, "{compared}");
    }

    #[test]
    fn grid_search_finds_the_exact_neighbours() {
        use kiddo::{ImmutableKdTree, SquaredEuclidean};
        let pts = strip(4, 30_000);
        let k = 12;
        let grid = Grid::new(&pts, k);
        let tree: ImmutableKdTree<f64, 3> = ImmutableKdTree::new_from_slice(&pts);
        let mut best = Best::new(k);
        for q in pts
            .iter()
            .step_by(3)
            .chain(&[[0.0, 0.0, 900.0], [7e5, 0.0, 0.0]])
        {
            assert!(grid.nearest(q, &mut best, f64::INFINITY));
            let want = tree.nearest_n::<SquaredEuclidean>(q, std::num::NonZero::new(k).unwrap());
            assert_eq!(best.points().len(), want.len());
            for (g, w) in best.points().iter().zip(&want) {
                assert_eq!(g.0, w.distance);
            }
        }
        // Fewer candidates than k: all of them.
        let few = &pts[..5];
        let grid = Grid::new(few, k);
        assert!(grid.nearest(&[0.0; 3], &mut best, f64::INFINITY));
        assert_eq!(best.points().len(), 5);
    }

    #[test]
    fn a_limited_search_finds_the_same_neighbours_or_says_it_did_not() {
        // Every limit from far too small to ample, on the strip with its wall, stacked returns,
        // duplicates and outlier: the same points in the same order whenever it reports k found,
        // and it reports so whenever the k-th is within the limit.
        let pts = strip(4, 30_000);
        let k = 10;
        let grid = Grid::new(&pts, k);
        let mut free = Best::new(k);
        let (hits, misses) = limited_searches(
            &grid,
            &pts,
            7,
            k,
            &[0.0, 0.3, 0.9, 1.0, 1.0000001, 1.5, 2.0, 50.0],
            Grid::nearest,
        );
        assert!(hits > 10_000 && misses > 10_000, "{hits} {misses}");
        // The whole neighbourhood pass gives what one unlimited search per target gives.
        let targets: Vec<[f64; 3]> = pts.iter().step_by(5).copied().collect();
        let got = for_each_neighbourhood(&pts, &targets, k, Vec::new(), |_, nn| nn.to_vec());
        for (q, g) in targets.iter().zip(&got) {
            grid.nearest(q, &mut free, f64::INFINITY);
            assert_eq!(g.as_slice(), free.points());
        }
    }

    #[test]
    fn a_window_search_finds_the_same_neighbours_or_says_it_did_not() {
        // `within` against `nearest` without a limit, for limits from far too small to ample,
        // with two cell sizes (k sets the cells) and with points on the mm grid of a LAS file
        // (many exact ties in distance: the order by index settles them the same way).
        let mut pts = strip(6, 30_000);
        for p in pts.iter_mut().step_by(2) {
            *p = p.map(|x| (x * 1000.0).round() / 1000.0);
        }
        for k in [10, 40] {
            let (hits, misses) = limited_searches(
                &Grid::new(&pts, k),
                &pts,
                5,
                k,
                &[
                    0.0,
                    0.3,
                    0.9,
                    1.0,
                    1.0000001,
                    1.25,
                    2.0,
                    50.0,
                    f64::INFINITY,
                ],
                Grid::within,
            );
            assert!(hits > 15_000 && misses > 15_000, "{hits} {misses}");
        }
    }

    /// `search` with limits of `factors` times the k-th squared distance, from every `step`-th
    /// point and two far queries, against [`Grid::nearest`] without a limit: the same points in
    /// the same order whenever it reports k found, and it reports so whenever the k-th is
    /// within the limit. (Reports, misses.)
    fn limited_searches(
        grid: &Grid,
        pts: &[[f64; 3]],
        step: usize,
        k: usize,
        factors: &[f64],
        search: impl Fn(&Grid, &[f64; 3], &mut Best, f64) -> bool,
    ) -> (usize, usize) {
        let (mut free, mut limited) = (Best::new(k), Best::new(k));
        let (mut hits, mut misses) = (0, 0);
        for q in pts
            .iter()
            .step_by(step)
            .chain(&[[0.0, 0.0, 900.0], [7e5, 0.0, 0.0]])
        {
            assert!(grid.nearest(q, &mut free, f64::INFINITY));
            let kth = free.worst();
            for factor in factors {
                let limit = kth * factor;
                if search(grid, q, &mut limited, limit) {
                    assert_eq!(limited.points(), free.points(), "{q:?} {factor}");
                    hits += 1;
                } else {
                    assert!(kth >= limit || limit == f64::INFINITY, "{q:?} {factor}");
                    misses += 1;
                }
            }
        }
        (hits, misses)
    }

    #[test]
    fn judgement_from_the_values_alone_is_that_of_the_full_solver() {
        // The judgement as it was (every eigenvalue and vector from `symmetric_eigen3`)
        // against this one's (the values from the cubic, the smallest one's vector only for a
        // plane), on the strip's neighbourhoods (planes, single scan lines, the wall, the
        // stacked column, duplicates): the same kind everywhere, normals to rounding.
        fn previous(q: &[f64; 3], nn: &[(f64, [f64; 3])]) -> Surface {
            let ([l3, l2, l1], [n, _, along]) = symmetric_eigen3(&scatter_of(q, nn));
            let (s1, s2, s3) = (l1.max(0.0).sqrt(), l2.max(0.0).sqrt(), l3.max(0.0).sqrt());
            if !(s1 > 0.0 && s1.is_finite()) {
                return Surface::TooFew;
            }
            let (linearity, planarity, scattering) = ((s1 - s2) / s1, (s2 - s3) / s1, s3 / s1);
            if linearity >= planarity && linearity >= scattering {
                Surface::Linear(along)
            } else if scattering > planarity || s2 < FLATNESS * s3 {
                Surface::Scattered
            } else {
                Surface::Planar(n / n.norm())
            }
        }
        let mut kinds = [0usize; 4];
        for (seed, k) in [(7, 10), (8, 4), (9, 30)] {
            let pts = strip(seed, 40_000);
            let both = for_each_neighbourhood(&pts, &pts, k, None, |q, nn| {
                Some((judge_neighbours(q, nn), previous(q, nn)))
            });
            for (now, before) in both.into_iter().flatten() {
                match (now, before) {
                    (Surface::Planar(a), Surface::Planar(b)) => {
                        let d = (a - b).norm().min((a + b).norm());
                        assert!(d < 1e-12, "{a} vs {b}");
                        kinds[0] += 1;
                    }
                    (Surface::Linear(a), Surface::Linear(b)) => {
                        assert!(a.dot(&b).abs() > 1.0 - 1e-9, "{a} vs {b}");
                        kinds[1] += 1;
                    }
                    (a, b) => {
                        assert_eq!(a, b);
                        kinds[match a {
                            Surface::Linear(_) => 1,
                            Surface::Scattered => 2,
                            _ => 3,
                        }] += 1;
                    }
                }
            }
        }
        assert!(
            kinds[0] > 50_000 && kinds[1] > 30_000 && kinds[2] > 30,
            "{kinds:?}"
        );
    }

    /// The plane z = 0.2 x sampled on lines `across` m apart, points `along` m apart on them
    /// (1 mm noise), 5 km from the [`strip`]: the k = 10 nearest lie on one line.
    fn scan_lines(along: f64, across: f64, lines: usize) -> Vec<[f64; 3]> {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let mut pts = Vec::new();
        for l in 0..lines {
            for i in 0..(60.0 / along) as usize {
                let z = 0.2 * i as f64 * along + rng.random_range(-0.001..0.001);
                pts.push([
                    5000.0 + i as f64 * along,
                    5000.0 + l as f64 * across,
                    1000.0 + z,
                ]);
            }
        }
        pts
    }

    #[test]
    fn a_shared_plane_stops_at_a_ridge_and_reaches_along_its_own_slope() {
        // A gable roof (slopes of ±30° meeting at x = 0), sampled on a 0.1 m lattice with 2 mm
        // noise, scanned row by row across the ridge: the k nearest are planar everywhere but at
        // the ridge, and a plane shared beyond its neighbourhood must not cross it.
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let slope = 30f64.to_radians().tan();
        let mut pts = Vec::new();
        for row in 0..21 {
            for col in 0..61 {
                let x = -3.0 + 0.1 * col as f64;
                let z = 10.0 - slope * x.abs() + rng.random_range(-0.002..0.002);
                pts.push([x, -1.0 + 0.1 * row as f64, z]);
            }
        }
        let shared = judge_surfaces(&pts, &pts, 10);
        let own = judge_surfaces_shared(&pts, &pts, 10, 1);
        let side = |x: f64| Vector3::new(slope * x.signum(), 0.0, 1.0).normalize();
        let (mut reached, mut planes) = (0, 0);
        for (i, p) in pts.iter().enumerate() {
            // Away from the ridge (its neighbourhood straddles both slopes within ~0.2 m).
            if p[0].abs() < 0.35 {
                continue;
            }
            let n = shared[i].normal().expect("a plane on either slope");
            assert!(
                n.dot(&side(p[0])).abs() > 5f64.to_radians().cos(),
                "point {i} at x = {:.2} took the other slope's plane: {n:?}",
                p[0]
            );
            planes += 1;
            if shared[i] != own[i] {
                reached += 1;
            }
        }
        // The sharing does happen: most points take a judgement made at another point.
        assert!(reached * 2 > planes, "{reached} of {planes} shared");
    }

    #[test]
    fn widening_gives_the_same_judgements_on_any_number_of_threads() {
        // Scan lines 2.5 m apart, 0.1 m along: linear at k = 10, planar when widened. The
        // result must not depend on how rayon splits the targets.
        let mut pts = scan_lines(0.1, 2.5, 12);
        pts.extend(strip(12, 20_000));
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| judge_surfaces(&pts, &pts, 10))
        };
        let one = run(1);
        assert_eq!(one, run(3));
        let widened = one[..7200]
            .iter()
            .filter(|s| matches!(s, Surface::PlanarWidened(_)))
            .count();
        assert!(widened > 7000, "{widened}");
        // Normal of z = 0.2 x, widened or not: within 0.1° of the truth.
        let truth = Vector3::new(-0.2, 0.0, 1.0).normalize();
        for s in &one[..7200] {
            let n = s.normal().unwrap();
            assert!(n.dot(&truth).abs() > 0.1f64.to_radians().cos(), "{n}");
        }
    }

    #[test]
    fn a_shared_judgement_is_the_seeds_or_the_targets_own_and_the_same_in_pieces() {
        // Scan lines (widened), and the strip with its wall, column and duplicates.
        let mut pts = scan_lines(0.1, 2.5, 12);
        pts.extend(strip(14, 20_000));
        let every = judge_surfaces_shared(&pts, &pts, 10, 1);
        let shared = judge_surfaces(&pts, &pts, 10);
        let mut taken = 0;
        for (i, s) in shared.iter().enumerate() {
            let group = i - i % SHARE_STRIDE..i;
            // A shared judgement is the own judgement of a target before it in its group (the
            // group's seed, or one judged on its own that seeded the rest).
            let earlier = group.clone().any(|j| *s == every[j]);
            if *s != every[i] {
                assert!(earlier, "target {i}");
            }
            taken += usize::from(i < 7200 && earlier && !group.is_empty());
        }
        // The first target of each group is judged as on its own; on the scan lines (widened
        // neighbourhoods, the first 7 200 points) most targets take an earlier judgement.
        assert!(
            shared
                .iter()
                .zip(&every)
                .step_by(SHARE_STRIDE)
                .all(|(a, b)| a == b)
        );
        let followers = 7200 - 7200 / SHARE_STRIDE;
        assert!(taken > followers * 3 / 4, "{taken} of {followers}");
        // Judged in pieces that start at multiples of the stride (not of the thread's block),
        // against the same candidates: the same judgements.
        let cut = 11_072;
        assert!(cut % SHARE_STRIDE == 0 && cut % QUERY_BLOCK != 0);
        let mut pieces = judge_surfaces(&pts, &pts[..cut], 10);
        pieces.extend(judge_surfaces(&pts, &pts[cut..], 10));
        assert_eq!(pieces, shared);
        // Stride 1 is every target judged on its own, on any number of threads.
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| judge_surfaces_shared(&pts, &pts, 10, 1));
        assert_eq!(one, every);
    }

    #[test]
    fn widened_neighbourhoods_are_the_exact_nearest() {
        // The candidates `gather` finds within a radius, ordered by (distance, index), against
        // the exact search for as many: the same points in the same order.
        let mut pts = scan_lines(0.1, 2.5, 6);
        pts.extend(strip(13, 10_000));
        let grid = Grid::new(&pts, 10);
        let mut wide = Vec::new();
        for q in pts.iter().step_by(37) {
            grid.gather(q, 9.0, &mut wide);
            let m = wide.len().min(MAX_NEIGHBOURS);
            if m < MIN_NEIGHBOURS {
                continue;
            }
            wide.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            let mut best = Best::new(m);
            assert!(grid.nearest(q, &mut best, f64::INFINITY));
            for ((d2, j), (want_d2, want_p)) in wide.iter().zip(best.points()) {
                assert_eq!((*d2, grid.point(*j as usize)), (*want_d2, *want_p));
            }
        }
    }

    #[test]
    fn a_line_alone_stays_linear_however_wide() {
        let line: Vec<[f64; 3]> = (0..2000).map(|i| [f64::from(i) * 0.1, 0.0, 0.0]).collect();
        assert!(
            judge_surfaces(&line, &line, 10)
                .iter()
                .all(|s| matches!(s, Surface::Linear(_)))
        );
    }

    #[test]
    fn collinear_or_too_few_points_have_no_normal() {
        let line: Vec<_> = (0..10)
            .map(|i| Vector3::new(f64::from(i), 0.0, 0.0))
            .collect();
        assert!(fit_normal(&line).is_none());
        assert!(plane_normals(&[[0.0; 3], [1.0, 0.0, 0.0]], &[[0.0; 3]], 8)[0].is_none());
    }
}
