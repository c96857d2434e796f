//! The target pipeline: intensity clustering → spatial segmentation → matching to control →
//! centre estimation.

use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;
use serde::Serialize;

use crate::centre::{
    CentreEstimate, CentreMethod, CentreOptions, TargetFlag, estimate_centre,
    estimate_centre_with_background,
};
use crate::fcm::{ExtractionReport, FcmConfig, ThresholdRule, select_high_intensity};
use crate::plate::{PlateFit, RING_OUT_M, fit_plate};
use crate::point::LidarPoint;
use crate::{Error, Result};
use lidarqa_model::ControlPoint;

/// Checks control points: at least one, unique ids, finite coordinates, sigmas ≥ 0.
///
/// # Errors
/// [`Error::NoControl`], [`Error::DuplicateControlId`], [`Error::NonFinite`],
/// [`Error::InvalidConfig`] (negative sigma or non-positive radius).
pub fn validate_control(control: &[ControlPoint]) -> Result<()> {
    if control.is_empty() {
        return Err(Error::NoControl);
    }
    let mut ids: Vec<&str> = control.iter().map(|c| c.id.as_str()).collect();
    ids.sort_unstable();
    for w in ids.windows(2) {
        if w[0] == w[1] {
            return Err(Error::DuplicateControlId {
                id: w[0].to_string(),
            });
        }
    }
    for (index, c) in control.iter().enumerate() {
        for (what, value) in [("control x", c.x), ("control y", c.y), ("control z", c.z)] {
            if !value.is_finite() {
                return Err(Error::NonFinite { what, index, value });
            }
        }
        for (key, value) in [("sigma_h_m", c.sigma_h_m), ("sigma_v_m", c.sigma_v_m)] {
            if let Some(s) = value
                && !(s >= 0.0 && s.is_finite())
            {
                return Err(Error::InvalidConfig {
                    key,
                    value: s,
                    reason: "a control sigma must be finite and >= 0",
                });
            }
        }
        if let Some(r) = c.radius_m
            && !(r > 0.0 && r.is_finite())
        {
            return Err(Error::InvalidConfig {
                key: "radius_m",
                value: r,
                reason: "the target radius must be finite and > 0",
            });
        }
    }
    Ok(())
}

/// Connected components of points in XY: two points are linked when closer than
/// `link_distance_m` (single linkage, i.e. DBSCAN with min_pts = 1). Components are returned
/// largest first, each as ascending indices into `xy`.
///
/// # Errors
/// [`Error::InvalidConfig`] for a link distance that is not finite and > 0, and
/// [`Error::NonFinite`] for NaN/∞ coordinates.
///
/// # Example
/// ```
/// use lidarqa_targets::segment_clusters;
/// let xy = [[0.0, 0.0], [0.5, 0.0], [10.0, 0.0], [1.0, 0.0]];
/// assert_eq!(segment_clusters(&xy, 0.6).unwrap(), vec![vec![0, 1, 3], vec![2]]);
/// ```
pub fn segment_clusters(xy: &[[f64; 2]], link_distance_m: f64) -> Result<Vec<Vec<usize>>> {
    if !(link_distance_m > 0.0 && link_distance_m.is_finite()) {
        return Err(Error::InvalidConfig {
            key: "link_distance_m",
            value: link_distance_m,
            reason: "must be finite and > 0",
        });
    }
    for (index, p) in xy.iter().enumerate() {
        for (what, value) in [("x", p[0]), ("y", p[1])] {
            if !value.is_finite() {
                return Err(Error::NonFinite { what, index, value });
            }
        }
    }
    if xy.is_empty() {
        return Ok(Vec::new());
    }
    let tree: ImmutableKdTree<f64, 2> = ImmutableKdTree::new_from_slice(xy);
    let r2 = link_distance_m * link_distance_m;
    let mut label = vec![usize::MAX; xy.len()];
    let mut clusters = Vec::new();
    let mut stack = Vec::new();
    for start in 0..xy.len() {
        if label[start] != usize::MAX {
            continue;
        }
        let id = clusters.len();
        let mut members = vec![start];
        label[start] = id;
        stack.push(start);
        while let Some(i) = stack.pop() {
            for nb in tree.within_unsorted::<SquaredEuclidean>(&xy[i], r2) {
                let j = nb.item as usize;
                if label[j] == usize::MAX {
                    label[j] = id;
                    members.push(j);
                    stack.push(j);
                }
            }
        }
        members.sort_unstable();
        clusters.push(members);
    }
    clusters.sort_by(|a, b| b.len().cmp(&a.len()).then(a[0].cmp(&b[0])));
    Ok(clusters)
}

