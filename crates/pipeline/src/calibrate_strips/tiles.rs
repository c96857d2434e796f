//! The automatic tie search cut into tiles of bounded size (regions of the overlap, each
//! strip's points inside a tile's reach), and the ties found turned into the CSV's terms.

use super::kept::{KEPT_BYTES, SCRATCH_READ_POINTS};
use super::scan::{Cells, PROJECTED_SLACK_M, StripScan, count_cell};
use super::*;

/// Local rectangles `[min north, min east, max north, max east]` and their projected bounding
/// boxes, both bucketed on a coarse grid, so far points are skipped before the projection's
/// inverse.
pub(super) struct Region {
    pub(super) rects: Vec<[f64; 4]>,
    pub(super) boxes: Vec<[f64; 4]>,
    pub(super) local: Cells<Vec<u32>>,
    pub(super) projected: Cells<Vec<u32>>,
}

/// Bucket size of [`Region`], m.
pub(super) const REGION_CELL_M: f64 = 50.0;
/// Most lookup cells of one tile's region (a square of 50 km at 50 m cells): a tile beyond it is
/// split, so no allocation is sized by the strips' raw extent.
pub(super) const MAX_REGION_CELLS: f64 = 1.0e6;
/// Most candidate nodes of one tile (each is visited): a tile with more is split.
pub(super) const MAX_TILE_NODES: usize = 250_000;
/// Fewest points a tile cut from an outlier-stretched extent needs to be searched for ties: a
/// tie needs planar patches of many points in two strips; fewer are corrupted records.
pub(super) const MIN_STRETCHED_TILE_POINTS: u64 = 1_000;

pub(super) fn buckets(r: &[f64; 4]) -> impl Iterator<Item = (i64, i64)> {
    let c = |v: f64| (v / REGION_CELL_M).floor() as i64;
    let (i0, j0, i1, j1) = (c(r[0]), c(r[1]), c(r[2]), c(r[3]));
    (i0..=i1).flat_map(move |i| (j0..=j1).map(move |j| (i, j)))
}

pub(super) fn bucket(a: f64, b: f64) -> (i64, i64) {
    (
        (a / REGION_CELL_M).floor() as i64,
        (b / REGION_CELL_M).floor() as i64,
    )
}

pub(super) fn inside(r: &[f64; 4], a: f64, b: f64) -> bool {
    r[0] <= a && a <= r[2] && r[1] <= b && b <= r[3]
}

/// The square of half side `reach` around (north, east).
pub(super) fn square(north: f64, east: f64, reach: f64) -> [f64; 4] {
    [north - reach, east - reach, north + reach, east + reach]
}

impl Region {
    pub(super) fn new(rects: Vec<[f64; 4]>, frame: &TangentFrame, zone: &Crs) -> Region {
        let boxes: Vec<[f64; 4]> = rects
            .iter()
            .map(|r| {
                let mut b = [
                    f64::INFINITY,
                    f64::INFINITY,
                    f64::NEG_INFINITY,
                    f64::NEG_INFINITY,
                ];
                for (fa, fb) in [(0.0, 0.0), (0.5, 0.0), (1.0, 0.0), (0.0, 0.5)]
                    .into_iter()
                    .chain([(1.0, 0.5), (0.0, 1.0), (0.5, 1.0), (1.0, 1.0)])
                {
                    let v = Ned::new(r[0] + fa * (r[2] - r[0]), r[1] + fb * (r[3] - r[1]), 0.0);
                    let [x, y, _] = local_to_projected(frame, zone, &v);
                    b = [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)];
                }
                [
                    b[0] - PROJECTED_SLACK_M,
                    b[1] - PROJECTED_SLACK_M,
                    b[2] + PROJECTED_SLACK_M,
                    b[3] + PROJECTED_SLACK_M,
                ]
            })
            .collect();
        let mut local: Cells<Vec<u32>> = Cells::default();
        let mut projected: Cells<Vec<u32>> = Cells::default();
        for (k, (r, b)) in rects.iter().zip(&boxes).enumerate() {
            for c in buckets(r) {
                local.entry(c).or_default().push(k as u32);
            }
            for c in buckets(b) {
                projected.entry(c).or_default().push(k as u32);
            }
        }
        Region {
            rects,
            boxes,
            local,
            projected,
        }
    }

    pub(super) fn near_projected(&self, x: f64, y: f64) -> bool {
        self.projected
            .get(&bucket(x, y))
            .is_some_and(|ks| ks.iter().any(|&k| inside(&self.boxes[k as usize], x, y)))
    }

    pub(super) fn near_local(&self, north: f64, east: f64) -> bool {
        self.local.get(&bucket(north, east)).is_some_and(|ks| {
            ks.iter()
                .any(|&k| inside(&self.rects[k as usize], north, east))
        })
    }

    pub(super) fn meets_projected(&self, e: &[f64; 4]) -> bool {
        self.boxes
            .iter()
            .any(|r| r[0] <= e[2] && e[0] <= r[2] && r[1] <= e[3] && e[1] <= r[3])
    }

    pub(super) fn meets(&self, e: &[f64; 4]) -> bool {
        self.rects
            .iter()
            .any(|r| r[0] <= e[2] && e[0] <= r[2] && r[1] <= e[3] && e[1] <= r[3])
    }
}

