//! What is measured on the delivery: smooth cells and their planes, intraswath precision,
//! density and the NVA at checkpoints.

use super::*;

/// Cell key `(ix, iy)` on the grid of `origin`.
pub(super) type Cell = (i64, i64);

pub(super) fn cell_of(p: &[f64; 3], origin: [f64; 2], c: f64) -> Cell {
    (
        ((p[0] - origin[0]) / c).floor() as i64,
        ((p[1] - origin[1]) / c).floor() as i64,
    )
}

#[derive(Clone, Copy)]
pub(super) struct CellFit {
    /// The plane's height at the cell centre.
    pub(super) z: f64,
    /// `dz/dx`, `dz/dy`.
    pub(super) grad: [f64; 2],
    /// The points' centroid from the cell centre.
    pub(super) centroid: [f64; 2],
    /// Slope within the limit and the points spread in both directions (the smallest standard
    /// deviation of their positions at least [`MIN_SPREAD`] of the cell): a band of points
    /// leaves the slope across it to their noise.
    pub(super) slope_ok: bool,
    pub(super) rms: f64,
}

/// Smallest standard deviation of a smooth cell's point positions across any direction, as a
/// fraction of the cell (a cell covered evenly has 0.29).
pub(super) const MIN_SPREAD: f64 = 0.1;

/// Plane fit `z = a + b·dx + c·dy` about the centre of a cell of `size`.
pub(super) fn fit(
    points: &[[f64; 3]],
    centre: [f64; 2],
    size: f64,
    max_slope: f64,
) -> Option<CellFit> {
    let mut ata = nalgebra::Matrix3::<f64>::zeros();
    let mut atb = nalgebra::Vector3::<f64>::zeros();
    for p in points {
        let a = nalgebra::Vector3::new(1.0, p[0] - centre[0], p[1] - centre[1]);
        ata += a * a.transpose();
        atb += a * p[2];
    }
    let s = ata.lu().solve(&atb)?;
    let slope = (s[1] * s[1] + s[2] * s[2]).sqrt();
    if !(s.iter().all(|x| x.is_finite()) && slope < 10.0) {
        return None;
    }
    let r: Vec<f64> = points
        .iter()
        .map(|p| p[2] - s[0] - s[1] * (p[0] - centre[0]) - s[2] * (p[1] - centre[1]))
        .collect();
    let rms = (r.iter().map(|v| v * v).sum::<f64>() / r.len() as f64).sqrt();
    let n = ata[(0, 0)];
    let m = [ata[(0, 1)] / n, ata[(0, 2)] / n];
    let (cxx, cyy, cxy) = (
        ata[(1, 1)] / n - m[0] * m[0],
        ata[(2, 2)] / n - m[1] * m[1],
        ata[(1, 2)] / n - m[0] * m[1],
    );
    let lambda_min = 0.5 * (cxx + cyy) - (0.25 * (cxx - cyy) * (cxx - cyy) + cxy * cxy).sqrt();
    Some(CellFit {
        z: s[0],
        grad: [s[1], s[2]],
        centroid: m,
        slope_ok: slope <= max_slope && lambda_min >= (MIN_SPREAD * size).powi(2),
        rms,
    })
}

/// One line's smooth-surface precision (module docs): the residuals of its single returns of
/// the surface from the plane of their smooth cell, binned into cells of `intra_cell` m; the
/// range (max − min) in each cell of at least two points; the median over the cells.
pub(super) fn intraswath(
    l: &FlightLine,
    fits: &BTreeMap<Cell, CellFit>,
    smooth: &dyn Fn(&CellFit) -> bool,
    ground_class: bool,
    origin: [f64; 2],
    c: f64,
    intra_cell: f64,
) -> QcIntraswath {
    let mut bins: BTreeMap<Cell, (f64, f64, usize)> = BTreeMap::new();
    let (mut ss, mut nn) = (0.0, 0usize);
    for p in &l.points {
        let surface = if ground_class { p.class == 2 } else { p.last };
        if !(surface && p.single) {
            continue;
        }
        let k = cell_of(&p.xyz, origin, c);
        let Some(f) = fits.get(&k).filter(|f| smooth(f)) else {
            continue;
        };
        let centre = [
            origin[0] + (k.0 as f64 + 0.5) * c,
            origin[1] + (k.1 as f64 + 0.5) * c,
        ];
        let r = p.xyz[2]
            - f.z
            - f.grad[0] * (p.xyz[0] - centre[0])
            - f.grad[1] * (p.xyz[1] - centre[1]);
        ss += r * r;
        nn += 1;
        let e = bins.entry(cell_of(&p.xyz, origin, intra_cell)).or_insert((
            f64::INFINITY,
            f64::NEG_INFINITY,
            0,
        ));
        e.0 = e.0.min(r);
        e.1 = e.1.max(r);
        e.2 += 1;
    }
    let used: Vec<&(f64, f64, usize)> = bins.values().filter(|b| b.2 >= 2).collect();
    let mut ranges: Vec<f64> = used.iter().map(|b| b.1 - b.0).collect();
    let mut counts: Vec<f64> = used.iter().map(|b| b.2 as f64).collect();
    QcIntraswath {
        line: l.id.clone(),
        cells: ranges.len(),
        median_range_m: median(&mut ranges),
        rms_m: (nn > 0).then(|| (ss / nn as f64).sqrt()),
        cell_m: intra_cell,
        median_points: median(&mut counts),
    }
}

