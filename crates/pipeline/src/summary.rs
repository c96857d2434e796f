//! Mergeable per-tile statistics and the survey summary built from them.
//!
//! Everything here merges exactly: counts, sums, minima and maxima add or compare, and the
//! percentiles come from a fixed **histogram** (1000 logarithmic bins per decade from 1 µm to
//! 10 km, so a reported median or 95th percentile is the geometric centre of its bin: within
//! ±0.12 % of an exact order statistic, clamped to the exact min / max). Because the bins are
//! fixed, the summary of N merged tiles is identical to the summary of the concatenated survey
//! (count, min, max, percentiles exactly; mean and shares up to floating-point summation order).
//! Storing every value would give exact percentiles but memory proportional to the survey.

mod checks;
mod histogram;
mod iho;

pub use checks::{AngleCheck, IncidenceTally, ResidualCheck};
pub(crate) use histogram::stats;
pub use histogram::{SIGMA_MAP_CELL_M, SIGMA_MAP_MAX_SIDE, SigmaMap};
pub use iho::{DEPTH_BANDS_M, IhoTally};

use crate::plausibility::PlausibilityTally;
use lidarqa_model::{LogHistogram, Warning};
use lidarqa_products::{
    RecoveryResidual, ScanAngleCheck, SigmaHistograms, TileLine, TpuSummaryDocument,
};
use std::collections::BTreeMap;
use std::path::PathBuf;

/// Why a point was skipped (each counted, never dropped silently).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum SkipReason {
    /// Its time is outside the trajectory span (`--skip-outside`).
    OutsideTrajectory,
    /// NaN or infinite coordinates (`--skip-invalid`).
    NonFiniteCoordinates,
    /// Its GPS time cannot be put on the trajectory's week (`--skip-invalid`).
    BadTime,
    /// The raw observation or its uncertainty cannot be computed (`--skip-invalid`).
    NoObservation,
    /// A bathymetric sounding (class 40) with no water surface above it: no surface return of
    /// its pulse and too few around it (`--skip-invalid`).
    NoWaterSurface,
    /// A bathymetric sounding not below its water surface (`--skip-invalid`).
    NegativeDepth,
    /// A range beyond the sensor's envelope or a recovery residual its σ cannot explain
    /// (`--skip-invalid`; otherwise written and counted in a warning).
    Implausible,
}

impl SkipReason {
    /// Every reason.
    pub const ALL: [SkipReason; 7] = [
        SkipReason::OutsideTrajectory,
        SkipReason::NonFiniteCoordinates,
        SkipReason::BadTime,
        SkipReason::NoObservation,
        SkipReason::NoWaterSurface,
        SkipReason::NegativeDepth,
        SkipReason::Implausible,
    ];

    /// snake_case name used in JSON.
    pub fn name(self) -> &'static str {
        match self {
            SkipReason::OutsideTrajectory => "outside_trajectory",
            SkipReason::NonFiniteCoordinates => "non_finite_coordinates",
            SkipReason::BadTime => "bad_gps_time",
            SkipReason::NoObservation => "no_observation",
            SkipReason::NoWaterSurface => "no_water_surface",
            SkipReason::NegativeDepth => "negative_depth",
            SkipReason::Implausible => "implausible",
        }
    }
}

/// The σ reported per point, in output order: the extra-bytes dimension names.
pub const SIGMA_NAMES: [&str; 7] = [
    "sigma_north",
    "sigma_east",
    "sigma_up",
    "sigma_horizontal",
    "sigma_vertical",
    "total_thu",
    "total_tvu",
];

