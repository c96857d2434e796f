//! Swath-to-swath overlap QC: height differences between overlapping strips on smooth surfaces,
//! as the USGS Lidar Base Specification's interswath (relative) accuracy — RMSDz and the largest
//! |dz| per strip pair — plus a dz grid and a height profile across the strips.
//!
//! Each strip's points are binned into square cells of [`OverlapOptions::cell_m`]. In a cell with
//! at least [`OverlapOptions::min_points`] points a least-squares plane `z = a + b·dx + c·dy` is
//! fitted (the smooth cells' plane, [`crate::fit_plane`]); the strip's height there is `a` (the
//! plane at the cell centre), its roughness the RMS of the plane residuals and its slope
//! `atan √(b² + c²)`. A cell is *smooth* in a strip when the
//! roughness is at most [`OverlapOptions::max_roughness_m`] and the slope at most
//! [`OverlapOptions::max_slope_deg`]; `dz = z_a − z_b` is taken only where both strips are smooth
//! (USGS: "smooth, open, non-vegetated terrain"), so vegetation, walls and roof edges do not count.
//! Coordinates are any right-handed Cartesian frame with z up (projected easting, northing,
//! height, or the local frame's east, north, up).

use crate::error::{Error, Result};
use crate::smooth::fit_plane;
use lidarqa_products::{OverlapDocument, OverlapProfileStrip, StripId};
use std::collections::BTreeMap;

/// A strip for overlap QC: points as `[x, y, z]`, metres, z up.
#[derive(Debug, Clone, PartialEq)]
pub struct OverlapStrip {
    /// The strip's id.
    pub id: String,
    /// Points `[x, y, z]`, m.
    pub points: Vec<[f64; 3]>,
}

/// Options of the overlap QC.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OverlapOptions {
    /// Cell size, m.
    pub cell_m: f64,
    /// Minimum points of one strip in a cell.
    pub min_points: usize,
    /// Largest RMS of plane residuals for a smooth cell, m.
    pub max_roughness_m: f64,
    /// Largest slope for a smooth cell, degrees.
    pub max_slope_deg: f64,
    /// Profile line `[[x0, y0], [x1, y1]]`, m; `None`: along x through the middle of the overlap.
    pub profile: Option<[[f64; 2]; 2]>,
    /// Fewest smooth cells for a pair to mean something: pairs with fewer are listed with
    /// `meaningful: false` and left out of the grid, the profile's extent and the overall RMSDz.
    pub min_cells: usize,
}

impl Default for OverlapOptions {
    fn default() -> Self {
        OverlapOptions {
            cell_m: 1.0,
            min_points: 4,
            max_roughness_m: 0.05,
            max_slope_deg: 10.0,
            profile: None,
            min_cells: 10,
        }
    }
}

/// RMSDz and max |dz| of one strip pair.
#[derive(Debug, Clone, PartialEq)]
pub struct OverlapPair {
    /// The two strips' ids, `dz = z(first) − z(second)`.
    pub strips: [String; 2],
    /// √(mean dz²) over smooth cells, m.
    pub rmsdz_m: f64,
    /// Largest |dz|, m.
    pub max_abs_dz_m: f64,
    /// Mean dz, m (a vertical offset between the strips).
    pub mean_dz_m: f64,
    /// Number of smooth cells compared.
    pub n: usize,
    /// Whether `n` reaches [`OverlapOptions::min_cells`].
    pub meaningful: bool,
}

/// The dz grid: cell `(ix, iy)` covers `[origin_x + ix·cell, origin_x + (ix+1)·cell)` ×
/// `[origin_y + iy·cell, …)`; `dz_m[iy·nx + ix]` is the dz of the pair with the largest |dz| in
/// that cell (`None` where no pair is smooth). The product's own type: the grid is written as
/// computed.
pub use lidarqa_products::OverlapGrid;