pub(super) fn line_fits(
    l: &FlightLine,
    ground_class: bool,
    origin: [f64; 2],
    c: f64,
    min_points: usize,
    max_slope: f64,
) -> BTreeMap<Cell, CellFit> {
    let mut bins: BTreeMap<Cell, Vec<[f64; 3]>> = BTreeMap::new();
    for p in &l.points {
        let surface = if ground_class { p.class == 2 } else { p.last };
        if surface {
            bins.entry(cell_of(&p.xyz, origin, c))
                .or_default()
                .push(p.xyz);
        }
    }
    bins.into_iter()
        .filter(|(_, v)| v.len() >= min_points.max(3))
        .filter_map(|(k, v)| {
            let centre = [
                origin[0] + (k.0 as f64 + 0.5) * c,
                origin[1] + (k.1 as f64 + 0.5) * c,
            ];
            fit(&v, centre, c, max_slope).map(|f| (k, f))
        })
        .collect()
}

/// Density (module docs) and its rasters: last returns per m² and mean σ_up per coarse cell.
pub(super) fn density(
    lines: &Lines,
    limits: &QlLimits,
) -> (QcDensity, Option<GeoRaster>, Option<GeoRaster>) {
    let fine = 2.0 * limits.anps_m;
    let k = (10.0 / fine).round().max(1.0) as i64;
    let coarse = fine * k as f64;
    let pts = || lines.lines.iter().flat_map(|l| l.points.iter());
    let min = pts().fold([f64::INFINITY; 2], |m, p| {
        [m[0].min(p.xyz[0]), m[1].min(p.xyz[1])]
    });
    let origin = [
        (min[0] / coarse).floor() * coarse,
        (min[1] / coarse).floor() * coarse,
    ];
    // Coarse cells: (points, last returns, σ_up sum, σ_up count).
    let mut cc: BTreeMap<Cell, (usize, usize, f64, usize)> = BTreeMap::new();
    let mut fine_last: std::collections::BTreeSet<Cell> = Default::default();
    for p in pts() {
        let e = cc.entry(cell_of(&p.xyz, origin, coarse)).or_default();
        e.0 += 1;
        if p.last {
            e.1 += 1;
            fine_last.insert(cell_of(&p.xyz, origin, fine));
        }
        if p.sigma_up_m.is_finite() {
            e.2 += f64::from(p.sigma_up_m);
            e.3 += 1;
        }
    }
    // Interior: the coarse cells whose eight neighbours hold points too (the footprint's edge
    // cells are partly empty by construction); all cells when that leaves none.
    let interior: Vec<Cell> = cc
        .keys()
        .filter(|(x, y)| (-1..=1).all(|dx| (-1..=1).all(|dy| cc.contains_key(&(x + dx, y + dy)))))
        .copied()
        .collect();
    let used: Vec<Cell> = if interior.is_empty() {
        cc.keys().copied().collect()
    } else {
        interior
    };
    let area = used.len() as f64 * coarse * coarse;
    let (np, nl) = used
        .iter()
        .fold((0, 0), |(a, b), c| (a + cc[c].0, b + cc[c].1));
    let mut cells = 0usize;
    let mut with = 0usize;
    for &(x, y) in &used {
        for i in 0..k {
            for j in 0..k {
                cells += 1;
                with += usize::from(fine_last.contains(&(x * k + i, y * k + j)));
            }
        }
    }
    let under = used
        .iter()
        .filter(|c| (cc[c].1 as f64) / (coarse * coarse) < limits.anpd_per_m2)
        .count();
    let d: BTreeMap<Cell, f64> = cc
        .iter()
        .map(|(k, v)| (*k, v.1 as f64 / (coarse * coarse)))
        .collect();
    let s: BTreeMap<Cell, f64> = cc
        .iter()
        .filter(|(_, v)| v.3 > 0)
        .map(|(k, v)| (*k, v.2 / v.3 as f64))
        .collect();
    (
        QcDensity {
            cell_m: fine,
            area_m2: area,
            points_per_m2: np as f64 / area,
            last_returns_per_m2: nl as f64 / area,
            cells,
            cells_with_last_return: with as f64 / cells.max(1) as f64,
            coarse_cells_under: under,
            coarse_cells: used.len(),
        },
        raster(&d, origin, coarse, lines.epsg),
        raster(&s, origin, coarse, lines.epsg),
    )
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
        .filter(|p| if ground_class { p.class == 2 } else { p.last })
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
