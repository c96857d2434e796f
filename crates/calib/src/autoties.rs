//! Automatic tie selection (`--auto-ties`).
//!
//! Selection rule:
//! 1. Candidate centres on a square grid of [`AutoTieOptions::spacing_m`] over the strips' extent;
//!    a centre counts when at least two strips have [`AutoTieOptions::min_points`] points within
//!    [`AutoTieOptions::patch_radius_m`].
//! 2. In each covering strip the patch must be planar: RANSAC keeps at least 90 % of the points
//!    within [`AutoTieOptions::planarity_m`].
//! 3. **Markings** — flat patches (slope < 5°) with intensity contrast: in every strip the bright
//!    points (above the midpoint of the patch's 5th and 95th intensity percentiles, the 95th at
//!    least twice the 5th, the bright and the dark intensities at least 4 pooled standard
//!    deviations apart: paint, not the bright tail of noisy intensity) are 5–60 % of the patch. The pick in each strip is the centroid of its
//!    bright points (recomputed once around the first centroid), so the tie is the marking as that
//!    strip sees it: a [`TieKind::Feature`] tie observing all three coordinates, or, when the bright
//!    points are elongated (eigenvalue ratio > 4: a centre line, a stripe), a [`TieKind::Line`] tie
//!    observing across the line and in height only (along the line the centroid only follows the
//!    window: on simulated centre lines it scattered by 0.2–0.4 m and spoiled the solution).
//!    A marking with fewer than 12 bright points in some strip is no horizontal tie: when the
//!    points across it are farther apart than it is wide, the centroid is wherever the scan
//!    lines happened to cross it, a few cm off in each strip and the same along the whole strip
//!    (a bias, not noise); such a patch becomes a [`TieKind::Surface`] tie at one place.
//! 4. **Roofs** — planar patches sloped 10–60°: a [`TieKind::Surface`] tie at the grid centre in
//!    every strip, observing only along the plane normal (nothing fixes a point within a roof face);
//!    the patch must be the same face in every strip (normals within 3°).
//! 5. Spread: candidates are binned by kind, by a 3 × 3 division of the candidates' extent, by
//!    |scan angle| in the first covering strip (three bins over its range) and, for roofs, by
//!    aspect (8 sectors of 45°) and slope (below / above 30°); bins are visited round-robin, best
//!    candidate first (markings by contrast, roofs by planarity), until
//!    [`AutoTieOptions::max_ties`].

use crate::error::{Error, Result};
use crate::geometry::{quadratic_sag_m, ransac_plane};
use crate::strip::{Georeferencing, Strip, check_strips, within};
use crate::vtpm::{
    Indexed, PickInStrip, Tie, TieKind, TiePick, VtpmOptions, build_virtual_tie, mix_seed,
};
use lidarqa_model::Mounting;
use nalgebra::Vector3;
use rayon::prelude::*;
use std::collections::BTreeMap;

/// Options of the automatic tie search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AutoTieOptions {
    /// Candidate grid spacing, m.
    pub spacing_m: f64,
    /// Patch radius, m.
    pub patch_radius_m: f64,
    /// Minimum points of one strip in a patch.
    pub min_points: usize,
    /// Planarity threshold (RANSAC inlier distance), m.
    pub planarity_m: f64,
    /// Largest number of ties returned.
    pub max_ties: usize,
    /// RANSAC seed.
    pub seed: u64,
    /// The VTPM options the ties will be used with: a candidate is kept only when every one of
    /// its picks gives a virtual tie with them (a coplanar triangle around the pick).
    pub vtpm: VtpmOptions,
}

impl Default for AutoTieOptions {
    fn default() -> Self {
        AutoTieOptions {
            spacing_m: 5.0,
            patch_radius_m: 2.0,
            min_points: 12,
            planarity_m: 0.06,
            max_ties: 100,
            seed: 5,
            vtpm: VtpmOptions::default(),
        }
    }
}

/// Largest departure of a tie patch from a plane at its radius (quadratic fit), m: well above
/// the sag that range noise of a few mm fakes on ~50 points, well below what a kerb or a road's
/// blend into the terrain bends.
const MAX_SAG_M: f64 = 0.03;

/// Fewest bright points of a marking in every strip for its centroid to locate it horizontally.
const MIN_BRIGHT_POINTS: usize = 12;

/// Fewest pooled standard deviations between a marking's bright and dark intensities (module
/// docs, step 3): noise split at its midpoint gives ~2.7.
const MIN_SEPARATION: f64 = 4.0;

