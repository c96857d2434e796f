//! The first pass over the strips: each file read once, its points binned by line and cell,
//! the lines' extents and counts that decide the tiles of the tie search.

use super::kept::Observed;
use super::*;

/// Extra reach around every neighbourhood, m: keeping a few more points than the adjustment
/// reads costs little; keeping fewer would change the result.
pub(super) const REACH_SLACK_M: f64 = 1.0;

/// Slack of a local rectangle's projected bounding box, m: covers the curvature of the local
/// frame against the projection over a survey (a height off the frame's by 1 km moves a point
/// 2 km from the centre by 0.3 m).
pub(super) const PROJECTED_SLACK_M: f64 = 5.0;

/// Most points of one tile of the automatic tie search (all strips, margins included, about
/// 104 bytes each in memory, counted by whole first-pass cells): fewer, larger tiles decode
/// fewer LAZ blocks twice, smaller ones hold less.
pub const POINTS_PER_TILE: u64 = 5_000_000;

/// Points per block of a strip's first-pass summary: a later pass reads the scratch records of
/// the blocks whose projected box meets its region, so small blocks read little more than the
/// region's points (a block of a linear scanner spans the swath across a few scan lines).
pub(super) const BLOCK_POINTS: u64 = 10_000;

/// One file's share of a strip: its records in a scratch file and the boxes of their blocks.
pub(super) struct Part {
    pub(super) path: PathBuf,
    /// The line's points of this file as [`Kept`] records, in file order: the later passes read
    /// these instead of decoding the LAZ and inverting the projection again.
    pub(super) scratch: Mutex<File>,
    /// Projected bounding box of each run of [`BLOCK_POINTS`] records.
    pub(super) blocks: Vec<[f64; 4]>,
    /// Records in `scratch`.
    pub(super) count: u64,
}

/// What the first pass keeps of a strip (one flight line): enough to place the neighbourhoods
/// the second one keeps.
pub(super) struct StripScan {
    pub(super) id: String,
    /// Its files' shares, in the inputs' order.
    pub(super) parts: Vec<Part>,
    /// Horizontal extent `[min north, min east, max north, max east]`, local, m.
    pub(super) extent_m: Option<[f64; 4]>,
    /// [`StripScan::extent_m`] without the few far records a corrupted file can hold
    /// ([`lidarqa_calib::robust_extent`]): what the surface calibration's region covers.
    pub(super) robust_extent_m: Option<[f64; 4]>,
    /// The points holding the extent and the time span, in (part, record) order: every cut of
    /// the strip keeps them, so a cut's extent, grid geometry and time span are the whole
    /// strip's.
    pub(super) extremes: Vec<(usize, u64, RawPoint)>,
    /// [`lidarqa_calib::radius_for_neighbours_m`] with [`VTPM_NEIGHBOURS`], when asked for.
    pub(super) radius_m: Option<f64>,
    /// For each tie pick naming this strip (by id or file stem): its index among the picks and
    /// the height (up, local) of the strip's point nearest to it horizontally.
    pub(super) pick_up_m: Vec<(usize, f64)>,
    /// Points per [`COUNT_CELL_M`] cell (local north, east): they size the tiles.
    pub(super) counts: Cells<u64>,
}

/// Values per grid cell (the point counts, the region's buckets): looked up for every point,
/// so with a fast fixed hasher (the keys are our own cell indices, not untrusted input).
pub(super) type Cells<V> = HashMap<(i64, i64), V, foldhash::fast::FixedState>;

/// Cell of the first pass's point counts, m.
pub(super) const COUNT_CELL_M: f64 = 25.0;

pub(super) fn count_cell(north: f64, east: f64) -> (i64, i64) {
    (
        (north / COUNT_CELL_M).floor() as i64,
        (east / COUNT_CELL_M).floor() as i64,
    )
}

/// One line's points of one file as the first pass leaves them.
pub(super) struct Piece {
    pub(super) line: usize,
    pub(super) xy: Vec<[f64; 2]>,
    pub(super) down: Vec<f64>,
    /// Lowest north, lowest east, highest north, highest east, earliest, latest: (value,
    /// record, point).
    pub(super) ext: [Option<(f64, u64, Kept)>; 6],
    pub(super) blocks: Vec<[f64; 4]>,
    pub(super) scratch: BufWriter<File>,
    pub(super) count: u64,
}

