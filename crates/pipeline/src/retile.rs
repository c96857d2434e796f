//! Cut strips into a grid of square-ish tiles: what a statewide survey is delivered as, and what
//! a tile manifest runs over.
//!
//! The grid covers the union of the inputs' header extents (x, y), `nx` columns by `ny` rows;
//! a point goes to the cell its x, y fall in (the east and north edges belong to the last
//! column / row). Each tile holds the points of every strip in input order, each strip's in
//! file order, with every attribute (GPS time, scan angle, point source id) kept, so the TPU
//! of a tile is the TPU of the same points in their strips. Tiles are named
//! `tile_<col>_<row>.<ext>` (column from the west, row from the south, zero-padded to the
//! grid's width) and written atomically; an empty cell writes no file and is counted.
//!
//! A directory of tiles is read whole (`lidarqa tpu DIR`, `lidarqa plan`), so tiles of an
//! earlier grid left beside new ones would be read as well: a non-empty output directory is
//! refused unless `overwrite`, and then the tiles of the earlier run that the new grid did not
//! write are removed once the new ones are complete. What "the tiles of the earlier run" are is
//! told by the run's own record, [`MARKER`] (each tile's name, size and BLAKE3), never by a
//! name pattern: a point cloud there that the record does not list, or that changed since, is
//! refused either way (a user's strip named `tile_9_9.laz` is not a tile), and so is a strip
//! given twice.
//!
//! **Whole or nothing.** The tiles are written into a hidden temporary directory inside the
//! output directory (`.lidarqa-tile.PID.XXXXXX`, same file system) and moved under their final
//! names only when every one is complete; a failure (a full disk, a bad record) removes the
//! temporary directory and leaves the output directory as it was. The record is first written
//! with `"complete": false` listing the earlier and the new tiles, then the move, then the
//! record with `"complete": true`: a run killed during the move leaves a record that says so,
//! and the next `overwrite` cleans exactly those files.
//!
//! **Extra bytes, unchanged.** A tile's records are its strips' records copied byte for byte
//! (cut only of a waveform packet, which lidarqa does not write), so every extra-bytes dimension
//! keeps its type and value bit for bit, and the tile's extra-bytes descriptors are the strips'
//! own (names, types, scale, offset, no-data, description), carried by lidarqa-io's
//! `LasWriteOptions::carry_extra_bytes`. That needs one layout: strips whose extra bytes differ
//! (another dimension, type, order, scale, offset or no-data; the minimum and maximum each file
//! records may differ) are refused with one line naming the two files and the first differing
//! dimension. Carrying the union instead would leave the points of a strip without a dimension
//! holding a value nobody measured (not every type has a no-data value to say so), and
//! converting would change values; the surveyor tiles such strips apart, or makes their extra
//! bytes alike first.
//!
//! **Bounded.** The cells are counted first; a grid with more than [`MAX_TILES`] non-empty cells
//! is refused (a tile per few points is not a tiling), and at most [`MAX_OPEN_TILES`] tiles are
//! open at once (more non-empty cells are written in several passes over the strips), so a
//! 1000 × 1000 grid neither runs out of file handles nor of memory.
//!
//! **Stages.** Each pass reads the strips through lidarqa-io's reader stage
//! ([`lidarqa_io::for_each_chunk`]), so the next chunk is decoded while this one is cut. The
//! tiles are written from the cutting loop, not through a writer stage: that stage owns one
//! output and commits it alone, while a pass here appends a few thousand records at a time to
//! any of up to [`MAX_OPEN_TILES`] tiles, and all of them are committed together by the move.