struct Candidate {
    tie: Tie,
    score: f64,
    bin: (u8, usize, usize, usize),
}

/// Finds ties automatically in the strips' overlaps (module docs), with the points georeferenced
/// with `prior`: [`auto_tie_candidates`] over the whole [`AutoTieGrid`], then
/// [`select_auto_ties`].
///
/// # Errors
/// Invalid strips or options; [`Error::NothingUsable`] when no candidate qualifies.
pub fn auto_ties(strips: &[Strip], prior: &Mounting, opts: &AutoTieOptions) -> Result<Vec<Tie>> {
    check_strips(strips)?;
    opts.check()?;
    let extents: Vec<[f64; 4]> = strips.iter().filter_map(Strip::extent_m).collect();
    let grid = AutoTieGrid::new(&extents, opts.spacing_m);
    let cands = auto_tie_candidates(strips, prior, opts, &grid, 0..grid.nx, 0..grid.ny)?;
    select_auto_ties(cands, opts)
}

impl AutoTieOptions {
    fn check(&self) -> Result<()> {
        self.vtpm.check()?;
        if !(self.spacing_m > 0.0 && self.patch_radius_m > 0.0 && self.planarity_m > 0.0) {
            return Err(Error::InvalidOption {
                name: "spacing_m / patch_radius_m / planarity_m",
                expected: "finite numbers > 0",
                value: self
                    .spacing_m
                    .min(self.patch_radius_m)
                    .min(self.planarity_m),
            });
        }
        Ok(())
    }

    /// How far from a grid node the search at that node reads points, m: the patch may move
    /// half a cell onto a marking (step 3) and its picks' virtual ties read
    /// [`crate::tie_reach_m`] around them. Strips cut to the nodes' surroundings by this much
    /// (plus their extreme points) give the same candidates.
    pub fn node_reach_m(&self) -> f64 {
        let recentred = 0.5 * self.spacing_m * std::f64::consts::SQRT_2;
        (recentred + self.patch_radius_m)
            .max(recentred + 0.5 * self.patch_radius_m + crate::tie_reach_m(&self.vtpm, None))
    }
}

/// The candidate grid of the automatic tie search: node `(i, j)` is at `origin_m + (i, j) ×
/// spacing_m` and is the `i·ny + j + 1`-th candidate (its id and RANSAC seed).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AutoTieGrid {
    /// North and east of node (0, 0): the strips' smallest north and east, m.
    pub origin_m: [f64; 2],
    /// Nodes along north.
    pub nx: usize,
    /// Nodes along east.
    pub ny: usize,
    /// Node spacing, m.
    pub spacing_m: f64,
}

impl AutoTieGrid {
    /// The grid over strips of horizontal extents `extents` ([`Strip::extent_m`]).
    pub fn new(extents: &[[f64; 4]], spacing_m: f64) -> AutoTieGrid {
        let mut ext = [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ];
        for e in extents {
            ext = [
                ext[0].min(e[0]),
                ext[1].min(e[1]),
                ext[2].max(e[2]),
                ext[3].max(e[3]),
            ];
        }
        AutoTieGrid {
            origin_m: [ext[0], ext[1]],
            nx: ((ext[2] - ext[0]) / spacing_m) as usize + 1,
            ny: ((ext[3] - ext[1]) / spacing_m) as usize + 1,
            spacing_m,
        }
    }

    /// North and east of node `(i, j)`, m.
    pub fn node_m(&self, i: usize, j: usize) -> [f64; 2] {
        [
            self.origin_m[0] + i as f64 * self.spacing_m,
            self.origin_m[1] + j as f64 * self.spacing_m,
        ]
    }
}

/// A tie found at one grid node, before the selection spreads them ([`select_auto_ties`]).
pub struct AutoTieCandidate {
    /// The node's place in the grid's order.
    k: usize,
    x: f64,
    y: f64,
    candidate: Candidate,
}

impl AutoTieCandidate {
    /// The candidate tie.
    pub fn tie(&self) -> &Tie {
        &self.candidate.tie
    }
}