/// One strip's heights along the profile.
#[derive(Debug, Clone, PartialEq)]
pub struct ProfileStrip {
    /// The strip's id.
    pub id: String,
    /// Height at each profile sample (cell plane at the sample's cell where it is smooth), m.
    pub z_m: Vec<Option<f64>>,
}

/// A height profile across the strips.
#[derive(Debug, Clone, PartialEq)]
pub struct OverlapProfile {
    /// Start and end of the line, m.
    pub line: [[f64; 2]; 2],
    /// Distance of each sample from the start, m.
    pub distance_m: Vec<f64>,
    /// Heights per strip.
    pub strips: Vec<ProfileStrip>,
}

/// The overlap QC result; [`OverlapReport::to_document`] gives the product the report reads.
#[derive(Debug, Clone, PartialEq)]
pub struct OverlapReport {
    /// Pairs with at least one smooth cell in common (those under `min_cells` marked).
    pub pairs: Vec<OverlapPair>,
    /// The dz grid.
    pub grid: OverlapGrid,
    /// The profile.
    pub profile: OverlapProfile,
}

impl OverlapReport {
    /// The product `lidarqa overlap -o` writes (lidarqa-products' [`OverlapDocument`]): strip
    /// ids that are numbers (point source ids) are written as numbers.
    pub fn to_document(&self) -> OverlapDocument {
        let id = |s: &str| StripId(s.to_string());
        OverlapDocument {
            pairs: self
                .pairs
                .iter()
                .map(|p| lidarqa_products::OverlapPair {
                    strips: [id(&p.strips[0]), id(&p.strips[1])],
                    rmsdz_m: p.rmsdz_m,
                    max_abs_dz_m: p.max_abs_dz_m,
                    mean_dz_m: p.mean_dz_m,
                    n: p.n,
                    meaningful: p.meaningful,
                })
                .collect(),
            grid: self.grid.clone(),
            profile: lidarqa_products::OverlapProfile {
                line: self.profile.line,
                distance_m: self.profile.distance_m.clone(),
                strips: self
                    .profile
                    .strips
                    .iter()
                    .map(|s| OverlapProfileStrip {
                        id: id(&s.id),
                        z_m: s.z_m.clone(),
                    })
                    .collect(),
            },
        }
    }

    /// RMS over the meaningful pairs' smooth cells of dz (each cell of each pair counts once), m.
    pub fn overall_rmsdz_m(&self) -> f64 {
        let pairs = || self.pairs.iter().filter(|p| p.meaningful);
        let n: usize = pairs().map(|p| p.n).sum();
        let s: f64 = pairs().map(|p| p.rmsdz_m * p.rmsdz_m * p.n as f64).sum();
        (s / n.max(1) as f64).sqrt()
    }
}

#[derive(Clone, Copy)]
struct CellFit {
    z: f64,
    smooth: bool,
}

/// Most cells of the dz grid (8 bytes each plus the fits): 50 million, 400 MB.
const MAX_GRID_CELLS: usize = 50_000_000;

/// The horizontal extent the point `sets` fill: the full `min`–`max` when the points fill it,
/// else their 1–99 % quantiles widened by a quarter of their span and `pad_m` each side (a
/// strip's corrupted records, kilometres off, then size neither a grid nor a region, and exhaust
/// no memory). A point is `[x, y, …]`; at most about 200 000 of them are sorted.
///
/// # Panics
/// When the sets hold no point.
pub fn robust_extent<const D: usize>(
    sets: &[&[[f64; D]]],
    min: [f64; 2],
    max: [f64; 2],
    pad_m: f64,
) -> ([f64; 2], [f64; 2]) {
    let n: usize = sets.iter().map(|s| s.len()).sum();
    let step = (n / 200_000).max(1);
    let mut out = (min, max);
    for k in 0..2 {
        let mut v: Vec<f64> = sets
            .iter()
            .flat_map(|s| s.iter().step_by(step).map(move |p| p[k]))
            .collect();
        v.sort_by(f64::total_cmp);
        let q = |f: f64| v[((v.len() - 1) as f64 * f).round() as usize];
        let (lo, hi) = (q(0.01), q(0.99));
        let pad = 0.25 * (hi - lo) + pad_m;
        out.0[k] = min[k].max(lo - pad);
        out.1[k] = max[k].min(hi + pad);
    }
    out
}