/// Mergeable statistics of one tile or of many.
#[derive(Debug, Clone, PartialEq)]
pub struct TpuSummary {
    /// `"linear"`, `"conic"` or a beam scanner's type (`"rotating-mirror"`, ...).
    pub scanner: &'static str,
    /// Points read.
    pub points_read: u64,
    /// Points written with their σ.
    pub points_written: u64,
    /// Skipped points by reason.
    pub skipped: BTreeMap<SkipReason, u64>,
    /// One histogram per [`SIGMA_NAMES`] entry in use (5 for linear, 7 for conic).
    pub sigma: Vec<LogHistogram>,
    /// Source names (model order, then `incidence`) and the sum over points of each source's
    /// share of the point's variance.
    pub share_sums: Vec<(&'static str, f64)>,
    /// Points whose incidence angle could be estimated (a plane through their neighbours).
    pub with_normal: u64,
    /// Where each point's incidence term came from, or why it was left out.
    pub incidence: IncidenceTally,
    /// Doubtful findings (from the shared inputs and from the tiles).
    pub warnings: Vec<Warning>,
    /// Scan-angle check: points, Σ d², max |d| (degrees), max |d| beyond the LAS quantisation.
    pub scan_angle: AngleCheck,
    /// Quality of recovery: Σ q², max |q| (m) of the out-of-plane (linear) or off-cone (conic)
    /// distance.
    pub recovery_residual: ResidualCheck,
    /// Map of σ vertical.
    pub map: SigmaMap,
    /// IHO S-44 counts of the bathymetric soundings (conic scanner).
    pub iho: IhoTally,
    /// Plausibility findings: warnings, implausible points, the mounting check's sums.
    pub plausibility: PlausibilityTally,
}

impl TpuSummary {
    /// An empty summary for a scanner with the given source names (model order, then
    /// `incidence`) and number of σ columns (5 or 7).
    pub fn new(scanner: &'static str, sources: Vec<&'static str>, n_sigma: usize) -> Self {
        TpuSummary {
            scanner,
            points_read: 0,
            points_written: 0,
            skipped: BTreeMap::new(),
            sigma: vec![LogHistogram::default(); n_sigma],
            share_sums: sources.into_iter().map(|s| (s, 0.0)).collect(),
            with_normal: 0,
            incidence: IncidenceTally::default(),
            warnings: Vec::new(),
            scan_angle: AngleCheck::default(),
            recovery_residual: ResidualCheck::default(),
            map: SigmaMap::default(),
            iho: IhoTally::default(),
            plausibility: PlausibilityTally::default(),
        }
    }

    /// Adds another summary (same scanner) into this one.
    pub fn merge(&mut self, o: &TpuSummary) {
        self.points_read += o.points_read;
        self.points_written += o.points_written;
        for (k, v) in &o.skipped {
            *self.skipped.entry(*k).or_default() += v;
        }
        for (a, b) in self.sigma.iter_mut().zip(&o.sigma) {
            a.merge(b);
        }
        for (name, v) in &o.share_sums {
            match self.share_sums.iter_mut().find(|(n, _)| n == name) {
                Some((_, s)) => *s += v,
                None => self.share_sums.push((name, *v)),
            }
        }
        self.with_normal += o.with_normal;
        self.incidence.merge(&o.incidence);
        for w in &o.warnings {
            if !self.warnings.contains(w) {
                self.warnings.push(w.clone());
            }
        }
        self.map.merge(&o.map);
        self.scan_angle.merge(&o.scan_angle);
        self.recovery_residual.merge(&o.recovery_residual);
        self.iho.merge(&o.iho);
        self.plausibility.merge(&o.plausibility);
    }

    /// Every warning of the summary, each once: the shared inputs' and the tiles' own, the
    /// plausibility findings (see [`PlausibilityTally::all_warnings`]) and the incidence term's.
    pub fn warnings(&self) -> Vec<Warning> {
        let skipped = self.skipped.contains_key(&SkipReason::Implausible);
        let mut all = self.warnings.clone();
        for w in self
            .plausibility
            .all_warnings(!skipped)
            .into_iter()
            .chain(self.incidence.warnings())
        {
            if !all.contains(&w) {
                all.push(w);
            }
        }
        all
    }

    /// Total skipped points.
    pub fn skipped_total(&self) -> u64 {
        self.skipped.values().sum()
    }