use crate::digest::FileDigest;
use crate::error::{Error, Result};
use lidarqa_io::{LasInfo, LasReader, LasWriteOptions, LasWriter, RawChunk, for_each_chunk};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The record of the tiles a run wrote, in the output directory (module docs).
pub const MARKER: &str = ".lidarqa-tiles.json";
/// `format` of the record.
const MARKER_FORMAT: &str = "lidarqa-tiles/1";
/// Most non-empty tiles one run writes: beyond it the grid is refused with the count.
pub const MAX_TILES: usize = 20_000;
/// Most tiles open for writing at once (file handles and each writer's buffers); more
/// non-empty cells are written in several passes over the strips.
pub const MAX_OPEN_TILES: usize = 256;
/// Points per chunk read from a strip.
const READ_POINTS: usize = 200_000;
/// Points a tile's buffer holds before they go to its writer: with [`MAX_OPEN_TILES`] open,
/// at most a few tens of MB of records.
const TILE_BUFFER_POINTS: usize = 4096;

/// One tile in the record.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
struct MarkedTile {
    name: String,
    #[serde(flatten)]
    digest: FileDigest,
}

/// The record: which files in the directory this command wrote.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
struct Marker {
    format: String,
    complete: bool,
    tiles: Vec<MarkedTile>,
}

fn io_err(path: &Path, source: std::io::Error) -> Error {
    Error::Io(lidarqa_io::Error::Io {
        path: path.to_path_buf(),
        source,
    })
}

fn write_marker(out_dir: &Path, marker: &Marker) -> Result<()> {
    use std::io::Write as _;
    let path = out_dir.join(MARKER);
    let mut f = lidarqa_io::AtomicFile::create(&path, &[] as &[&Path])?;
    serde_json::to_writer_pretty(&mut f, marker)
        .map_err(|e| io_err(&path, std::io::Error::other(e)))?;
    writeln!(f).map_err(|e| io_err(&path, e))?;
    f.commit()?;
    Ok(())
}

/// A grid of `nx` × `ny` tiles.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TileGrid {
    /// Columns (west → east), ≥ 1.
    pub nx: usize,
    /// Rows (south → north), ≥ 1.
    pub ny: usize,
}

/// One tile written by [`retile`].
#[derive(Debug, Clone, PartialEq)]
pub struct TileFile {
    /// The file.
    pub path: PathBuf,
    /// Column (from the west).
    pub col: usize,
    /// Row (from the south).
    pub row: usize,
    /// Points in it.
    pub points: u64,
    /// West, south edge (projected metres).
    pub min_xy: [f64; 2],
    /// East, north edge (projected metres).
    pub max_xy: [f64; 2],
}

/// What [`retile`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct RetileReport {
    /// The non-empty tiles, column-major by name order.
    pub tiles: Vec<TileFile>,
    /// Grid cells without a point (no file written).
    pub empty_cells: usize,
    /// Points read (= the sum over tiles).
    pub points: u64,
}

