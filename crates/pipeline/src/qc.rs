//! Delivery QC against the standards: the work behind `lidarqa qc`, writing `qc.json`
//! ([`lidarqa_products::QcDocument`]) and GeoTIFF rasters into one directory.
//!
//! The delivery is read as flight lines across all its files ([`crate::read_lines`]). Then:
//!
//! - **Smooth cells.** Each line's ground points (class 2; all last returns, with a warning, when
//!   the delivery has no ground class) are binned into square cells of [`QcOptions::cell_m`]; in a
//!   cell with at least [`QcOptions::min_points`] of one line a plane `z = a + b·dx + c·dy` is
//!   fitted. The cell is smooth for that line when its slope is at most
//!   [`QcOptions::max_slope_deg`], the RMS of the residuals at most
//!   [`QcOptions::max_roughness_m`] and the points spread across the cell (their smallest
//!   standard deviation in any direction at least a tenth of the cell: a band of points, as
//!   along a wall's shadow, leaves the slope across it to the noise): the "open, smooth,
//!   non-vegetated" ground on which the USGS Lidar Base Specification measures relative
//!   accuracy. Trees, roofs and walls drop out because their returns are not ground, not because
//!   of a threshold on the spikes they make.
//! - **Interswath** (USGS: swath overlap difference): per pair of lines, on the cells smooth in
//!   both, `dz = z_A − z_B` of the two planes at the middle of the two lines' point centroids
//!   (the least extrapolation of either); RMSDz and max |dz|. Pairs with fewer than
//!   [`QcOptions::min_cells`] cells are listed but not judged.
//! - **Intraswath** (USGS: smooth-surface repeatability, or precision): per line, its single
//!   ground returns in its smooth cells as residuals from their cell's plane (slope compensated),
//!   binned in cells of 2 × the delivery's aggregate nominal pulse spacing rounded up to a whole
//!   metre; the range (max − min) of each cell of at least two returns; the median is judged. A
//!   range of n normal residuals is about d(n)·σ, so the cell size, the median returns per cell
//!   and the residual RMS are reported beside it.
//! - **Density**: all points and last returns (one per pulse) per m² over the footprint (10 m
//!   cells holding points, the outer ring left out); the spatial distribution as the share of
//!   cells of 2 × the nominal pulse spacing holding a last return (USGS: 90 %).
//! - **NVA** with checkpoints: the TIN of the ground points at each checkpoint (lidarqa-targets'
//!   `evaluate_vertical_tin`), judged by the ASPRS Positional Accuracy Standards, Edition 2
//!   (2023): at least 30 checkpoints, RMSEz within the accuracy class, mean error within 25 % of
//!   it, and the 95 % figure 1.96 × RMSEz.
//! - **IHO S-44** (`qc/iho.rs`): each sounding's predicted 95 % uncertainties (from lidarqa tpu's σ)
//!   against its order's allowances at its depth; `iho.json` beside `qc.json` for the report.
//! - **Predicted beside measured**: with the TPU's prediction, a measured RMS above it by more
//!   than the 95 % sampling interval of an RMS of its n samples (1.96 / √(2n)) is noted and
//!   warned (`measured_exceeds_predicted`).
//!
//! Thresholds (USGS Lidar Base Specification, relative vertical accuracy, absolute vertical
//! accuracy and nominal pulse density tables, per quality level):
//!
//! | QL | intraswath max diff | RMSDz | max \|dz\| | NVA RMSEz | ANPD (pts/m²) | ANPS (m) |
//! |---|---|---|---|---|---|---|
//! | QL0 | 0.03 m | 0.04 m | 0.08 m | 0.05 m | 8 | 0.35 |
//! | QL1 | 0.06 m | 0.08 m | 0.16 m | 0.10 m | 8 | 0.35 |
//! | QL2 | 0.06 m | 0.08 m | 0.16 m | 0.10 m | 2 | 0.71 |
//! | QL3 | 0.12 m | 0.16 m | 0.32 m | 0.20 m | 0.5 | 1.41 |

