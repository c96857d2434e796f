//! Physical plausibility of a tile's inputs against each other: the points near the trajectory,
//! in their CRS's zone, with ranges and residuals a sensor can have; and the tally that carries
//! every finding of a tile.
//!
//! What the trajectory alone can be is tpu's ([`lidarqa_tpu::check_trajectory`] and its
//! siblings); their refusal names the file here (`implausible_trajectory`). Each check is a
//! function with its threshold as a named constant; an input that cannot be right is an
//! [`Error::Implausible`] naming the file, the value and the likely cause; a doubtful one is a
//! [`Warning`] that the tile's summary carries (merged across tiles, printed by the CLI, written
//! to the JSON and the report).
//!
//! The mounting check's sums and fit are tpu's ([`lidarqa_tpu::MountingTally`]); this tally
//! carries them with the other findings.

use crate::error::{Error, Result};
use lidarqa_model::{Ecef, Warning};
use lidarqa_tpu::{ImplausibleTrajectory, MountingTally};
use serde::{Deserialize, Serialize};
use std::f64::consts::{PI, TAU};
use std::path::Path;

/// The default longest range of an airborne LiDAR, m: long-range sensors (e.g. flown at 6 km
/// above ground, off-nadir) stay below it. A point farther from its scanner is implausible.
pub const DEFAULT_MAX_RANGE_M: f64 = 10_000.0;
/// Median point-to-trajectory distance of a chunk beyond which the points cannot belong to this
/// trajectory, m: a wrong zone, a wrong CRS or another survey's trajectory.
pub const MAX_TRAJECTORY_DISTANCE_M: f64 = 50_000.0;
/// Points sampled per chunk for the distance check: a median of 101 distances is robust to a
/// few corrupted points and costs nothing next to the chunk's propagation.
pub const DISTANCE_SAMPLES: usize = 101;
/// Margin beyond a UTM zone's ±3° from its central meridian, degrees: points up to here are in
/// the zone's usual overlap; beyond it the projection's scale error grows fast.
pub const ZONE_MARGIN_DEG: f64 = 1.0;
/// A point whose recovery residual exceeds this many of its own 3-D σ ...
pub const POINT_RESIDUAL_SIGMAS: f64 = 10.0;
/// ... and this many metres is implausible (corrupted point data, a wrong time): the σ do not
/// explain it.
pub const POINT_RESIDUAL_FLOOR_M: f64 = 1.0;

fn implausible(path: &Path, message: String) -> Error {
    Error::Implausible {
        path: path.to_path_buf(),
        message,
    }
}

/// Names `path` in a refusal of tpu's trajectory checks; the message is the check's, unchanged.
pub(crate) fn implausible_trajectory(path: &Path) -> impl FnOnce(ImplausibleTrajectory) -> Error {
    move |e| implausible(path, e.message)
}

/// The angle `a − b` wrapped to (−π, π].
fn wrapped(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(TAU);
    if d > PI { d - TAU } else { d }
}

/// The UTM zone (e.g. `49N`) a longitude and latitude fall in, for messages.
pub fn utm_zone_name(latitude_rad: f64, longitude_rad: f64) -> String {
    let lon = wrapped(longitude_rad, 0.0).to_degrees();
    let zone = (((lon + 180.0) / 6.0).floor() as i64).clamp(0, 59) + 1;
    format!("{zone}{}", if latitude_rad >= 0.0 { 'N' } else { 'S' })
}