/// A later pass over one strip: its points in `region` and its extreme points, in (file,
/// record) order, from the first pass's scratch records of the blocks whose projected box meets
/// the region.
pub(super) fn cut_strip(
    scan: &StripScan,
    ctx: &TpuContext,
    frame: &TangentFrame,
    region: &Region,
) -> Result<Strip> {
    let mut points = Vec::new();
    let mut extremes = scan.extremes.iter().peekable();
    let meets = scan.extent_m.is_some_and(|e| region.meets(&e));
    for (p, part) in scan.parts.iter().enumerate() {
        let mut ranges: Vec<Range<u64>> = Vec::new();
        if meets {
            for (b, bx) in part.blocks.iter().enumerate() {
                if !region.meets_projected(bx) {
                    continue;
                }
                let start = b as u64 * BLOCK_POINTS;
                let end = (start + BLOCK_POINTS).min(part.count);
                match ranges.last_mut() {
                    Some(r) if r.end == start => r.end = end,
                    _ => ranges.push(start..end),
                }
            }
        }
        if ranges.is_empty() {
            continue;
        }
        let tile = ctx.open_tile(&part.path)?;
        let recoverer = Recoverer::new(&ctx.recovery_mounting);
        let mut segment = SegmentRotation::default();
        let mut scratch = part.scratch.lock().unwrap_or_else(|e| e.into_inner());
        let scratch_error = |source| Error::Scratch {
            path: part.path.clone(),
            source,
        };
        let mut buf = Vec::new();
        for range in &ranges {
            let mut start = range.start;
            while start < range.end {
                let n = (range.end - start).min(SCRATCH_READ_POINTS);
                buf.resize(n as usize * KEPT_BYTES, 0);
                scratch
                    .seek(SeekFrom::Start(start * KEPT_BYTES as u64))
                    .and_then(|_| scratch.read_exact(&mut buf))
                    .map_err(scratch_error)?;
                for (k, record) in (start..).zip(buf.chunks_exact(KEPT_BYTES)) {
                    let kept = Kept::from_bytes(record);
                    if !region.near_projected(kept.x, kept.y) {
                        continue;
                    }
                    let v = kept.local(frame);
                    if !region.near_local(v.x, v.y) {
                        continue;
                    }
                    let observed =
                        kept.observe(&tile.trajectory, &mut segment, &recoverer, &part.path)?;
                    let point = kept.raw_point(frame, &observed, ctx.scan_geometry());
                    while let Some((_, _, e)) = extremes.next_if(|(q, j, _)| (*q, *j) < (p, k)) {
                        points.push(*e);
                    }
                    // An extreme point read here is the same point, computed the same way.
                    let _ = extremes.next_if(|(q, j, _)| (*q, *j) == (p, k));
                    points.push(point);
                }
                start += n;
            }
        }
    }
    points.extend(extremes.map(|(_, _, p)| *p));
    points.shrink_to_fit();
    Ok(Strip {
        id: scan.id.clone(),
        points,
    })
}

/// [`cut_strip`] of every strip, in parallel, in the given order.
pub(super) fn cut_all(
    scans: &[StripScan],
    ctx: &TpuContext,
    frame: &TangentFrame,
    region: &Region,
) -> Result<Vec<Strip>> {
    let cut: Vec<Result<Strip>> = scans
        .par_iter()
        .map(|s| cut_strip(s, ctx, frame, region))
        .collect();
    cut.into_iter().collect()
}