/// Settings of [`extract_targets`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TargetConfig {
    /// Fuzzy c-means settings.
    pub fcm: FcmConfig,
    /// Threshold rule applied after fuzzy c-means. Default [`ThresholdRule::Midpoint`].
    pub threshold: ThresholdRule,
    /// Link distance of the XY segmentation (m). Must exceed the point spacing on the target and
    /// stay below the gap between targets. Default 1.0 m (spacing 0.5 m at 4 pts/m²).
    pub link_distance_m: f64,
    /// Clusters with fewer points are counted in [`TargetReport::small_clusters`] and not
    /// matched. Default 3.
    pub min_cluster_points: usize,
    /// A cluster's centroid must be within this horizontal distance of a control point to be
    /// matched to it (m). Default 2.0 m.
    pub search_radius_m: f64,
    /// Centre estimation; its `radius_m` is used unless the control point gives one.
    pub centre: CentreOptions,
}

impl Default for TargetConfig {
    fn default() -> Self {
        Self {
            fcm: FcmConfig::default(),
            threshold: ThresholdRule::Midpoint,
            link_distance_m: 1.0,
            min_cluster_points: 3,
            search_radius_m: 2.0,
            centre: CentreOptions::default(),
        }
    }
}

/// A target matched to a control point, with its fitted centre.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TargetResult {
    /// The id of the control point the target was matched to.
    pub id: String,
    /// Horizontal distance from the cluster centroid to the control point (m).
    pub match_distance_m: f64,
    /// The fitted centre and its quality.
    #[serde(flatten)]
    pub centre: CentreEstimate,
}

/// Why a cluster was not matched.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum UnmatchedReason {
    /// No control point within the search radius.
    NoControlWithinRadius,
    /// The nearest control point was taken by a cluster closer to it.
    ControlTaken,
}

/// A high-intensity cluster that did not become a target.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct UnmatchedCluster {
    /// Centroid easting (projected m).
    pub x: f64,
    /// Centroid northing (projected m).
    pub y: f64,
    /// Centroid height (m).
    pub z: f64,
    /// Points in the cluster.
    pub n_points: usize,
    /// Id of the nearest control point.
    pub nearest_control: String,
    /// Horizontal distance to it (m).
    pub nearest_distance_m: f64,
    /// Why it was not matched.
    pub reason: UnmatchedReason,
}

/// Everything [`extract_targets`] found; nothing is dropped silently.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TargetReport {
    /// The intensity extraction (fuzzy c-means report, threshold, counts).
    pub extraction: ExtractionReport,
    /// Matched targets, in control order.
    pub targets: Vec<TargetResult>,
    /// Clusters (with at least `min_cluster_points` points) not matched to any control point.
    pub unmatched_clusters: Vec<UnmatchedCluster>,
    /// Ids of control points with no target.
    pub missing_control: Vec<String>,
    /// Clusters below `min_cluster_points` (isolated bright returns), not matched.
    pub small_clusters: usize,
    /// Points in those small clusters.
    pub small_cluster_points: usize,
}