/// The candidates at the nodes `(i, j)` of `grid` with `i` in `rows` and `j` in `columns`
/// (module docs, steps 1–4). `strips` are all the strips in the same order as for the whole
/// search, each holding at least its points within [`AutoTieOptions::node_reach_m`] of these
/// nodes and its extreme points (so its extent is the whole strip's).
///
/// # Errors
/// Invalid strips or options.
pub fn auto_tie_candidates(
    strips: &[Strip],
    prior: &Mounting,
    opts: &AutoTieOptions,
    grid: &AutoTieGrid,
    rows: std::ops::Range<usize>,
    columns: std::ops::Range<usize>,
) -> Result<Vec<AutoTieCandidate>> {
    check_strips(strips)?;
    opts.check()?;
    let idx = Indexed::new(strips, opts.patch_radius_m);
    let g = Georeferencing::new(prior);
    // Every node on its own (its RANSAC seed is its number), so in parallel, in grid order.
    let nodes: Vec<(usize, usize)> = rows
        .flat_map(|i| columns.clone().map(move |j| (i, j)))
        .collect();
    Ok(nodes
        .par_iter()
        .filter_map(|&(i, j)| {
            let k = i * grid.ny + j + 1;
            let [x, y] = grid.node_m(i, j);
            candidate(&idx, &g, x, y, k, opts, None)
                .filter(|c| usable(&idx, &g, &c.tie, opts))
                .map(|c| AutoTieCandidate {
                    k,
                    x,
                    y,
                    candidate: c,
                })
        })
        .collect())
}

/// Spreads the candidates over kinds, places, scan angles and roof aspects (module docs,
/// step 5), at most [`AutoTieOptions::max_ties`]; the result does not depend on the order of
/// `cands`.
///
/// # Errors
/// [`Error::NothingUsable`] when there is no candidate.
pub fn select_auto_ties(
    mut cands: Vec<AutoTieCandidate>,
    opts: &AutoTieOptions,
) -> Result<Vec<Tie>> {
    if cands.is_empty() {
        return Err(Error::NothingUsable {
            what: "automatic tie",
            reason: "no planar patch in two strips with intensity contrast or a roof slope".into(),
        });
    }
    // The grid's order: equal scores keep it through the stable sorts below.
    cands.sort_by_key(|c| c.k);
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for c in &cands {
        lo = [lo[0].min(c.x), lo[1].min(c.y)];
        hi = [hi[0].max(c.x), hi[1].max(c.y)];
    }
    let mut bins: BTreeMap<(u8, usize, usize, usize), Vec<Candidate>> = BTreeMap::new();
    for AutoTieCandidate {
        x,
        y,
        candidate: mut c,
        ..
    } in cands
    {
        let cell =
            |v: f64, a: usize| (((v - lo[a]) / (hi[a] - lo[a]).max(1e-9) * 3.0) as usize).min(2);
        c.bin.1 = cell(x, 0) * 3 + cell(y, 1);
        bins.entry(c.bin).or_default().push(c);
    }
    for v in bins.values_mut() {
        v.sort_by(|a, b| a.score.total_cmp(&b.score));
    }
    let mut out = Vec::new();
    while out.len() < opts.max_ties && bins.values().any(|v| !v.is_empty()) {
        for v in bins.values_mut() {
            if let Some(c) = v.pop() {
                if out.len() < opts.max_ties {
                    out.push(c.tie);
                }
            }
        }
    }
    Ok(out)
}

/// Every pick of the tie yields a virtual tie (step 2 of Zhang & Jiang (2011) would succeed).
fn usable(idx: &Indexed<'_>, g: &Georeferencing, tie: &Tie, opts: &AutoTieOptions) -> bool {
    tie.picks.iter().enumerate().all(|(pi, p)| {
        idx.strip_index(&p.strip).is_some_and(|s| {
            build_virtual_tie(&PickInStrip {
                idx,
                strip: s,
                tie_id: &tie.id,
                x: p.north_m,
                y: p.east_m,
                g,
                opts: &opts.vtpm,
                seed: mix_seed(opts.seed, 7, pi),
            })
            .is_ok()
        })
    })
}