mod iho;
mod measure;
mod standards;
#[cfg(test)]
mod tests;
mod verdict;

use measure::*;
use standards::*;
pub use standards::{QlLimits, QualityLevel, Standard};
use verdict::*;

use crate::error::{Error, Result};
use crate::lines::{FlightLine, LineOptions, Lines, read_lines};
use crate::targets_files::control_for_targets;
use lidarqa_calib::{Cell, CellFit, MIN_SPREAD, plane_differences};
use lidarqa_io::WaterClasses;
use lidarqa_io::{AtomicFile, ControlPoints, GeoRaster};
use lidarqa_model::{Warning, median};
use lidarqa_products::{
    QC_FORMAT, QcDensity, QcDocument, QcIho, QcInterswath, QcIntraswath, QcLine, QcLines, QcNva,
    QcPredicted, QcRaster, QcRequirement, QcSmoothCells, QcVerdict,
};
use lidarqa_targets::{EvaluateOptions, evaluate_vertical_tin};
use std::collections::BTreeMap;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::str::FromStr;
/// Options of [`qc_delivery`].
#[derive(Debug, Clone, PartialEq)]
pub struct QcOptions {
    /// Standards to judge by.
    pub standards: Vec<Standard>,
    /// Smooth-cell size, m.
    pub cell_m: f64,
    /// Largest slope of a smooth cell, degrees.
    pub max_slope_deg: f64,
    /// Largest plane-fit RMS of a smooth cell, m.
    pub max_roughness_m: f64,
    /// Fewest points of one line in a cell.
    pub min_points: usize,
    /// Fewest cells for a pair or line to be judged.
    pub min_cells: usize,
    /// Line splitting.
    pub lines: LineOptions,
    /// Checkpoint CSV (vertical), if any.
    pub control: Option<PathBuf>,
    /// The TPU's prediction, if any.
    pub predicted: Option<QcPredicted>,
    /// Which classes are returns from below the water surface (IHO S-44).
    pub water: WaterClasses,
}

impl Default for QcOptions {
    fn default() -> Self {
        QcOptions {
            standards: vec![
                Standard::UsgsLbs2024(QualityLevel::Ql2),
                Standard::Asprs2023(None),
            ],
            cell_m: 2.0,
            max_slope_deg: 10.0,
            max_roughness_m: 0.05,
            min_points: 4,
            min_cells: 30,
            lines: LineOptions::default(),
            control: None,
            predicted: None,
            water: WaterClasses::default(),
        }
    }
}

/// A raster of the cells in `values` (keys on the grid of `origin`, `cell`).
fn raster(
    values: &BTreeMap<Cell, f64>,
    origin: [f64; 2],
    cell: f64,
    epsg: Option<u32>,
) -> Option<GeoRaster> {
    let (x0, x1) = values
        .keys()
        .fold((i64::MAX, i64::MIN), |(a, b), k| (a.min(k.0), b.max(k.0)));
    let (y0, y1) = values
        .keys()
        .fold((i64::MAX, i64::MIN), |(a, b), k| (a.min(k.1), b.max(k.1)));
    if values.is_empty() {
        return None;
    }
    let width = (x1 - x0 + 1) as usize;
    let height = (y1 - y0 + 1) as usize;
    let mut v = vec![None; width * height];
    for (&(ix, iy), &z) in values {
        let row = (y1 - iy) as usize;
        let col = (ix - x0) as usize;
        v[row * width + col] = Some(z as f32);
    }
    Some(GeoRaster {
        width,
        height,
        west: origin[0] + x0 as f64 * cell,
        north: origin[1] + (y1 + 1) as f64 * cell,
        cell,
        epsg,
        values: v,
    })
}