fn fit_cells(
    points: &[[f64; 3]],
    origin: [f64; 2],
    nx: usize,
    ny: usize,
    opts: &OverlapOptions,
) -> BTreeMap<usize, CellFit> {
    let c = opts.cell_m;
    let mut bins: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for (k, p) in points.iter().enumerate() {
        let (fx, fy) = (
            ((p[0] - origin[0]) / c).floor(),
            ((p[1] - origin[1]) / c).floor(),
        );
        // Outside the robust extent (corrupted records): not compared.
        if fx < 0.0 || fy < 0.0 || fx >= nx as f64 || fy >= ny as f64 {
            continue;
        }
        bins.entry(fy as usize * nx + fx as usize)
            .or_default()
            .push(k);
    }
    let max_slope = opts.max_slope_deg.to_radians().tan();
    bins.into_iter()
        .filter(|(_, v)| v.len() >= opts.min_points.max(3))
        .filter_map(|(cell, v)| {
            let (ix, iy) = (cell % nx, cell / nx);
            let centre = [
                origin[0] + (ix as f64 + 0.5) * c,
                origin[1] + (iy as f64 + 0.5) * c,
            ];
            let f = fit_plane(v.iter().map(|&k| &points[k]), centre)?;
            Some((
                cell,
                CellFit {
                    z: f.z,
                    smooth: f.smooth(max_slope, opts.max_roughness_m, None),
                },
            ))
        })
        .collect()
}