/// Cuts `inputs` into `grid` tiles in `out_dir` with extension `ext` (`laz` or `las`).
/// `out_dir` must be empty or missing unless `overwrite` (module docs).
///
/// # Errors
/// [`Error::InvalidOption`] for an empty grid, no inputs, inputs with different CRS, scale,
/// offset, point format or extra-bytes layout (a tile has one header), a non-empty `out_dir`
/// without `overwrite`, or point clouds in it that are not tiles; lidarqa-io's
/// `DuplicateInput`; I/O and LAS errors naming the file.
pub fn retile(
    inputs: &[PathBuf],
    grid: TileGrid,
    out_dir: &Path,
    ext: &str,
    overwrite: bool,
) -> Result<RetileReport> {
    if grid.nx == 0 || grid.ny == 0 {
        return Err(Error::InvalidOption(format!(
            "grid {}x{} must have at least one column and one row",
            grid.nx, grid.ny
        )));
    }
    lidarqa_io::check_distinct_inputs(inputs)?;
    let earlier = earlier_tiles(out_dir, inputs, overwrite)?;
    let infos: Vec<LasInfo> = inputs
        .iter()
        .map(|p| Ok(LasReader::from_path(p)?.info().clone()))
        .collect::<Result<_>>()?;
    let first = infos
        .first()
        .ok_or_else(|| Error::InvalidOption("no input strips to tile".into()))?;
    for i in &infos[1..] {
        if let Some(difference) = extra_bytes_difference(first, i) {
            return Err(Error::InvalidOption(format!(
                "{}: {difference}; a tile has one extra-bytes layout, so tile these strips apart \
                 or make their extra bytes alike first",
                i.path.display()
            )));
        }
        if i.crs != first.crs
            || i.scale != first.scale
            || i.offset != first.offset
            || i.point_format != first.point_format
            || i.time_base != first.time_base
        {
            return Err(Error::InvalidOption(format!(
                "{}: its CRS, scale, offset, point format or time base differ from {}'s; tiles need one header",
                i.path.display(),
                first.path.display()
            )));
        }
    }
    let min = [0, 1].map(|k| infos.iter().map(|i| i.min[k]).fold(f64::INFINITY, f64::min));
    let max = [0, 1].map(|k| {
        infos
            .iter()
            .map(|i| i.max[k])
            .fold(f64::NEG_INFINITY, f64::max)
    });
    let size = [0, 1].map(|k| (max[k] - min[k]).max(1e-9));
    let n = [grid.nx, grid.ny];
    let cell = |v: f64, k: usize| -> usize {
        let f = ((v - min[k]) / size[k] * n[k] as f64).floor();
        (f.max(0.0) as usize).min(n[k] - 1)
    };
    let width = (grid.nx.max(grid.ny) - 1).to_string().len();
    let name_of = |c: usize, r: usize| format!("tile_{c:0width$}_{r:0width$}.{ext}");
    // Count first: the non-empty cells bound the tiles and the passes.
    let mut counts = vec![0u64; grid.nx * grid.ny];
    let cell_of = |xyz: [f64; 3]| cell(xyz[1], 1) * grid.nx + cell(xyz[0], 0);
    // Each pass reads the strips through lidarqa-io's reader stage: the next chunk is decoded
    // while this one is counted or cut.
    let panicked = crate::error::panicked(&first.path);
    let count = |chunk: &mut RawChunk| -> Result<()> {
        for p in chunk.points() {
            counts[cell_of(p.xyz())] += 1;
        }
        Ok(())
    };
    for_each_chunk(inputs, READ_POINTS, count, &panicked)?;
    let non_empty: Vec<usize> = (0..counts.len()).filter(|&k| counts[k] > 0).collect();
    if non_empty.len() > MAX_TILES {
        let total: u64 = counts.iter().sum();
        return Err(Error::InvalidOption(format!(
            "grid {}x{}: {} non-empty tiles of {:.0} points on average, more than the {MAX_TILES} \
             one run writes; choose a coarser grid",
            grid.nx,
            grid.ny,
            non_empty.len(),
            total as f64 / non_empty.len().max(1) as f64
        )));
    }
    std::fs::create_dir_all(out_dir).map_err(|e| io_err(out_dir, e))?;
    // Everything is written in a hidden temporary directory beside the final names (module docs).
    let staging = tempfile::Builder::new()
        .prefix(&format!(".lidarqa-tile.{}.", std::process::id()))
        .tempdir_in(out_dir)
        .map_err(|e| io_err(out_dir, e))?;
    // The strips' own extra bytes ride unchanged; lidarqa adds no dimension, so nothing is
    // renamed, and a record of at most 65 535 bytes stays one.
    let mut options = LasWriteOptions::for_input(first, &[]);
    // A record without GPS time stays in its own format (`for_input` would give it one with a
    // time lidarqa's products need, which a copy has no value for).
    if !first.has_gps_time {
        options.point_format = first.point_format;
    }
    if let Some(w) = options.carry_extra_bytes(first, out_dir) {
        // Unreachable for a readable input (its records fit); never drop the bytes silently.
        return Err(Error::InvalidOption(w.message));
    }
    let mut total = 0u64;
    for batch in non_empty.chunks(MAX_OPEN_TILES) {
        let (lo, hi) = (batch[0], batch[batch.len() - 1]);
        let mut writers: std::collections::HashMap<usize, (LasWriter, RawChunk, PathBuf)> =
            Default::default();
        for &k in batch {
            let (c, r) = (k % grid.nx, k / grid.nx);
            let path = staging.path().join(name_of(c, r));
            let w = LasWriter::create(&path, &options, inputs)?;
            let buffer = w.raw_chunk();
            writers.insert(k, (w, buffer, path));
        }
        let cut = |chunk: &mut RawChunk| -> Result<()> {
            for p in chunk.points() {
                let k = cell_of(p.xyz());
                if k < lo || k > hi {
                    continue;
                }
                if let Some((w, buffer, tile)) = writers.get_mut(&k) {
                    buffer.push(tile, p, &[], &[])?;
                    if buffer.len() >= TILE_BUFFER_POINTS {
                        w.write_raw(buffer)?;
                        buffer.clear();
                    }
                    total += 1;
                }
            }
            Ok(())
        };
        for_each_chunk(inputs, READ_POINTS, cut, &panicked)?;
        for &k in batch {
            if let Some((mut w, buffer, _)) = writers.remove(&k) {
                if !buffer.is_empty() {
                    w.write_raw(&buffer)?;
                }
                w.finish()?;
            }
        }
    }
    let mut tiles = Vec::new();
    let mut marked = Vec::new();
    let empty_cells = counts.len() - non_empty.len();
    for c in 0..grid.nx {
        for r in 0..grid.ny {
            let points = counts[r * grid.nx + c];
            if points == 0 {
                continue;
            }
            let name = name_of(c, r);
            let edge = |k: usize, i: usize| min[k] + size[k] * i as f64 / n[k] as f64;
            marked.push(MarkedTile {
                digest: FileDigest::of_file(&staging.path().join(&name))?,
                name: name.clone(),
            });
            tiles.push(TileFile {
                path: out_dir.join(&name),
                col: c,
                row: r,
                points,
                min_xy: [edge(0, c), edge(1, r)],
                max_xy: [edge(0, c + 1), edge(1, r + 1)],
            });
        }
    }
    // The move: first a record that the directory is in transition (earlier and new tiles),
    // then the stale tiles removed, the new ones renamed in, and the record completed.
    let mut transition: Vec<MarkedTile> = earlier.clone();
    transition.extend(marked.iter().cloned());
    write_marker(
        out_dir,
        &Marker {
            format: MARKER_FORMAT.into(),
            complete: false,
            tiles: transition,
        },
    )?;
    for stale in &earlier {
        if !marked.iter().any(|t| t.name == stale.name) {
            let path = out_dir.join(&stale.name);
            std::fs::remove_file(&path).map_err(|e| io_err(&path, e))?;
        }
    }
    for t in &marked {
        let to = out_dir.join(&t.name);
        std::fs::rename(staging.path().join(&t.name), &to).map_err(|e| io_err(&to, e))?;
    }
    write_marker(
        out_dir,
        &Marker {
            format: MARKER_FORMAT.into(),
            complete: true,
            tiles: marked,
        },
    )?;
    drop(staging);
    Ok(RetileReport {
        tiles,
        empty_cells,
        points: total,
    })
}