    /// The `tpu_summary.json` of these statistics and the given tiles' lines.
    pub fn document(&self, tiles: Vec<TileLine>) -> TpuSummaryDocument {
        let n = self.points_written;
        TpuSummaryDocument {
            tiles,
            scanner: self.scanner.to_string(),
            points_read: self.points_read,
            points_written: n,
            points: n,
            skipped: SkipReason::ALL
                .iter()
                .map(|r| {
                    let n = self.skipped.get(r).copied().unwrap_or(0);
                    (r.name().to_string(), n)
                })
                .collect(),
            sigma: self
                .sigma
                .iter()
                .zip(SIGMA_NAMES)
                .map(|(h, name)| (name.trim_start_matches("sigma_").to_string(), stats(h)))
                .collect(),
            percentiles: "histogram: 1000 log bins per decade, bin centre (within 0.12 %)"
                .to_string(),
            source_share: self
                .share_sums
                .iter()
                .map(|(s, v)| (s.to_string(), if n > 0 { v / n as f64 } else { 0.0 }))
                .collect(),
            points_with_surface_normal: self.with_normal,
            incidence: self.incidence.counts(),
            histogram: SigmaHistograms {
                horizontal: self.sigma.get(3).and_then(|h| histogram::linear(h, 40)),
                vertical: self.sigma.get(4).and_then(|h| histogram::linear(h, 40)),
            },
            grid: self.map.view(),
            scan_angle_check: (self.scan_angle.n > 0).then(|| ScanAngleCheck {
                points: self.scan_angle.n,
                rms_deg: (self.scan_angle.sum_sq_deg2 / self.scan_angle.n as f64).sqrt(),
                max_deg: self.scan_angle.max_deg,
                las_step_deg: self.scan_angle.step_deg,
                max_beyond_las_step_deg: self.scan_angle.max_beyond_step_deg,
            }),
            recovery_residual_m: (self.recovery_residual.n > 0).then(|| RecoveryResidual {
                kind: match self.scanner {
                    "linear" => "out_of_plane",
                    "conic" => "off_cone",
                    // A beam scanner: the distance from the nearest beam the head fires.
                    _ => "off_beam",
                }
                .to_string(),
                rms: (self.recovery_residual.sum_sq_m2 / self.recovery_residual.n as f64).sqrt(),
                max_abs: self.recovery_residual.max_abs_m,
            }),
            iho_s44: self.iho.view(),
            mounting_check: self.plausibility.mounting.view(),
            warnings: self.warnings(),
        }
    }
}

/// The result of one tile.
#[derive(Debug, Clone, PartialEq)]
pub struct TileReport {
    /// The input tile.
    pub input: PathBuf,
    /// The output written.
    pub output: PathBuf,
    /// Its statistics.
    pub summary: TpuSummary,
}

impl TileReport {
    /// Merges tile reports into the survey summary (see the module docs for what is exact) and
    /// its `tpu_summary.json`; `None` for no tiles.
    pub fn merge(reports: &[TileReport]) -> Option<(TpuSummary, TpuSummaryDocument)> {
        let (first, rest) = reports.split_first()?;
        let mut all = first.summary.clone();
        for r in rest {
            all.merge(&r.summary);
        }
        let tiles = reports
            .iter()
            .map(|r| TileLine {
                input: r.input.clone(),
                output: r.output.clone(),
                points_read: r.summary.points_read,
                points_written: r.summary.points_written,
                points_skipped: r.summary.skipped_total(),
            })
            .collect();
        let document = all.document(tiles);
        Some((all, document))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lidarqa_tpu::IncidenceClass;
    #[test]
    fn incidence_warnings_past_a_tenth_with_the_reasons() {
        let mut t = IncidenceTally {
            planar: 91,
            linear: 9,
            ..IncidenceTally::default()
        };
        assert_eq!(t.warnings(), vec![]);
        t.merge(&IncidenceTally {
            scattered: 20,
            ..IncidenceTally::default()
        });
        let w = t.warnings();
        assert_eq!(w.len(), 1);
        assert_eq!(w[0].code, "incidence_assumed");
        assert!(
            w[0].message.starts_with(
                "no plane the beam meets is measured around 29 of 120 points (24.2 %): linear \
                 7.5 % take"
            ),
            "{}",
            w[0].message
        );
        t.add(IncidenceClass::TooFew);
        for _ in 0..14 {
            t.add(IncidenceClass::InvalidFileNormal);
        }
        let w = t.warnings();
        assert_eq!(w[0].code, "incidence_left_out");
        assert!(
            w[0].message.starts_with(
                "no surface is defined around 15 of 135 points (11.1 %), so their incidence \
                 term is left out: too few points 0.7 %, invalid file normals 10.4 %"
            ),
            "{}",
            w[0].message
        );
    }
}