/// Swath-to-swath QC of overlapping strips (module docs).
///
/// # Errors
/// Fewer than two strips, an invalid option, a non-finite coordinate, or strips sharing no smooth
/// cell ([`Error::NoOverlap`] naming the first strip).
pub fn overlap_qc(strips: &[OverlapStrip], opts: &OverlapOptions) -> Result<OverlapReport> {
    if strips.len() < 2 {
        return Err(Error::TooFewStrips {
            what: "overlap qc",
            needed: 2,
            got: strips.len(),
        });
    }
    let bad = |name, expected, value| {
        Err(Error::InvalidOption {
            name,
            expected,
            value,
        })
    };
    if !(opts.cell_m.is_finite() && opts.cell_m > 0.0) {
        return bad("cell_m", "a finite number > 0", opts.cell_m);
    }
    if opts.max_roughness_m.is_nan() || opts.max_roughness_m < 0.0 {
        return bad("max_roughness_m", "a number >= 0", opts.max_roughness_m);
    }
    if !(opts.max_slope_deg >= 0.0 && opts.max_slope_deg < 90.0) {
        return bad("max_slope_deg", "in [0, 90)", opts.max_slope_deg);
    }
    let mut min = [f64::INFINITY; 2];
    let mut max = [f64::NEG_INFINITY; 2];
    for s in strips {
        if s.points.is_empty() {
            return Err(Error::EmptyStrip {
                strip: s.id.clone(),
            });
        }
        for (k, p) in s.points.iter().enumerate() {
            if !p.iter().all(|v| v.is_finite()) {
                return Err(Error::NonFinitePoint {
                    strip: s.id.clone(),
                    index: k,
                });
            }
            for a in 0..2 {
                min[a] = min[a].min(p[a]);
                max[a] = max[a].max(p[a]);
            }
        }
    }
    let c = opts.cell_m;
    // The grid covers the points' robust extent: a few corrupted records kilometres away do
    // not size it (they fall outside and are not compared).
    let sets: Vec<&[[f64; 3]]> = strips.iter().map(|s| s.points.as_slice()).collect();
    let (min, max) = robust_extent(&sets, min, max, 10.0 * c);
    let origin = [(min[0] / c).floor() * c, (min[1] / c).floor() * c];
    let cells = |k: usize| ((max[k] - origin[k]) / c).floor() + 1.0;
    if cells(0) * cells(1) > MAX_GRID_CELLS as f64 {
        return Err(Error::InvalidOption {
            name: "cell_m",
            expected: "a cell large enough for at most 50 million cells over the strips' extent",
            value: c,
        });
    }
    let nx = cells(0) as usize;
    let ny = cells(1) as usize;
    let fits: Vec<BTreeMap<usize, CellFit>> = strips
        .iter()
        .map(|s| fit_cells(&s.points, origin, nx, ny, opts))
        .collect();
    let mut pairs = Vec::new();
    let mut grid: BTreeMap<usize, f64> = BTreeMap::new();
    for a in 0..strips.len() {
        for b in a + 1..strips.len() {
            let (mut n, mut s2, mut s1, mut mx) = (0usize, 0.0, 0.0, 0.0f64);
            let mut cells = Vec::new();
            for (cell, fa) in &fits[a] {
                let Some(fb) = fits[b].get(cell) else {
                    continue;
                };
                if !(fa.smooth && fb.smooth) {
                    continue;
                }
                let dz = fa.z - fb.z;
                n += 1;
                s2 += dz * dz;
                s1 += dz;
                mx = mx.max(dz.abs());
                cells.push((*cell, dz));
            }
            let meaningful = n >= opts.min_cells.max(1);
            if meaningful {
                for (cell, dz) in cells {
                    let g = grid.entry(cell).or_insert(dz);
                    if dz.abs() > g.abs() {
                        *g = dz;
                    }
                }
            }
            if n > 0 {
                pairs.push(OverlapPair {
                    strips: [strips[a].id.clone(), strips[b].id.clone()],
                    rmsdz_m: (s2 / n as f64).sqrt(),
                    max_abs_dz_m: mx,
                    mean_dz_m: s1 / n as f64,
                    n,
                    meaningful,
                });
            }
        }
    }
    if pairs.is_empty() {
        return Err(Error::NoOverlap {
            strip: strips[0].id.clone(),
        });
    }
    let mut dz_m = vec![None; nx * ny];
    for (cell, dz) in &grid {
        dz_m[*cell] = Some(*dz);
    }
    // Default profile: along x through the middle row of the compared cells.
    let line = opts.profile.unwrap_or_else(|| {
        let rows: Vec<usize> = grid.keys().map(|k| k / nx).collect();
        let cols: Vec<usize> = grid.keys().map(|k| k % nx).collect();
        let mid_row = (rows.iter().min().unwrap_or(&0) + rows.iter().max().unwrap_or(&0)) / 2;
        let y = origin[1] + (mid_row as f64 + 0.5) * c;
        let x0 = origin[0] + *cols.iter().min().unwrap_or(&0) as f64 * c;
        let x1 = origin[0] + (*cols.iter().max().unwrap_or(&0) + 1) as f64 * c;
        [[x0, y], [x1, y]]
    });
    let len = ((line[1][0] - line[0][0]).powi(2) + (line[1][1] - line[0][1]).powi(2)).sqrt();
    let samples = ((len / c).floor() as usize + 1).min(1_000_000);
    let distance_m: Vec<f64> = (0..samples).map(|k| k as f64 * c).collect();
    let profile_strips = strips
        .iter()
        .zip(&fits)
        .map(|(s, f)| ProfileStrip {
            id: s.id.clone(),
            z_m: distance_m
                .iter()
                .map(|d| {
                    let w = if len > 0.0 { d / len } else { 0.0 };
                    let x = line[0][0] + w * (line[1][0] - line[0][0]);
                    let y = line[0][1] + w * (line[1][1] - line[0][1]);
                    if x < origin[0] || y < origin[1] {
                        return None;
                    }
                    let ix = ((x - origin[0]) / c).floor() as usize;
                    let iy = ((y - origin[1]) / c).floor() as usize;
                    if ix >= nx || iy >= ny {
                        return None;
                    }
                    // Smooth cells only: a roof edge or a tree is no height of the terrain.
                    f.get(&(iy * nx + ix)).filter(|cf| cf.smooth).map(|cf| cf.z)
                })
                .collect(),
        })
        .collect();
    Ok(OverlapReport {
        pairs,
        grid: OverlapGrid {
            cell_m: c,
            origin_x: origin[0],
            origin_y: origin[1],
            nx,
            ny,
            dz_m,
        },
        profile: OverlapProfile {
            line,
            distance_m,
            strips: profile_strips,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plane_strip(id: &str, dz: f64, x0: f64) -> OverlapStrip {
        let mut points = Vec::new();
        for i in 0..40 {
            for j in 0..20 {
                let (x, y) = (x0 + i as f64 * 0.25 + 0.01, j as f64 * 0.25 + 0.01);
                points.push([x, y, 100.0 + 0.02 * x + dz]);
            }
        }
        OverlapStrip {
            id: id.into(),
            points,
        }
    }

    #[test]
    fn constant_offset_gives_its_rmsdz() {
        let r = overlap_qc(
            &[plane_strip("1", 0.0, 0.0), plane_strip("2", 0.07, 5.0)],
            &OverlapOptions::default(),
        )
        .unwrap();
        assert_eq!(r.pairs.len(), 1);
        let p = &r.pairs[0];
        assert!((p.rmsdz_m - 0.07).abs() < 1e-9, "{}", p.rmsdz_m);
        assert!((p.mean_dz_m + 0.07).abs() < 1e-9);
        // Overlap x in [5, 10): 5 columns × 5 rows of 1 m cells.
        assert_eq!(p.n, 25);
        let j = serde_json::to_value(r.to_document()).unwrap();
        assert_eq!(j["pairs"][0]["strips"][1], 2);
        assert_eq!(
            j["grid"]["dz_m"].as_array().unwrap().len(),
            r.grid.nx * r.grid.ny
        );
    }

    /// The sums run over the cells in one order (a hash map's order changes from map to map,
    /// and with it the last bits of RMSDz: the demo's overlap files differed between runs).
    #[test]
    fn the_result_does_not_depend_on_the_run() {
        // Each cell's dz differs, over four orders of magnitude, so the order of the sums shows
        // in their last bits.
        let mut wobbly = plane_strip("2", 0.0, 3.0);
        for p in &mut wobbly.points {
            let cell = (p[0].floor() as usize) * 31 + p[1].floor() as usize;
            let digits = -((cell % 5) as i32) - 2;
            p[2] += ((cell * 7919) % 97 + 1) as f64 * 10f64.powi(digits) / 97.0;
        }
        let strips = [plane_strip("1", 0.0, 0.0), wobbly];
        let first = overlap_qc(&strips, &OverlapOptions::default()).unwrap();
        for _ in 0..10 {
            let again = overlap_qc(&strips, &OverlapOptions::default()).unwrap();
            assert_eq!(
                again.pairs[0].rmsdz_m.to_bits(),
                first.pairs[0].rmsdz_m.to_bits()
            );
            assert_eq!(
                again.pairs[0].mean_dz_m.to_bits(),
                first.pairs[0].mean_dz_m.to_bits()
            );
        }
    }

    #[test]
    fn disjoint_strips_are_refused() {
        let e = overlap_qc(
            &[plane_strip("a", 0.0, 0.0), plane_strip("b", 0.0, 50.0)],
            &OverlapOptions::default(),
        )
        .unwrap_err();
        assert_eq!(e.to_string(), "strip a does not overlap any other strip");
    }
}