impl Piece {
    pub(super) fn take(
        &mut self,
        kept: &Kept,
        observed: &Observed,
        frame: &TangentFrame,
    ) -> std::io::Result<()> {
        // Only the local position and the time are needed for every point; the whole point
        // only for the extreme ones, built at the end (the latest point changes at every point).
        let k = self.count;
        let local = kept.local(frame);
        let (x, y) = (kept.x, kept.y);
        if k % BLOCK_POINTS == 0 {
            self.blocks.push([x, y, x, y]);
        }
        if let Some(b) = self.blocks.last_mut() {
            *b = [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)];
        }
        self.xy.push([local.x, local.y]);
        self.down.push(local.z);
        let v = [
            local.x,
            local.y,
            -local.x,
            -local.y,
            observed.0.time_s,
            -observed.0.time_s,
        ];
        for (slot, value) in self.ext.iter_mut().zip(v) {
            if slot.is_none_or(|(best, _, _)| value < best) {
                *slot = Some((value, k, *kept));
            }
        }
        self.count = k + 1;
        self.scratch.write_all(&kept.to_bytes())
    }
}

/// The first pass over one file: every point read and checked (time, trajectory, recovery)
/// as [`load_all`] does and handed to its line's [`Piece`]; only its horizontal position and
/// height kept until the end. The pieces in line order.
pub(super) fn scan_file(
    path: &Path,
    ctx: &TpuContext,
    frame: &TangentFrame,
    of_point: &[u32],
    progress: Progress<'_, CalibrateStep>,
) -> Result<Vec<Piece>> {
    let scratch_error = |source| Error::Scratch {
        path: path.to_path_buf(),
        source,
    };
    // Each line's points in this file, so that a piece's columns are allocated once at their
    // size (growing by doubling would hold up to twice the survey's points at the peak).
    let mut sizes = vec![0usize; of_point.iter().max().map_or(0, |&l| l as usize + 1)];
    for &l in of_point {
        sizes[l as usize] += 1;
    }
    let mut pieces: Vec<Piece> = Vec::new();
    let mut read = 0u64;
    stream_file(path, ctx, |kept, observed| {
        let l = line_of(of_point, kept, path)?;
        let at = match pieces.iter().position(|p| p.line == l) {
            Some(i) => i,
            None => {
                pieces.push(Piece {
                    line: l,
                    xy: Vec::with_capacity(sizes.get(l).copied().unwrap_or(0)),
                    down: Vec::with_capacity(sizes.get(l).copied().unwrap_or(0)),
                    ext: [None; 6],
                    blocks: Vec::new(),
                    scratch: BufWriter::with_capacity(
                        1 << 20,
                        tempfile::tempfile().map_err(scratch_error)?,
                    ),
                    count: 0,
                });
                pieces.len() - 1
            }
        };
        pieces[at]
            .take(kept, observed, frame)
            .map_err(scratch_error)?;
        read += 1;
        if read % BLOCK_POINTS == 0 {
            progress.report(CalibrateStep::Read(BLOCK_POINTS));
        }
        Ok(())
    })?;
    // The last (partial) block's points.
    progress.report(CalibrateStep::Read(read % BLOCK_POINTS));
    pieces.sort_by_key(|p| p.line);
    Ok(pieces)
}