/// The QC of a delivery (module docs): reads `paths`, writes `qc.json` and the rasters into
/// `dir` (created), and returns the document.
///
/// # Errors
/// I/O and format errors naming the file; an option out of range; a delivery without points;
/// checkpoints the TIN cannot evaluate, naming the checkpoint file; an output that is an input.
pub fn qc_delivery<P: AsRef<Path>>(
    paths: &[P],
    dir: &Path,
    options: &QcOptions,
) -> Result<QcDocument> {
    if !(options.cell_m.is_finite() && options.cell_m > 0.0) {
        return Err(Error::InvalidOption(format!(
            "the smooth-cell size must be a number of metres > 0, got {}",
            options.cell_m
        )));
    }
    if !(options.max_slope_deg >= 0.0 && options.max_slope_deg < 90.0) {
        return Err(Error::InvalidOption(format!(
            "the slope limit must be in [0, 90) degrees, got {}",
            options.max_slope_deg
        )));
    }
    let lines = read_lines(paths, &options.lines)?;
    qc_lines(&lines, dir, options)
}

/// As [`qc_delivery`], on lines already read.
///
/// # Errors
/// As [`qc_delivery`].
pub fn qc_lines(lines: &Lines, dir: &Path, options: &QcOptions) -> Result<QcDocument> {
    let inputs = &lines.inputs;
    let mut warnings = lines.warnings.clone();
    let all = lines.lines.iter().flat_map(|l| l.points.iter());
    let (mut min, mut n_points) = ([f64::INFINITY; 2], 0usize);
    for p in all {
        if !(p.xyz.iter().all(|v| v.is_finite())) {
            return Err(Error::InvalidOption(format!(
                "a point with a non-finite coordinate ({:?}) in the delivery",
                p.xyz
            )));
        }
        min[0] = min[0].min(p.xyz[0]);
        min[1] = min[1].min(p.xyz[1]);
        n_points += 1;
    }
    if n_points == 0 {
        return Err(Error::InvalidOption("the delivery holds no points".into()));
    }
    std::fs::create_dir_all(dir).map_err(|e| {
        Error::Io(lidarqa_io::Error::Io {
            path: dir.to_path_buf(),
            source: e,
        })
    })?;
    let ql = options.standards.iter().find_map(|s| match s {
        Standard::UsgsLbs2024(q) => Some(*q),
        _ => None,
    });
    let limits = ql.unwrap_or(QualityLevel::Ql2).limits();
    let c = options.cell_m;
    let origin = [(min[0] / c).floor() * c, (min[1] / c).floor() * c];
    let ground_class = lines.has_ground;
    if !ground_class {
        warnings.push(Warning::new(
            "no_ground_class",
            "no point is classified ground (class 2): smooth cells are tested on all last \
             returns, so low vegetation and roofs may pass as smooth",
        ));
    }
    let max_slope = options.max_slope_deg.to_radians().tan();
    // Per line: cell fits of the surface points.
    let fits: Vec<BTreeMap<Cell, CellFit>> = lines
        .lines
        .iter()
        .map(|l| line_fits(l, ground_class, origin, c, options.min_points))
        .collect();
    let smooth = |f: &CellFit| f.smooth(max_slope, options.max_roughness_m, Some(MIN_SPREAD * c));
    // Interswath.
    let mut interswath = Vec::new();
    let mut rasters = Vec::new();
    let mut pair_dz: Vec<([String; 2], BTreeMap<Cell, f64>)> = Vec::new();
    for a in 0..lines.lines.len() {
        for b in a + 1..lines.lines.len() {
            let dz = plane_differences(&fits[a], &fits[b], smooth);
            if dz.is_empty() {
                continue;
            }
            let n = dz.len();
            let rms = (dz.values().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
            let mx = dz.values().fold(0.0f64, |m, v| m.max(v.abs()));
            let ids = [lines.lines[a].id.clone(), lines.lines[b].id.clone()];
            interswath.push(QcInterswath {
                lines: ids.clone(),
                rmsdz_m: rms,
                max_abs_dz_m: mx,
                cells: n,
            });
            pair_dz.push((ids, dz));
        }
    }
    // Density.
    let (density, density_raster, sigma_raster) = delivery_density(lines, &limits);
    // Intraswath (USGS smooth-surface precision): cells of 2 × the delivery's aggregate nominal
    // pulse spacing, rounded up to a whole metre.
    let anps_m = 1.0 / density.last_returns_per_m2.max(1e-12).sqrt();
    let intra_cell = (2.0 * anps_m).ceil().max(1.0);
    let intraswath: Vec<QcIntraswath> = lines
        .lines
        .iter()
        .zip(&fits)
        .map(|(l, f)| line_intraswath(l, f, &smooth, ground_class, origin, c, intra_cell))
        .collect();
    // NVA.
    let nva = match &options.control {
        None => None,
        Some(cp) => Some(nva(lines, ground_class, cp, &mut warnings)?),
    };
    // Rasters.
    let mut write_raster =
        |kind: &str, name: String, r: Option<GeoRaster>, pair: Option<[String; 2]>| -> Result<()> {
            if let Some(r) = r {
                r.write(&dir.join(&name), inputs)?;
                rasters.push(QcRaster {
                    kind: kind.into(),
                    path: name,
                    lines: pair,
                    cell_m: r.cell,
                });
            }
            Ok(())
        };
    for (ids, dz) in &pair_dz {
        write_raster(
            "dz",
            format!("dz_{}_{}.tif", ids[0], ids[1]),
            raster(dz, origin, c, lines.epsg),
            Some(ids.clone()),
        )?;
    }
    write_raster("density", "density.tif".into(), density_raster, None)?;
    write_raster("sigma_up", "sigma_up.tif".into(), sigma_raster, None)?;
    if lines.epsg.is_none() {
        warnings.push(Warning::new(
            "no_epsg",
            "the delivery declares no EPSG code: the rasters carry no CRS",
        ));
    }
    // IHO S-44: the soundings judged, and iho.json for the report.
    let iho = if options
        .standards
        .iter()
        .any(|s| matches!(s, Standard::IhoS44(_)))
    {
        let j = iho::judge(lines, &options.water);
        if let Some(d) = &j.document {
            write_json(&dir.join(IHO_FILE), inputs, d)?;
        }
        if j.summary.soundings == 0 {
            warnings.push(Warning::new("iho_not_judged", iho_why_not(&j.summary)));
        } else if j.summary.no_depth + j.summary.no_tpu > 0 {
            warnings.push(Warning::new(
                "iho_soundings_left_out",
                format!(
                    "{} of {} soundings not judged by IHO S-44: {} without a depth (no `depth` \
                     extra byte, no water-surface point of class 41/42 within 10 m), {} without \
                     a TPU (run `lidarqa tpu` on the delivery first)",
                    j.summary.no_depth + j.summary.no_tpu,
                    j.summary.bottom_points,
                    j.summary.no_depth,
                    j.summary.no_tpu
                ),
            ));
        }
        Some(j.summary)
    } else {
        None
    };
    // Verdicts.
    let mut verdicts = Vec::new();
    for s in &options.standards {
        verdicts.push(verdict(
            s,
            &VerdictInput {
                ql_nva: ql.map(|q| q.limits().nva_rmse_m),
                interswath: &interswath,
                intraswath: &intraswath,
                density: &density,
                nva: nva.as_ref(),
                predicted: options.predicted.as_ref(),
                min_cells: options.min_cells,
                iho: iho.as_ref(),
            },
        ));
    }
    for v in &mut verdicts {
        for r in &mut v.requirements {
            if let Some(w) = beyond_prediction(r) {
                warnings.push(Warning::new(
                    "measured_exceeds_predicted",
                    format!("{} ({}): {w}", r.requirement, v.standard),
                ));
                r.note = Some(match r.note.take() {
                    Some(n) => format!("{n}; {w}"),
                    None => w,
                });
            }
        }
    }
    let doc = QcDocument {
        format: QC_FORMAT.into(),
        inputs: inputs.iter().map(|p| p.display().to_string()).collect(),
        epsg: lines.epsg,
        lines: QcLines {
            count: lines.lines.len(),
            reasons: lines.reasons.clone(),
            lines: lines
                .lines
                .iter()
                .map(|l| QcLine {
                    id: l.id.clone(),
                    point_source_id: l.point_source_id,
                    points: l.points.len(),
                    gps_time_s: l.gps_time_s,
                    files: l
                        .files
                        .iter()
                        .map(|&f| inputs[f].display().to_string())
                        .collect(),
                })
                .collect(),
        },
        interswath,
        interswath_min_cells: options.min_cells,
        smooth_cells: QcSmoothCells {
            cell_m: c,
            max_slope_deg: options.max_slope_deg,
            max_roughness_m: options.max_roughness_m,
            min_points: options.min_points,
            points: if ground_class {
                "ground (class 2)".into()
            } else {
                "all last returns (no ground class)".into()
            },
        },
        intraswath,
        density,
        nva,
        predicted: options.predicted.clone(),
        iho,
        verdicts,
        rasters,
        warnings,
    };
    write_json(&dir.join("qc.json"), inputs, &doc)?;
    Ok(doc)
}

/// `iho.json` beside `qc.json` (the report's IHO S-44 statement).
const IHO_FILE: &str = "iho.json";

/// Writes `value` as pretty JSON to `path`, atomically, refusing an input as the output.
fn write_json<T: serde::Serialize>(path: &Path, inputs: &[PathBuf], value: &T) -> Result<()> {
    let mut f = AtomicFile::create(path, inputs)?;
    let io = |e: std::io::Error| {
        Error::Io(lidarqa_io::Error::Io {
            path: path.to_path_buf(),
            source: e,
        })
    };
    serde_json::to_writer_pretty(&mut f, value).map_err(|e| io(e.into()))?;
    writeln!(f).map_err(io)?;
    f.commit()?;
    Ok(())
}

/// Why no sounding could be judged by IHO S-44.
fn iho_why_not(i: &QcIho) -> String {
    if i.bottom_points == 0 {
        format!(
            "no point in the sounding classes ({}): not a bathymetric delivery, or its bottom \
             class is another one (--water-classes)",
            i.bottom_classes
                .iter()
                .map(u8::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        )
    } else if i.no_tpu == i.bottom_points {
        format!(
            "{} soundings, none with a TPU (`sigma_up`, `sigma_horizontal` extra bytes): run \
             `lidarqa tpu` on the delivery and give qc its output",
            i.bottom_points
        )
    } else {
        format!(
            "{} soundings: {} without a TPU, {} without a depth (no `depth` extra byte, no \
             water-surface point of class 41/42 within 10 m)",
            i.bottom_points, i.no_tpu, i.no_depth
        )
    }
}

/// The TPU's prediction for the delivery: the sensor file's budget at the flying height above
/// the ground (the trajectory's mean height minus the median ground height of the delivery),
/// nadir, level flight.
///
/// # Errors
/// The trajectory's and sensor file's errors naming the file; a trajectory below the ground.
pub fn qc_prediction(sensor: &Path, trajectory: &Path, lines: &Lines) -> Result<QcPredicted> {
    let heights: Vec<f64> = match lidarqa_io::read_trajectory(trajectory)? {
        lidarqa_io::TrajectoryFile::Sbet(p) => p.iter().map(|x| x.height_m).collect(),
        lidarqa_io::TrajectoryFile::Text(t) => t.poses.iter().map(|x| x.position[2]).collect(),
    };
    let mean = heights.iter().sum::<f64>() / heights.len().max(1) as f64;
    let mut ground: Vec<f64> = lines
        .lines
        .iter()
        .flat_map(|l| l.points.iter())
        .filter(|p| {
            if lines.has_ground {
                p.class == 2
            } else {
                p.last
            }
        })
        .map(|p| p.xyz[2])
        .collect();
    let g = median(&mut ground).unwrap_or(0.0);
    let height_m = mean - g;
    if !(height_m.is_finite() && height_m > 0.0) {
        return Err(Error::InvalidOption(format!(
            "{}: the trajectory's mean height {mean:.1} m is not above the delivery's ground \
             ({g:.1} m): heights in different systems?",
            trajectory.display()
        )));
    }
    let c = crate::predicted_from_sensor(sensor, height_m, None)?;
    Ok(QcPredicted {
        height_m,
        sigma_up_m: c.up,
        sigma_horizontal_m: c.horizontal,
    })
}