/// How the extra bytes of `b` differ from those of `a` (module docs), naming the first
/// differing dimension and `a`; `None` when one descriptor list serves both.
fn extra_bytes_difference(a: &LasInfo, b: &LasInfo) -> Option<String> {
    let show = |d: &lidarqa_io::ExtraDim| {
        format!(
            "`{}` (type {}, {} bytes at byte {}, scale {}, offset {})",
            d.name, d.data_type, d.size, d.offset, d.scale, d.value_offset
        )
    };
    let a_name = a.path.display();
    for k in 0..a.extra_dims.len().max(b.extra_dims.len()) {
        match (a.extra_dims.get(k), b.extra_dims.get(k)) {
            (Some(x), Some(y)) if x.same_layout(y) => {}
            (Some(x), Some(y)) => {
                return Some(format!(
                    "its extra-bytes dimension {} differs from {a_name}'s {}{}",
                    show(y),
                    show(x),
                    if x.name == y.name && x.description != y.description {
                        format!(" (description `{}` vs `{}`)", y.description, x.description)
                    } else {
                        String::new()
                    }
                ));
            }
            (Some(x), None) => {
                return Some(format!(
                    "it lacks the extra-bytes dimension {} of {a_name}",
                    show(x)
                ));
            }
            (None, Some(y)) => {
                return Some(format!(
                    "its extra-bytes dimension {} is not in {a_name}",
                    show(y)
                ));
            }
            (None, None) => {}
        }
    }
    (a.extra_bytes_len != b.extra_bytes_len).then(|| {
        format!(
            "its records have {} extra bytes, {a_name}'s {}",
            b.extra_bytes_len, a.extra_bytes_len
        )
    })
}