/// The strips from the files' pieces (`pieces[f]`: file f's, in line order): each line's
/// pieces in the files' order, its extent, extreme points, density and the heights under the
/// picks naming it.
pub(super) fn finish_lines(
    pieces: Vec<Vec<Piece>>,
    names: &[LineName],
    paths: &[PathBuf],
    ctx: &TpuContext,
    frame: &TangentFrame,
    picks: Option<(&TiePicks, &[[f64; 2]])>,
    want_radius: bool,
) -> Result<Vec<StripScan>> {
    let mut per_line: Vec<Vec<(usize, Piece)>> = (0..names.len()).map(|_| Vec::new()).collect();
    for (f, file_pieces) in pieces.into_iter().enumerate() {
        for piece in file_pieces {
            let l = piece.line;
            per_line[l].push((f, piece));
        }
    }
    let recoverer = Recoverer::new(&ctx.recovery_mounting);
    let mut scans = Vec::with_capacity(names.len());
    for (name, line_pieces) in names.iter().zip(per_line) {
        let mut ext: [Option<(f64, usize, u64, Kept)>; 6] = [None; 6];
        let mut xy: Vec<[f64; 2]> = Vec::new();
        let mut down: Vec<f64> = Vec::new();
        let mut parts = Vec::with_capacity(line_pieces.len());
        for (p, (f, piece)) in line_pieces.into_iter().enumerate() {
            let path = &paths[f];
            for (slot, e) in ext.iter_mut().zip(piece.ext) {
                if let Some((value, k, kept)) = e
                    && slot.is_none_or(|(best, ..)| value < best)
                {
                    *slot = Some((value, p, k, kept));
                }
            }
            xy.extend(piece.xy);
            down.extend(piece.down);
            let scratch = piece.scratch.into_inner().map_err(|e| Error::Scratch {
                path: path.clone(),
                source: e.into_error(),
            })?;
            parts.push(Part {
                path: path.clone(),
                scratch: Mutex::new(scratch),
                blocks: piece.blocks,
                count: piece.count,
            });
        }
        let extent_m = match (ext[0], ext[1], ext[2], ext[3]) {
            (Some(a), Some(b), Some(c), Some(d)) => Some([a.0, b.0, -c.0, -d.0]),
            _ => None,
        };
        let robust_extent_m = extent_m.map(|e| {
            let (lo, hi) = lidarqa_calib::robust_extent(
                &[xy.as_slice()],
                [e[0], e[1]],
                [e[2], e[3]],
                REACH_SLACK_M,
            );
            [lo[0], lo[1], hi[0], hi[1]]
        });
        let mut extreme_kept: Vec<(usize, u64, Kept)> =
            ext.iter().flatten().map(|e| (e.1, e.2, e.3)).collect();
        extreme_kept.sort_by_key(|e| (e.0, e.1));
        extreme_kept.dedup_by_key(|e| (e.0, e.1));
        let extremes = extreme_kept
            .iter()
            .map(|(p, k, kept)| {
                let tile = ctx.open_tile(&parts[*p].path)?;
                let observed = kept.observe(
                    &tile.trajectory,
                    &mut SegmentRotation::default(),
                    &recoverer,
                    &parts[*p].path,
                )?;
                Ok((
                    *p,
                    *k,
                    kept.raw_point(frame, &observed, ctx.scan_geometry()),
                ))
            })
            .collect::<Result<Vec<_>>>()?;
        let mut counts: Cells<u64> = Cells::default();
        for [n, e] in &xy {
            *counts.entry(count_cell(*n, *e)).or_default() += 1;
        }
        let radius_m = want_radius
            .then(|| lidarqa_calib::radius_for_neighbours_m(&xy, VTPM_NEIGHBOURS))
            .flatten();
        let mut pick_up_m = Vec::new();
        if let Some((table, guesses)) = picks {
            let mut tree: Option<ImmutableKdTree<f64, 2>> = None;
            for (i, p) in table.picks.iter().enumerate() {
                if !name.aliases.contains(&p.strip) {
                    continue;
                }
                let up = if xy.is_empty() {
                    0.0
                } else {
                    let t = tree.get_or_insert_with(|| ImmutableKdTree::new_from_slice(&xy));
                    let n = t.nearest_one::<SquaredEuclidean>(&guesses[i]);
                    usize::try_from(n.item)
                        .ok()
                        .and_then(|k| down.get(k))
                        .map_or(0.0, |z| -z)
                };
                pick_up_m.push((i, up));
            }
        }
        scans.push(StripScan {
            id: name.id.clone(),
            parts,
            extent_m,
            robust_extent_m,
            extremes,
            radius_m,
            pick_up_m,
            counts,
        });
    }
    Ok(scans)
}