/// The whole target pipeline on one tile: fuzzy c-means on intensity and the threshold
/// ([`select_high_intensity`]), XY segmentation ([`segment_clusters`]), matching of each
/// cluster's centroid to the nearest control point within `search_radius_m` (one cluster per
/// control point: the nearest wins), and [`estimate_centre_with_background`] on each matched
/// cluster, with the unselected points within 1 m of it as background.
///
/// # Errors
/// Bad control ([`validate_control`]), [`Error::NoPoints`], [`Error::NonFinite`],
/// [`Error::NoHighIntensityPoints`], and [`Error::NoTargetNearControl`] when clusters exist but
/// none lies within the search radius of any control point (typically a CRS mismatch).
pub fn extract_targets(
    points: &[LidarPoint],
    control: &[ControlPoint],
    config: &TargetConfig,
) -> Result<TargetReport> {
    validate_control(control)?;
    if points.is_empty() {
        return Err(Error::NoPoints);
    }
    if !(config.search_radius_m > 0.0 && config.search_radius_m.is_finite()) {
        return Err(Error::InvalidConfig {
            key: "search_radius_m",
            value: config.search_radius_m,
            reason: "must be finite and > 0",
        });
    }
    for (index, p) in points.iter().enumerate() {
        for (what, value) in [
            ("x", p.x),
            ("y", p.y),
            ("z", p.z),
            ("intensity", p.intensity),
        ] {
            if !value.is_finite() {
                return Err(Error::NonFinite { what, index, value });
            }
        }
    }
    let intensities: Vec<f64> = points.iter().map(|p| p.intensity).collect();
    let (selected, extraction) =
        select_high_intensity(&intensities, &config.fcm, config.threshold)?;
    let xy: Vec<[f64; 2]> = selected
        .iter()
        .map(|&i| [points[i].x, points[i].y])
        .collect();
    let clusters = segment_clusters(&xy, config.link_distance_m)?;

    let ctrl_xy: Vec<[f64; 2]> = control.iter().map(|c| [c.x, c.y]).collect();
    let tree: ImmutableKdTree<f64, 2> = ImmutableKdTree::new_from_slice(&ctrl_xy);
    // (cluster index, centroid, nearest control, distance)
    let mut candidates = Vec::new();
    let mut small_clusters = 0;
    let mut small_cluster_points = 0;
    for (k, members) in clusters.iter().enumerate() {
        if members.len() < config.min_cluster_points {
            small_clusters += 1;
            small_cluster_points += members.len();
            continue;
        }
        let nf = members.len() as f64;
        let mut c = [0.0; 3];
        for &m in members {
            let p = &points[selected[m]];
            c[0] += p.x / nf;
            c[1] += p.y / nf;
            c[2] += p.z / nf;
        }
        let nn = tree.nearest_one::<SquaredEuclidean>(&[c[0], c[1]]);
        candidates.push((k, c, nn.item as usize, nn.distance.sqrt()));
    }
    // Control points with a known radius: the plate model (module `plate`) on every return
    // around them. Without a radius: the nearest intensity cluster wins the control point.
    let all_xy: Vec<[f64; 2]> = points.iter().map(|p| [p.x, p.y]).collect();
    let all_tree: ImmutableKdTree<f64, 2> = ImmutableKdTree::new_from_slice(&all_xy);
    // Each control point's plate fit is independent of the others and dominates the run time (a
    // grid posterior per plate): they run in parallel, and the first error in control order is
    // the one returned, as a sequential loop would.
    let fits: Vec<Option<Result<TargetResult>>> = control
        .par_iter()
        .map(|c| {
            let radius = c.radius_m.or(config.centre.radius_m)?;
            let reach = config.search_radius_m + radius + RING_OUT_M + 0.5;
            let local: Vec<LidarPoint> = all_tree
                .within_unsorted::<SquaredEuclidean>(&[c.x, c.y], reach * reach)
                .into_iter()
                .map(|nb| points[nb.item as usize])
                .collect();
            let fit = fit_plate(
                &local,
                [c.x, c.y],
                radius,
                config.search_radius_m,
                config.centre.edge_width_m,
            )?;
            let mut opts = config.centre.clone();
            opts.radius_m = Some(radius);
            let match_distance_m = (fit.centre[0] - c.x).hypot(fit.centre[1] - c.y);
            Some(
                plate_estimate(&local, fit, radius, &opts).map(|centre| TargetResult {
                    id: c.id.clone(),
                    match_distance_m,
                    centre,
                }),
            )
        })
        .collect();
    let mut found: Vec<Option<TargetResult>> = fits
        .into_iter()
        .map(Option::transpose)
        .collect::<Result<_>>()?;
    let mut owner: Vec<Option<(usize, f64)>> = vec![None; control.len()];
    for (ci, cand) in candidates.iter().enumerate() {
        let ctrl = &control[cand.2];
        if ctrl.radius_m.or(config.centre.radius_m).is_some() {
            continue;
        }
        if cand.3 <= config.search_radius_m && owner[cand.2].is_none_or(|(_, d)| cand.3 < d) {
            owner[cand.2] = Some((ci, cand.3));
        }
    }
    if found.iter().all(Option::is_none) && owner.iter().all(Option::is_none) {
        if clusters.len() == small_clusters {
            // Every bright point is isolated: report it as no target at all.
            return Err(Error::NoHighIntensityPoints {
                n: points.len(),
                threshold: extraction.threshold,
                rule: format!(
                    "{}; only clusters smaller than {} points",
                    extraction.rule, config.min_cluster_points
                ),
            });
        }
        // A cluster within the search radius of a control point with a known radius was
        // left to the plate model, which found no plate: say that, not "none within".
        if let Some(c) = candidates
            .iter()
            .filter(|c| c.3 <= config.search_radius_m)
            .filter(|c| control[c.2].radius_m.or(config.centre.radius_m).is_some())
            .min_by(|a, b| a.3.total_cmp(&b.3))
        {
            let ctrl = &control[c.2];
            return Err(Error::NoPlateAtControl {
                id: ctrl.id.clone(),
                radius_m: ctrl.radius_m.or(config.centre.radius_m).unwrap_or(f64::NAN),
                nearest_m: c.3,
            });
        }
        let nearest = candidates.iter().map(|c| c.3).fold(f64::INFINITY, f64::min);
        return Err(Error::NoTargetNearControl {
            clusters: candidates.len(),
            control: control.len(),
            search_radius_m: config.search_radius_m,
            nearest_m: nearest,
        });
    }
    // Background: the points that were not selected, for the edge-likelihood refinement.
    let mut is_selected = vec![false; points.len()];
    for &i in &selected {
        is_selected[i] = true;
    }
    let background_idx: Vec<usize> = (0..points.len()).filter(|&i| !is_selected[i]).collect();
    let background_xy: Vec<[f64; 2]> = background_idx
        .iter()
        .map(|&i| [points[i].x, points[i].y])
        .collect();
    let background_tree: Option<ImmutableKdTree<f64, 2>> =
        (!background_xy.is_empty()).then(|| ImmutableKdTree::new_from_slice(&background_xy));
    let mut targets = Vec::new();
    let mut missing_control = Vec::new();
    for (ctrl_idx, own) in owner.iter().enumerate() {
        if let Some(t) = found[ctrl_idx].take() {
            targets.push(t);
            continue;
        }
        let Some((ci, dist)) = *own else {
            missing_control.push(control[ctrl_idx].id.clone());
            continue;
        };
        let members = &clusters[candidates[ci].0];
        let pts: Vec<[f64; 3]> = members
            .iter()
            .map(|&m| {
                let p = &points[selected[m]];
                [p.x, p.y, p.z]
            })
            .collect();
        let opts = config.centre.clone();
        let centroid = candidates[ci].1;
        let extent = pts
            .iter()
            .map(|p| (p[0] - centroid[0]).hypot(p[1] - centroid[1]))
            .fold(0.0, f64::max);
        let reach = extent + 1.0;
        let background: Vec<[f64; 3]> = background_tree
            .as_ref()
            .map(|t| {
                t.within_unsorted::<SquaredEuclidean>(&[centroid[0], centroid[1]], reach * reach)
                    .into_iter()
                    .map(|nb| {
                        let p = &points[background_idx[nb.item as usize]];
                        [p.x, p.y, p.z]
                    })
                    .collect()
            })
            .unwrap_or_default();
        let centre = estimate_centre_with_background(&pts, &background, &opts)?;
        targets.push(TargetResult {
            id: control[ctrl_idx].id.clone(),
            match_distance_m: dist,
            centre,
        });
    }
    flag_neighbours(&mut targets, control, config.centre.radius_m);
    let mut unmatched_clusters = Vec::new();
    for (ci, cand) in candidates.iter().enumerate() {
        if owner[cand.2].is_some_and(|(o, _)| o == ci) {
            continue;
        }
        // A cluster on a plate-model target is that target's.
        if targets.iter().any(|t| {
            let r = t.centre.radius_m.unwrap_or(0.0);
            (t.centre.x - cand.1[0]).hypot(t.centre.y - cand.1[1]) <= r + 0.5
        }) {
            continue;
        }
        let reason = if cand.3 <= config.search_radius_m {
            UnmatchedReason::ControlTaken
        } else {
            UnmatchedReason::NoControlWithinRadius
        };
        unmatched_clusters.push(UnmatchedCluster {
            x: cand.1[0],
            y: cand.1[1],
            z: cand.1[2],
            n_points: clusters[cand.0].len(),
            nearest_control: control[cand.2].id.clone(),
            nearest_distance_m: cand.3,
            reason,
        });
    }
    Ok(TargetReport {
        extraction,
        targets,
        unmatched_clusters,
        missing_control,
        small_clusters,
        small_cluster_points,
    })
}