fn candidate(
    idx: &Indexed<'_>,
    g: &Georeferencing,
    x: f64,
    y: f64,
    k: usize,
    opts: &AutoTieOptions,
    cell_centre: Option<(f64, f64)>,
) -> Option<Candidate> {
    let mut patches = Vec::new();
    for (s, strip) in idx.strips.iter().enumerate() {
        let near = within(&idx.grids[s], &strip.points, x, y, opts.patch_radius_m);
        if near.len() < opts.min_points {
            continue;
        }
        let pos: Vec<Vector3<f64>> = near
            .iter()
            .map(|&i| g.apply_vector(&strip.points[i]))
            .collect();
        let (plane, inl) = ransac_plane(&pos, opts.planarity_m, 100, mix_seed(opts.seed, k, s))?;
        if (inl.len() as f64) < 0.9 * pos.len() as f64 {
            return None;
        }
        // A bent patch (a kerb, the blend from a road to the terrain) is no tie: its plane's
        // height at the pick depends on where each strip's points fell.
        let inliers: Vec<Vector3<f64>> = inl.iter().map(|&i| pos[i]).collect();
        if quadratic_sag_m(&inliers, x, y, opts.patch_radius_m).is_some_and(|s| s > MAX_SAG_M) {
            return None;
        }
        patches.push((s, near, pos, plane));
    }
    if patches.len() < 2 {
        return None;
    }
    let n = patches[0].3.normal;
    let slope = n.z.clamp(-1.0, 1.0).acos().to_degrees();
    let theta = {
        let (s, near, _, _) = &patches[0];
        let th: Vec<f64> = near
            .iter()
            .map(|&i| idx.strips[*s].points[i].observation.scan_angle_rad.abs())
            .collect();
        th.iter().sum::<f64>() / th.len() as f64
    };
    let theta_bin = ((theta.to_degrees() / 10.0) as usize).min(2);
    let id = format!("a{k}");
    if slope < 5.0 {
        let mut picks = Vec::new();
        let mut shape: Option<TieKind> = None;
        let mut score = f64::INFINITY;
        let mut fewest_bright = usize::MAX;
        for (s, near, pos, _) in &patches {
            let mut inten: Vec<u16> = near
                .iter()
                .map(|&i| idx.strips[*s].points[i].intensity)
                .collect();
            inten.sort_unstable();
            let p5 = f64::from(inten[inten.len() / 20]);
            let p95 = f64::from(inten[inten.len() * 19 / 20]);
            if p95 < 2.0 * p5.max(1.0) {
                return None;
            }
            let mid = 0.5 * (p5 + p95);
            // Paint is a second population, not the bright tail of one: with realistic
            // intensity noise any patch's 95th percentile is twice its 5th, and a split of
            // noise at its midpoint leaves the two halves ~2.7 of their spread apart.
            if intensity_separation(&inten, mid) < MIN_SEPARATION {
                return None;
            }
            let bright = |cx: f64, cy: f64| -> (usize, f64, f64) {
                let (mut c, mut sx, mut sy) = (0, 0.0, 0.0);
                for (j, &i) in near.iter().enumerate() {
                    let p = &pos[j];
                    if f64::from(idx.strips[*s].points[i].intensity) > mid
                        && (p.x - cx).powi(2) + (p.y - cy).powi(2) <= opts.patch_radius_m.powi(2)
                    {
                        c += 1;
                        sx += p.x;
                        sy += p.y;
                    }
                }
                (c, sx / c.max(1) as f64, sy / c.max(1) as f64)
            };
            let (c0, x0, y0) = bright(x, y);
            if shape.is_none() {
                // Several separate bright blobs in the window (zebra stripes, dashes) make the
                // centroid jump between them from strip to strip: such a patch is no tie.
                let blobs: Vec<[f64; 2]> = near
                    .iter()
                    .enumerate()
                    .filter(|(_, i)| f64::from(idx.strips[*s].points[**i].intensity) > mid)
                    .map(|(j, _)| [pos[j].x, pos[j].y])
                    .collect();
                if bright_components(&blobs, 0.6) > 1 {
                    return None;
                }
                // Elongated bright points (a centre line, a stripe) fix the tie only across the
                // marking: the along-line centroid just follows the window.
                let (mut sxx, mut syy, mut sxy, mut c) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
                for (j, &i) in near.iter().enumerate() {
                    let p = &pos[j];
                    if f64::from(idx.strips[*s].points[i].intensity) > mid {
                        let (dx, dy) = (p.x - x0, p.y - y0);
                        sxx += dx * dx;
                        syy += dy * dy;
                        sxy += dx * dy;
                        c += 1.0;
                    }
                }
                let (sxx, syy, sxy) = (sxx / c.max(1.0), syy / c.max(1.0), sxy / c.max(1.0));
                let tr = sxx + syy;
                let det = sxx * syy - sxy * sxy;
                let disc = (0.25 * tr * tr - det).max(0.0).sqrt();
                let (l_max, l_min) = (0.5 * tr + disc, 0.5 * tr - disc);
                shape = Some(if l_max > 4.0 * l_min.max(1e-12) {
                    // A line marking is narrow: a bright half-plane (the edge of a road) is not
                    // one, its centroid follows the window.
                    if l_min.max(0.0).sqrt() > 0.2 {
                        return None;
                    }
                    // Unit vector of the small eigenvalue: across the line.
                    let (vx, vy) = if sxy.abs() > 1e-15 {
                        (l_min - syy, sxy)
                    } else if sxx < syy {
                        (1.0, 0.0)
                    } else {
                        (0.0, 1.0)
                    };
                    let norm = vx.hypot(vy);
                    let (ux, uy) = (vx / norm, vy / norm);
                    // A painted line is brighter than the ground on both sides; the edge of a
                    // bright surface (grass beside asphalt in the infrared) is not.
                    let side = |sign: f64| {
                        let (mut sum, mut n) = (0.0, 0usize);
                        for (j, &i) in near.iter().enumerate() {
                            let d = (pos[j].x - x0) * ux + (pos[j].y - y0) * uy;
                            if (0.4..=1.2).contains(&(sign * d)) {
                                sum += f64::from(idx.strips[*s].points[i].intensity);
                                n += 1;
                            }
                        }
                        (n > 0).then(|| sum / n as f64)
                    };
                    match (side(1.0), side(-1.0)) {
                        (Some(a), Some(b)) if a < mid && b < mid => {}
                        _ => return None,
                    }
                    TieKind::Line([ux, uy])
                } else {
                    TieKind::Feature
                });
            }
            if cell_centre.is_none() {
                // Move the patch onto the marking as the first strip sees it, once; only a
                // marking inside this grid cell counts, so each marking is found once.
                let half = 0.5 * opts.spacing_m;
                if c0 < 3 || (x0 - x).abs() > half || (y0 - y).abs() > half {
                    return None;
                }
                return candidate(idx, g, x0, y0, k, opts, Some((x, y)));
            }
            let frac = c0 as f64 / near.len() as f64;
            if !(0.05..=0.6).contains(&frac) {
                return None;
            }
            // Recentre once on the marking; it must stay well inside the patch.
            let (c1, x1, y1) = bright(x0, y0);
            if c1 < 3 || (x1 - x).hypot(y1 - y) > 0.5 * opts.patch_radius_m {
                return None;
            }
            score = score.min((p95 - p5) / p95 - (x1 - x).hypot(y1 - y));
            fewest_bright = fewest_bright.min(c1);
            picks.push(TiePick {
                strip: idx.strips[*s].id.clone(),
                north_m: x1,
                east_m: y1,
            });
        }
        // Too few bright points in a strip: their centroid is where the scan lines happened to
        // cross the marking, not the marking (module docs, step 3): the patch ties heights only,
        // at one place.
        let kind = if fewest_bright < MIN_BRIGHT_POINTS {
            let (n0, e0) = (picks[0].north_m, picks[0].east_m);
            for p in &mut picks {
                (p.north_m, p.east_m) = (n0, e0);
            }
            TieKind::Surface
        } else {
            shape.unwrap_or(TieKind::Feature)
        };
        Some(Candidate {
            tie: Tie { id, picks, kind },
            score,
            bin: (0, 0, theta_bin, 0),
        })
    } else if (10.0..=60.0).contains(&slope)
        && cell_centre.is_none()
        // The same face in every strip (not the other side of a ridge): normals within 3°.
        && patches
            .iter()
            .all(|p| p.3.normal.dot(&n).abs() > 3f64.to_radians().cos())
    {
        // Aspect of the up-pointing normal (−n in NED, model's normals have n_z ≥ 0).
        let aspect = (-n.y).atan2(-n.x).to_degrees().rem_euclid(360.0);
        let sector = (aspect / 45.0) as usize % 8 + 8 * usize::from(slope > 30.0);
        let picks = patches
            .iter()
            .map(|(s, _, _, _)| TiePick {
                strip: idx.strips[*s].id.clone(),
                north_m: x,
                east_m: y,
            })
            .collect();
        Some(Candidate {
            tie: Tie {
                id,
                picks,
                kind: TieKind::Surface,
            },
            score: 1.0,
            bin: (1, 0, theta_bin, sector),
        })
    } else {
        None
    }
}