/// The tiles an earlier run recorded in `out_dir` (to be removed after the new ones are
/// written), after refusing a non-empty directory without `overwrite`, an input inside it, or
/// point clouds there that the record does not list or that changed since (module docs).
/// Hidden files (the record, an interrupted run's temporaries) do not count.
fn earlier_tiles(out_dir: &Path, inputs: &[PathBuf], overwrite: bool) -> Result<Vec<MarkedTile>> {
    let io = |source| io_err(out_dir, source);
    let entries = match std::fs::read_dir(out_dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(io(e)),
    };
    let mut names: Vec<String> = Vec::new();
    for e in entries {
        let name = e.map_err(io)?.file_name().to_string_lossy().into_owned();
        if !name.starts_with('.') {
            names.push(name);
        }
    }
    names.sort();
    if names.is_empty() {
        return Ok(Vec::new());
    }
    if !overwrite {
        return Err(Error::InvalidOption(format!(
            "{}: the output directory is not empty ({} file(s), first {}); give a new or empty \
             directory, or --overwrite to replace the tiles of an earlier run",
            out_dir.display(),
            names.len(),
            names[0]
        )));
    }
    let dir = lidarqa_io::resolved(out_dir);
    if let Some(i) = inputs
        .iter()
        .find(|i| lidarqa_io::resolved(i).parent() == Some(dir.as_path()))
    {
        return Err(Error::InvalidOption(format!(
            "{}: the input {} is in the output directory; tiles and strips would mix",
            out_dir.display(),
            i.display()
        )));
    }
    let marker_path = out_dir.join(MARKER);
    let marker: Option<Marker> = match std::fs::read(&marker_path) {
        Ok(bytes) => Some(
            serde_json::from_slice::<Marker>(&bytes)
                .ok()
                .filter(|m| m.format == MARKER_FORMAT)
                .ok_or_else(|| {
                    Error::InvalidOption(format!(
                        "{}: not a record of `lidarqa tile` ({MARKER_FORMAT}); remove the \
                         directory's tiles by hand or give a new directory",
                        marker_path.display()
                    ))
                })?,
        ),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => return Err(io_err(&marker_path, e)),
    };
    let recorded = marker.map(|m| m.tiles).unwrap_or_default();
    let is_cloud = |n: &str| {
        let l = n.to_ascii_lowercase();
        l.ends_with(".las") || l.ends_with(".laz")
    };
    let mut earlier = Vec::new();
    for name in names.iter().filter(|n| is_cloud(n)) {
        let path = out_dir.join(name);
        let digest = FileDigest::of_file(&path).ok();
        let mine = recorded
            .iter()
            .find(|t| &t.name == name && digest.as_ref() == Some(&t.digest));
        match mine {
            Some(t) => earlier.push(t.clone()),
            None => {
                return Err(Error::InvalidOption(format!(
                    "{}: holds {name}, not a tile `lidarqa tile` wrote there (its record \
                     {MARKER} does not list it, or it changed since); --overwrite replaces only \
                     the tiles it wrote",
                    out_dir.display()
                )));
            }
        }
    }
    Ok(earlier)
}