/// The target's [`CentreEstimate`] from its plate fit: `circle-fit` takes the plate model's
/// posterior centre and its elevation from the plate; `sector-mec` and `centroid` run on the
/// plate's segmented points (Zhang et al. 2018: their elevation is the mean Z of those points,
/// eq. 8).
fn plate_estimate(
    local: &[LidarPoint],
    fit: PlateFit,
    radius: f64,
    options: &CentreOptions,
) -> Result<CentreEstimate> {
    let plate_pts: Vec<[f64; 3]> = fit
        .plate_points
        .iter()
        .map(|&i| [local[i].x, local[i].y, local[i].z])
        .collect();
    let mut flags = Vec::new();
    if plate_pts.len() < options.min_points {
        flags.push(TargetFlag::TooFewPoints);
    }
    let m = &fit.model;
    // A plate is dark around (≤ 5 % of the ring's returns bright at 30 % noise); a line through
    // the circle, or a neighbouring target, is bright in the ring too. (A circle mostly dark
    // inside is no target at all: `fit_plate` finds none.)
    if m.ring_bright_fraction > 0.25 {
        flags.push(TargetFlag::NotADisc);
    }
    if fit.elevation_fallback {
        flags.push(TargetFlag::ElevationFallback);
    }
    let mut est = if options.method == CentreMethod::CircleFit || plate_pts.is_empty() {
        if fit.coverage_deg < options.min_coverage_deg {
            flags.push(TargetFlag::PoorCoverage);
        }
        let cov = [
            [fit.cov[0][0], fit.cov[0][1], 0.0],
            [fit.cov[1][0], fit.cov[1][1], 0.0],
            [0.0, 0.0, fit.var_z],
        ];
        CentreEstimate {
            x: fit.centre[0],
            y: fit.centre[1],
            z: fit.z,
            method: CentreMethod::CircleFit,
            n_points: plate_pts.len(),
            n_edge_points: fit.n_edge,
            n_outliers: 0,
            n_background_points: 0,
            coverage_deg: fit.coverage_deg,
            radius_m: Some(radius),
            radius_estimated: false,
            sigma_horizontal_m: (cov[0][0] + cov[1][1]).max(0.0).sqrt(),
            covariance: cov,
            iterations: 0,
            flags: Vec::new(),
            plate: None,
        }
    } else {
        estimate_centre(&plate_pts, options)?
    };
    for f in flags {
        if !est.flags.contains(&f) {
            est.flags.push(f);
        }
    }
    est.plate = Some(fit.model);
    Ok(est)
}

/// Sets [`TargetFlag::NeighbourTooClose`] on every target with another control point or
/// another fitted target within its diameter plus 0.6 m (the fit windows overlap).
fn flag_neighbours(targets: &mut [TargetResult], control: &[ControlPoint], radius: Option<f64>) {
    let centres: Vec<(String, [f64; 2])> = targets
        .iter()
        .map(|t| (t.id.clone(), [t.centre.x, t.centre.y]))
        .collect();
    for t in targets.iter_mut() {
        let Some(me) = control.iter().find(|c| c.id == t.id) else {
            continue;
        };
        let Some(r) = t.centre.radius_m.or(me.radius_m).or(radius) else {
            continue;
        };
        let limit = 2.0 * r + RING_OUT_M;
        let close_control = control
            .iter()
            .any(|c| c.id != me.id && (c.x - me.x).hypot(c.y - me.y) < limit);
        let close_target = centres
            .iter()
            .any(|(id, c)| *id != t.id && (c[0] - t.centre.x).hypot(c[1] - t.centre.y) < limit);
        if (close_control || close_target)
            && !t.centre.flags.contains(&TargetFlag::NeighbourTooClose)
        {
            t.centre.flags.push(TargetFlag::NeighbourTooClose);
        }
    }
}