/// How far apart the intensities above and below `mid` are: the difference of their means over
/// their pooled standard deviation (Fisher's ratio); 0 when one side is empty.
fn intensity_separation(intensities: &[u16], mid: f64) -> f64 {
    let (mut n, mut sum, mut sq) = ([0.0f64; 2], [0.0f64; 2], [0.0f64; 2]);
    for &i in intensities {
        let v = f64::from(i);
        let k = usize::from(v > mid);
        n[k] += 1.0;
        sum[k] += v;
        sq[k] += v * v;
    }
    if n[0] < 1.0 || n[1] < 1.0 {
        return 0.0;
    }
    let mean = [sum[0] / n[0], sum[1] / n[1]];
    let var = [
        (sq[0] / n[0] - mean[0] * mean[0]).max(0.0),
        (sq[1] / n[1] - mean[1] * mean[1]).max(0.0),
    ];
    (mean[1] - mean[0]) / (0.5 * (var[0] + var[1])).sqrt().max(1e-9)
}

/// Number of groups of at least 3 points linked by steps ≤ `link_m` (union–find; the patches are
/// small, so O(n²) is fine).
fn bright_components(points: &[[f64; 2]], link_m: f64) -> usize {
    let n = points.len();
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    for a in 0..n {
        for b in a + 1..n {
            let d = (points[a][0] - points[b][0]).hypot(points[a][1] - points[b][1]);
            if d <= link_m {
                let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
                parent[ra] = rb;
            }
        }
    }
    let mut sizes = std::collections::HashMap::new();
    for i in 0..n {
        *sizes.entry(root(&mut parent, i)).or_insert(0usize) += 1;
    }
    sizes.values().filter(|&&c| c >= 3).count()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::strip::RawPoint;
    use lidarqa_model::Ned;

    /// Flat ground, every point its own origin, with a 0.4 m painted stripe along east at north 0;
    /// points `north_m` apart across the stripe and `east_m` along it, starting at `phase_m`.
    fn striped(id: &str, north_m: f64, east_m: f64, phase_m: f64) -> Strip {
        let mut points = Vec::new();
        let (ni, ej) = ((6.0 / north_m) as i64, (6.0 / east_m) as i64);
        for i in -ni..=ni {
            for j in -ej..=ej {
                let (x, y) = (phase_m + i as f64 * north_m, j as f64 * east_m);
                let intensity = if x.abs() <= 0.2 { 4000 } else { 500 };
                points.push(RawPoint::own_origin(Ned::new(x, y, 0.0), intensity));
            }
        }
        Strip {
            id: id.into(),
            points,
        }
    }

    fn kinds(strips: &[Strip]) -> Vec<TieKind> {
        auto_ties(strips, &Mounting::default(), &AutoTieOptions::default())
            .unwrap()
            .into_iter()
            .map(|t| t.kind)
            .collect()
    }

    #[test]
    fn noise_is_not_a_second_population() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        // Box–Muller normal draws around `mean`.
        let mut normal = |mean: f64, sigma: f64| -> u16 {
            let (u1, u2): (f64, f64) = (rng.random::<f64>().max(1e-12), rng.random());
            let z = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
            (mean + sigma * z).round() as u16
        };
        let median_split = |v: &mut Vec<u16>| {
            v.sort_unstable();
            let (p5, p95) = (v[v.len() / 20], v[v.len() * 19 / 20]);
            intensity_separation(v, 0.5 * (f64::from(p5) + f64::from(p95)))
        };
        // One Gaussian split at its middle: the halves' means ±0.8σ, their spread 0.6σ.
        let mut noise: Vec<u16> = (0..4000).map(|_| normal(3000.0, 600.0)).collect();
        let s = median_split(&mut noise);
        assert!((2.4..3.0).contains(&s), "{s}");
        // Paint on asphalt: two populations 6σ apart.
        let mut paint: Vec<u16> = (0..4000)
            .map(|i| normal(if i % 5 == 0 { 6600.0 } else { 3000.0 }, 600.0))
            .collect();
        let s = median_split(&mut paint);
        assert!(s > MIN_SEPARATION, "{s}");
    }

    #[test]
    fn a_marking_crossed_by_few_points_ties_heights_only() {
        // Both strips sample the stripe densely: located across it.
        let fine = [striped("1", 0.1, 0.1, 0.0), striped("2", 0.1, 0.12, 0.03)];
        let k = kinds(&fine);
        assert!(
            !k.is_empty() && k.iter().all(|k| matches!(k, TieKind::Line(_))),
            "{k:?}"
        );
        // The second strip's points are 0.5 m apart across the 0.4 m stripe: one point per scan
        // line falls on it, where the phase puts it, and the tie observes heights only.
        let sparse = [striped("1", 0.1, 0.1, 0.0), striped("2", 0.5, 0.55, 0.13)];
        let k = kinds(&sparse);
        assert!(
            !k.is_empty() && k.iter().all(|k| *k == TieKind::Surface),
            "{k:?}"
        );
    }
}
