//! What is measured on the delivery, from its flight lines: smooth cells and their planes,
//! intraswath precision and density by lidarqa-calib's estimators, the NVA at checkpoints by
//! lidarqa-targets'; here the lines' points are picked and the results put into `qc.json`'s types.

use super::*;
use crate::lines::LinePoint;
use lidarqa_calib::{DensityPoint, density, fit_cells, intraswath};

/// Whether a line's point is of the surface QC measures: a ground return, or any last return
/// when the delivery has no ground class.
fn surface(p: &LinePoint, ground_class: bool) -> bool {
    if ground_class { p.class == 2 } else { p.last }
}

/// A line's smooth-cell planes (lidarqa-calib's [`fit_cells`]) of its surface points.
pub(super) fn line_fits(
    l: &FlightLine,
    ground_class: bool,
    origin: [f64; 2],
    c: f64,
    min_points: usize,
) -> BTreeMap<Cell, CellFit> {
    let points = l.points.iter().filter(|p| surface(p, ground_class));
    fit_cells(points.map(|p| p.xyz), origin, c, min_points)
}

/// One line's smooth-surface precision (lidarqa-calib's [`intraswath`]) of its single returns of
/// the surface.
pub(super) fn line_intraswath(
    l: &FlightLine,
    fits: &BTreeMap<Cell, CellFit>,
    smooth: &dyn Fn(&CellFit) -> bool,
    ground_class: bool,
    origin: [f64; 2],
    c: f64,
    intra_cell: f64,
) -> QcIntraswath {
    let points = l
        .points
        .iter()
        .filter(|p| surface(p, ground_class) && p.single);
    let i = intraswath(points.map(|p| p.xyz), fits, smooth, origin, c, intra_cell);
    QcIntraswath {
        line: l.id.clone(),
        cells: i.cells,
        median_range_m: i.median_range_m,
        rms_m: i.rms_m,
        cell_m: intra_cell,
        median_points: i.median_points,
    }
}

/// The delivery's density (lidarqa-calib's [`density`]) and its rasters: last returns per m² and
/// mean σ_up per coarse cell.
pub(super) fn delivery_density(
    lines: &Lines,
    limits: &QlLimits,
) -> (QcDensity, Option<GeoRaster>, Option<GeoRaster>) {
    let points = lines
        .lines
        .iter()
        .flat_map(|l| l.points.iter())
        .map(|p| DensityPoint {
            xyz: p.xyz,
            last: p.last,
            sigma_up_m: p.sigma_up_m,
        });
    let d = density(points, limits.anps_m, limits.anpd_per_m2);
    let last = raster(&d.last_per_m2, d.origin, d.coarse_m, lines.epsg);
    let sigma = raster(&d.mean_sigma_up_m, d.origin, d.coarse_m, lines.epsg);
    (d.summary, last, sigma)
}

pub(super) fn nva(
    lines: &Lines,
    ground_class: bool,
    cp: &Path,
    warnings: &mut Vec<Warning>,
) -> Result<QcNva> {
    let table = ControlPoints::from_path(cp)?;
    let cps = control_for_targets(&table, None)?;
    let ground: Vec<[f64; 3]> = lines
        .lines
        .iter()
        .flat_map(|l| l.points.iter())
        .filter(|p| surface(p, ground_class))
        .map(|p| p.xyz)
        .collect();
    let v =
        evaluate_vertical_tin(&ground, &cps, &EvaluateOptions::default()).map_err(|source| {
            Error::Checkpoints {
                path: cp.to_path_buf(),
                source,
            }
        })?;
    if !v.outside_tin.is_empty() {
        warnings.push(Warning::new(
            "checkpoints_outside",
            format!(
                "{}: {} checkpoints outside the ground TIN, not assessed: {}",
                cp.display(),
                v.outside_tin.len(),
                v.outside_tin.join(", ")
            ),
        ));
    }
    Ok(QcNva {
        file: cp.display().to_string(),
        checkpoints: v.n,
        outside_tin: v.outside_tin.len(),
        rmse_z_m: v.rmse_v_m,
        product_rmse_z_m: v.asprs.vertical.rmse_m,
        mean_z_m: v.mean_up_m,
        accuracy_95_m: v.nssda.vertical_95_m,
        statement: v.asprs.statement.clone(),
    })
}