/// [`lidarqa_calib::auto_ties`] tile by tile: the grid of candidate nodes is cut into tiles of
/// at most `tile_points` points, each tile's strips are read cut to its nodes' reach, and
/// the candidates of all tiles are selected together, so the ties are those of whole strips.
pub(super) fn auto_ties_tiled(
    scans: &[StripScan],
    tile_points: u64,
    ctx: &TpuContext,
    frame: &TangentFrame,
    zone: &Crs,
    prior: &lidarqa_model::Mounting,
    opts: &AutoTieOptions,
) -> Result<Vec<Tie>> {
    let failed = |e: lidarqa_calib::Error| Error::Calibration(e.to_string());
    let extents: Vec<[f64; 4]> = scans.iter().filter_map(|s| s.extent_m).collect();
    if extents.len() < scans.len() {
        // An empty strip: the search reports it as it would on whole strips.
        let strips: Vec<Strip> = scans
            .iter()
            .map(|s| Strip {
                id: s.id.clone(),
                points: s.extremes.iter().map(|(_, _, p)| *p).collect(),
            })
            .collect();
        return auto_ties(&strips, prior, opts).map_err(failed);
    }
    let grid = AutoTieGrid::new(&extents, opts.spacing_m);
    let mut counts: Cells<u64> = Cells::default();
    for s in scans {
        for (c, n) in &s.counts {
            *counts.entry(*c).or_default() += n;
        }
    }
    // Points a rectangle may hold: every count cell it meets counts whole.
    let points_in = |r: &[f64; 4]| -> u64 {
        let ((i0, j0), (i1, j1)) = (count_cell(r[0], r[1]), count_cell(r[2], r[3]));
        counts
            .iter()
            .filter(|((i, j), _)| (i0..=i1).contains(i) && (j0..=j1).contains(j))
            .map(|(_, n)| n)
            .sum()
    };
    let reach = opts.node_reach_m() + REACH_SLACK_M;
    let mut candidates = Vec::new();
    // Tiles split in two along their longer side while they would hold too many points.
    // The third member: the tile comes from splitting one too large for any survey (an extent
    // stretched by corrupted records), where a handful of points is such records, not a tie.
    let mut todo = vec![(0..grid.nx, 0..grid.ny, false)];
    while let Some((rows, columns, stretched)) = todo.pop() {
        if rows.is_empty() || columns.is_empty() {
            continue;
        }
        let lo = grid.node_m(rows.start, columns.start);
        let hi = grid.node_m(rows.end - 1, columns.end - 1);
        let rect = [lo[0] - reach, lo[1] - reach, hi[0] + reach, hi[1] + reach];
        let n = points_in(&rect);
        if n == 0 || (stretched && n < MIN_STRETCHED_TILE_POINTS) {
            // Nothing to tie here.
            continue;
        }
        // A region's lookup cells are bounded too: a tile far larger than any survey's is
        // split until it is not.
        let too_large = (rect[2] - rect[0]) / REGION_CELL_M * ((rect[3] - rect[1]) / REGION_CELL_M)
            > MAX_REGION_CELLS
            || rows.len() * columns.len() > MAX_TILE_NODES;
        if (n > tile_points || too_large) && rows.len().max(columns.len()) > 1 {
            let stretched = stretched || too_large;
            if rows.len() >= columns.len() {
                let mid = rows.start + rows.len() / 2;
                todo.push((mid..rows.end, columns.clone(), stretched));
                todo.push((rows.start..mid, columns, stretched));
            } else {
                let mid = columns.start + columns.len() / 2;
                todo.push((rows.clone(), mid..columns.end, stretched));
                todo.push((rows, columns.start..mid, stretched));
            }
            continue;
        }
        let region = Region::new(vec![rect], frame, zone);
        let strips = cut_all(scans, ctx, frame, &region)?;
        candidates.extend(
            auto_tie_candidates(&strips, prior, opts, &grid, rows, columns).map_err(failed)?,
        );
    }
    match select_auto_ties(candidates, opts) {
        // No tie patch: the caller turns to the strips' 3-D surfaces.
        Err(lidarqa_calib::Error::NothingUsable { .. }) => Ok(Vec::new()),
        other => other.map_err(failed),
    }
}

