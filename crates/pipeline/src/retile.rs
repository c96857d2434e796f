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
//! write are removed once the new ones are complete. Point clouds there that are not tiles are
//! refused either way, and so is a strip given twice.

use crate::error::{Error, Result};
use lidarqa_io::{LasInfo, LasReader, LasWriteOptions, LasWriter, PointChunk};
use std::path::{Path, PathBuf};

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
/// offset or point format (a tile has one header), a non-empty `out_dir` without `overwrite`,
/// or point clouds in it that are not tiles; lidarqa-io's `DuplicateInput`; I/O and LAS errors
/// naming the file.
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
        if i.crs != first.crs
            || i.scale != first.scale
            || i.offset != first.offset
            || i.point_format != first.point_format
            || i.time_base != first.time_base
            || i.extra_dims != first.extra_dims
        {
            return Err(Error::InvalidOption(format!(
                "{}: its CRS, scale, offset, point format, time base or extra bytes differ from {}'s; tiles need one header",
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
    let path_of = |c: usize, r: usize| out_dir.join(format!("tile_{c:0width$}_{r:0width$}.{ext}"));
    std::fs::create_dir_all(out_dir).map_err(|source| {
        Error::Io(lidarqa_io::Error::Io {
            path: out_dir.to_path_buf(),
            source,
        })
    })?;
    let names: Vec<&str> = first.extra_dims.iter().map(|d| d.name.as_str()).collect();
    let dims: Vec<(&str, &str)> = first
        .extra_dims
        .iter()
        .map(|d| (d.name.as_str(), d.description.as_str()))
        .collect();
    let options = LasWriteOptions::for_input(first, &dims);
    // Writers are opened on a cell's first point, so an empty cell leaves no file.
    let mut writers: Vec<Option<(LasWriter, u64)>> = (0..grid.nx * grid.ny).map(|_| None).collect();
    let mut chunk = PointChunk::new();
    let mut extra = vec![0f32; names.len()];
    let mut total = 0u64;
    for path in inputs {
        let mut reader = LasReader::from_path(path)?;
        while reader.fill(&mut chunk, 200_000)? > 0 {
            for (i, p) in chunk.points.iter().enumerate() {
                let (c, r) = (cell(p.x, 0), cell(p.y, 1));
                let slot = &mut writers[r * grid.nx + c];
                if slot.is_none() {
                    *slot = Some((LasWriter::create(path_of(c, r), &options, inputs)?, 0));
                }
                if let Some((w, count)) = slot.as_mut() {
                    for (e, name) in extra.iter_mut().zip(&names) {
                        *e = chunk.extra(i, name).unwrap_or(f64::NAN) as f32;
                    }
                    w.write_point(p, &extra)?;
                    *count += 1;
                }
                total += 1;
            }
        }
    }
    let mut tiles = Vec::new();
    let mut empty_cells = 0;
    for c in 0..grid.nx {
        for r in 0..grid.ny {
            match writers[r * grid.nx + c].take() {
                None => empty_cells += 1,
                Some((w, points)) => {
                    w.finish()?;
                    let edge = |k: usize, i: usize| min[k] + size[k] * i as f64 / n[k] as f64;
                    tiles.push(TileFile {
                        path: path_of(c, r),
                        col: c,
                        row: r,
                        points,
                        min_xy: [edge(0, c), edge(1, r)],
                        max_xy: [edge(0, c + 1), edge(1, r + 1)],
                    });
                }
            }
        }
    }
    for stale in earlier {
        if !tiles.iter().any(|t| t.path == stale) {
            std::fs::remove_file(&stale).map_err(|source| {
                Error::Io(lidarqa_io::Error::Io {
                    path: stale.clone(),
                    source,
                })
            })?;
        }
    }
    Ok(RetileReport {
        tiles,
        empty_cells,
        points: total,
    })
}

/// `tile_<digits>_<digits>.las|laz`: a file [`retile`] writes.
fn is_tile_name(name: &str) -> bool {
    let Some(stem) = name
        .strip_suffix(".laz")
        .or_else(|| name.strip_suffix(".las"))
    else {
        return false;
    };
    let Some((c, r)) = stem.strip_prefix("tile_").and_then(|s| s.split_once('_')) else {
        return false;
    };
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    digits(c) && digits(r)
}

/// The tiles an earlier run left in `out_dir` (to be removed after the new ones are written),
/// after refusing a non-empty directory without `overwrite`, an input inside it, or point
/// clouds there that are not tiles. Hidden files (an interrupted run's temporaries) do not count.
fn earlier_tiles(out_dir: &Path, inputs: &[PathBuf], overwrite: bool) -> Result<Vec<PathBuf>> {
    let io = |source| {
        Error::Io(lidarqa_io::Error::Io {
            path: out_dir.to_path_buf(),
            source,
        })
    };
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
    let dir = out_dir.canonicalize().map_err(io)?;
    if let Some(i) = inputs.iter().find(|i| {
        i.canonicalize()
            .ok()
            .and_then(|c| c.parent().map(Path::to_path_buf))
            == Some(dir.clone())
    }) {
        return Err(Error::InvalidOption(format!(
            "{}: the input {} is in the output directory; tiles and strips would mix",
            out_dir.display(),
            i.display()
        )));
    }
    let is_cloud = |n: &str| {
        let l = n.to_ascii_lowercase();
        l.ends_with(".las") || l.ends_with(".laz")
    };
    if let Some(other) = names.iter().find(|n| is_cloud(n) && !is_tile_name(n)) {
        return Err(Error::InvalidOption(format!(
            "{}: holds {other}, a point cloud that is not a tile; --overwrite replaces tiles only",
            out_dir.display()
        )));
    }
    Ok(names
        .iter()
        .filter(|n| is_tile_name(n))
        .map(|n| out_dir.join(n))
        .collect())
}