/// Checks that a chunk's points lie near the trajectory: the median distance from each point
/// to the aircraft at its time, over up to 101 points spread through `points` (`(time,
/// point ECEF, aircraft ECEF, aircraft latitude, longitude)`), must stay below
/// [`MAX_TRAJECTORY_DISTANCE_M`]. `crs` names the points' CRS in the message.
///
/// # Errors
/// [`Error::Implausible`] naming the file, the distance, the CRS and the trajectory's zone.
pub fn check_distance(path: &Path, crs: &str, points: &[(Ecef, Ecef, f64, f64)]) -> Result<()> {
    if points.is_empty() {
        return Ok(());
    }
    let step = points.len().div_ceil(DISTANCE_SAMPLES).max(1);
    let mut d: Vec<f64> = points
        .iter()
        .step_by(step)
        .map(|(p, a, _, _)| (*p - *a).norm())
        .collect();
    d.sort_by(f64::total_cmp);
    let median = d[d.len() / 2];
    if median > MAX_TRAJECTORY_DISTANCE_M {
        let (_, _, lat, lon) = points[0];
        return Err(implausible(
            path,
            format!(
                "the points are {:.0} km from the trajectory (median of {} points): wrong UTM \
                 zone or CRS? the points are read in {crs}, the trajectory is in {}",
                median / 1000.0,
                d.len(),
                utm_zone_name(lat, lon)
            ),
        ));
    }
    Ok(())
}

/// A CRS's name for messages: `UTM zone 50N` for a UTM zone, else `EPSG:2180 (ETRS89 / Poland
/// CS92)` or the CRS's name.
pub fn crs_name(crs: &lidarqa_io::Crs) -> String {
    if let Some(zone) = crs.utm_zone() {
        let h = match zone.hemisphere() {
            lidarqa_io::Hemisphere::North => 'N',
            lidarqa_io::Hemisphere::South => 'S',
        };
        return format!("UTM zone {}{h}", zone.zone());
    }
    match crs.epsg() {
        Some(code) => format!("EPSG:{code} ({})", crs.name()),
        None => crs.name().to_string(),
    }
}

/// Whether a point at `longitude_rad` lies outside a UTM zone with central meridian
/// `central_meridian_rad` (± 3° + [`ZONE_MARGIN_DEG`]).
pub fn outside_zone(longitude_rad: f64, central_meridian_rad: f64) -> bool {
    // Within 3.5° without wrapping (no `fmod` per point of a tile): inside, whatever the
    // rounding of the wrap below.
    if (longitude_rad - central_meridian_rad).abs() < 3.5f64.to_radians() {
        return false;
    }
    wrapped(longitude_rad, central_meridian_rad)
        .to_degrees()
        .abs()
        > 3.0 + ZONE_MARGIN_DEG
}

/// Why a point is implausible, if it is: a range beyond the sensor's envelope, or a recovery
/// residual its σ cannot explain.
pub fn point_implausible(range_m: f64, residual_m: f64, sigma_3d_m: f64) -> bool {
    range_m > DEFAULT_MAX_RANGE_M
        || (residual_m.abs() > POINT_RESIDUAL_SIGMAS * sigma_3d_m
            && residual_m.abs() > POINT_RESIDUAL_FLOOR_M)
}

/// Mergeable plausibility findings of one tile or many.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlausibilityTally {
    /// Warnings found while reading (trajectory, gaps), sorted and without duplicates.
    pub warnings: Vec<Warning>,
    /// Points outside their UTM zone's area.
    pub outside_zone: u64,
    /// Points outside the trajectory σ's time span (their σ is the nearest record's).
    pub outside_sigma_span: u64,
    /// The σ records' time span, s.
    pub sigma_span_s: Option<[f64; 2]>,
    /// Points whose range or residual is implausible.
    pub implausible: u64,
    /// The largest residual among them, m.
    pub implausible_max_residual_m: f64,
    /// The largest range among them, m.
    pub implausible_max_range_m: f64,
    /// The first of them: file and point index.
    pub first_implausible: Option<(String, u64)>,
    /// The mounting check's sums.
    pub mounting: MountingTally,
}

impl PlausibilityTally {
    /// Adds warnings (kept sorted, without duplicates).
    pub fn warn(&mut self, w: impl IntoIterator<Item = Warning>) {
        self.warnings.extend(w);
        self.warnings.sort();
        self.warnings.dedup();
    }