/// Tie picks in the local frame; a pick's height is taken from the nearest point of its strip
/// (the horizontal local position depends on it by ~1.6 cm per 100 m per km from the centre),
/// found in the first pass ([`StripScan::pick_up_m`]).
pub(super) fn ties_from_scans(
    picks: &TiePicks,
    scans: &[StripScan],
    names: &[LineName],
    frame: &TangentFrame,
    zone: &Crs,
    h0: f64,
) -> Result<Vec<Tie>> {
    let mut by_id: HashMap<&str, usize> = HashMap::new();
    for (k, l) in names.iter().enumerate() {
        for a in &l.aliases {
            by_id.insert(a.as_str(), k);
        }
    }
    // A file holding several lines names none of them.
    for p in &picks.picks {
        if by_id.contains_key(p.strip.as_str()) {
            continue;
        }
        let holding: Vec<&str> = names
            .iter()
            .filter(|l| l.files.contains(&p.strip))
            .map(|l| l.id.as_str())
            .collect();
        if holding.len() > 1 {
            return Err(Error::Calibration(format!(
                "{}: line {}: strip {} is a file holding {} flight lines ({}): name the line \
                 by its id",
                picks.path.display(),
                p.line,
                p.strip,
                holding.len(),
                holding.join(", ")
            )));
        }
    }
    let mut order: Vec<String> = Vec::new();
    let mut ties: HashMap<String, Vec<TiePick>> = HashMap::new();
    for (i, p) in picks.picks.iter().enumerate() {
        let &k = by_id.get(p.strip.as_str()).ok_or_else(|| {
            Error::Calibration(format!(
                "{}: line {}: strip {} is not among the input strips",
                picks.path.display(),
                p.line,
                p.strip
            ))
        })?;
        let up = scans[k]
            .pick_up_m
            .iter()
            .find(|(j, _)| *j == i)
            .map_or(0.0, |(_, u)| *u);
        let local = projected_to_local(frame, zone, p.x, p.y, h0 + up);
        if !ties.contains_key(&p.tie) {
            order.push(p.tie.clone());
        }
        ties.entry(p.tie.clone()).or_default().push(TiePick {
            strip: scans[k].id.clone(),
            north_m: local.north_m(),
            east_m: local.east_m(),
        });
    }
    Ok(order
        .into_iter()
        .map(|id| Tie {
            picks: ties.remove(&id).unwrap_or_default(),
            id,
            kind: TieKind::Feature,
        })
        .collect())
}

/// A calibration error about a tie or control point, told in the CSV's own terms: file, line,
/// and the projected x, y the user wrote, not the local frame the adjustment works in.
pub(super) fn in_csv_terms(
    e: lidarqa_calib::Error,
    picks: Option<&TiePicks>,
    control: Option<(&ControlPoints, &Path)>,
    strips: &[(String, Vec<String>)],
) -> String {
    use lidarqa_calib::Error as E;
    let same_strip = |csv: &str, id: &str| {
        strips
            .iter()
            .any(|(i, aliases)| i == id && aliases.iter().any(|a| a == csv))
    };
    let pick = |tie: &str, strip: Option<&str>| {
        picks.and_then(|p| {
            p.picks
                .iter()
                .find(|k| k.tie == tie && strip.is_none_or(|s| same_strip(&k.strip, s)))
                .map(|k| {
                    format!(
                        "{}: line {}: tie {} in strip {} at x {}, y {}",
                        p.path.display(),
                        k.line,
                        k.tie,
                        k.strip,
                        k.x,
                        k.y
                    )
                })
        })
    };
    let told = match &e {
        E::TieOutsideStrip {
            tie,
            strip,
            radius_m,
            ..
        } => pick(tie, Some(strip))
            .map(|w| format!("{w}: no point of the strip within {radius_m:.2} m of the pick")),
        E::NoCoplanarTriangle { tie, strip, reason } => pick(tie, Some(strip))
            .map(|w| format!("{w}: no coplanar triangle around the pick ({reason})")),
        E::InvalidTie { tie, message } => pick(tie, None).map(|w| format!("{w}: {message}")),
        // Too few ties remain because picks were dropped: name the first in the CSV's terms.
        E::TooFewTies {
            ties,
            observations,
            unknowns,
            dropped,
        } if !dropped.is_empty() => {
            let d = &dropped[0];
            pick(&d.tie, Some(&d.strip)).map(|w| {
                format!(
                    "{w}: {}; with this and {} other dropped picks, {ties} ties give \
                     {observations} independent observations, {unknowns} unknowns need at least \
                     {unknowns}",
                    d.reason,
                    dropped.len() - 1
                )
            })
        }
        E::OutsideEveryStrip { what, id, .. } if *what == "tie" => {
            pick(id, None).map(|w| format!("{w}: outside every strip"))
        }
        E::OutsideEveryStrip { id, .. } => control.and_then(|(table, path)| {
            table.records.iter().find(|c| &c.id == id).map(|c| {
                format!(
                    "{}: line {}: control point {id} at x {}, y {} is outside every strip",
                    path.display(),
                    c.line,
                    c.x,
                    c.y
                )
            })
        }),
        _ => None,
    };
    told.unwrap_or_else(|| e.to_string())
}