    /// Counts one implausible point.
    pub fn add_implausible(&mut self, path: &Path, index: u64, range_m: f64, residual_m: f64) {
        self.implausible += 1;
        self.implausible_max_range_m = self.implausible_max_range_m.max(range_m);
        self.implausible_max_residual_m = self.implausible_max_residual_m.max(residual_m.abs());
        if self.first_implausible.is_none() {
            self.first_implausible = Some((path.display().to_string(), index));
        }
    }

    /// Adds another tally.
    pub fn merge(&mut self, o: &PlausibilityTally) {
        self.warn(o.warnings.iter().cloned());
        self.outside_zone += o.outside_zone;
        self.outside_sigma_span += o.outside_sigma_span;
        self.sigma_span_s = self.sigma_span_s.or(o.sigma_span_s);
        if self.first_implausible.is_none() {
            self.first_implausible = o.first_implausible.clone();
        }
        self.implausible += o.implausible;
        self.implausible_max_range_m = self.implausible_max_range_m.max(o.implausible_max_range_m);
        self.implausible_max_residual_m = self
            .implausible_max_residual_m
            .max(o.implausible_max_residual_m);
        self.mounting.merge(&o.mounting);
    }

    /// Every warning: those found while reading and those the counts imply.
    pub fn all_warnings(&self, skip_invalid_hint: bool) -> Vec<Warning> {
        let mut out = self.warnings.clone();
        if self.outside_zone > 0 {
            out.push(Warning::new(
                "outside_crs_area",
                format!(
                    "{} points lie more than {}° from their UTM zone's central meridian: a \
                     wrong zone? the projection's scale error grows fast there",
                    self.outside_zone,
                    3.0 + ZONE_MARGIN_DEG
                ),
            ));
        }
        if self.outside_sigma_span > 0 {
            let span = self
                .sigma_span_s
                .map(|[a, b]| format!(" ({a} to {b} s)"))
                .unwrap_or_default();
            out.push(Warning::new(
                "trajectory_sigma_not_covering",
                format!(
                    "{} points lie outside the time span of the trajectory σ{span}: their σ is \
                     the nearest record's, held constant",
                    self.outside_sigma_span
                ),
            ));
        }
        let mounting = self.mounting.does_not_fit();
        // A mounting that does not fit puts every point far off: that warning says it once.
        if self.implausible > 0 && (!mounting || self.implausible * 2 < self.mounting.n) {
            let first = self
                .first_implausible
                .as_ref()
                .map(|(p, i)| format!(" (first: {p} point {i})"))
                .unwrap_or_default();
            out.push(Warning::new(
                "implausible_points",
                format!(
                    "{} points{first} have a range beyond {DEFAULT_MAX_RANGE_M} m or a recovery \
                     residual beyond {POINT_RESIDUAL_SIGMAS} σ and {POINT_RESIDUAL_FLOOR_M} m \
                     (largest residual {:.1} m, largest range {:.1} m): corrupted point data?{}",
                    self.implausible,
                    self.implausible_max_residual_m,
                    self.implausible_max_range_m,
                    if skip_invalid_hint {
                        " --skip-invalid leaves them out"
                    } else {
                        " they were skipped"
                    }
                ),
            ));
        }
        if mounting {
            out.push(Warning::new(
                "mounting_does_not_fit",
                self.mounting.message(),
            ));
        }
        out.sort();
        out.dedup();
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utm_zone_names() {
        assert_eq!(utm_zone_name(0.4, 111f64.to_radians()), "49N");
        assert_eq!(utm_zone_name(-0.4, 117.5f64.to_radians()), "50S");
        assert!(outside_zone(112.9f64.to_radians(), 117f64.to_radians()));
        assert!(!outside_zone(113.5f64.to_radians(), 117f64.to_radians()));
    }
}
