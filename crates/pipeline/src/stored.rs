//! The on-disk form of a [`TpuSummary`]: every count, sum, minimum, maximum and histogram bin, so
//! that tile reports written by many machines merge into exactly the summary one machine would
//! have built (SPEC §9). Kept apart from the in-memory types (as las-rs keeps `raw` apart from
//! its cooked types); f64 values round-trip bit for bit (serde_json's `float_roundtrip`).

use crate::plausibility::PlausibilityTally;
use crate::summary::{
    AngleCheck, IhoTally, IncidenceTally, ResidualCheck, SigmaMap, SkipReason, TpuSummary,
};
use lidarqa_model::{BeamKind, LogHistogram, Source};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A [`LogHistogram`] as stored: empty bins left out.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StoredHistogram {
    /// Values.
    pub n: u64,
    /// Σ values, m.
    pub sum: f64,
    /// Smallest value, m (null when empty).
    pub min: Option<f64>,
    /// Largest value, m (null when empty).
    pub max: Option<f64>,
    /// Values at or below the first bin.
    pub below: u64,
    /// Values above the last bin.
    pub above: u64,
    /// `[bin index, count]` of the non-empty logarithmic bins.
    pub bins: Vec<(usize, u64)>,
}

/// A [`TpuSummary`] as stored.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StoredSummary {
    /// `"linear"`, `"conic"` or a beam scanner's type (`"rotating-mirror"`, ...).
    pub scanner: String,
    /// Points read.
    pub points_read: u64,
    /// Points written.
    pub points_written: u64,
    /// Skipped points by reason name.
    pub skipped: BTreeMap<String, u64>,
    /// One histogram per σ column.
    pub sigma: Vec<StoredHistogram>,
    /// `[source name, Σ share]` in model order.
    pub share_sums: Vec<(String, f64)>,
    /// Points with an incidence angle.
    pub with_normal: u64,
    /// `[n, Σ d² (deg²), max |d| (deg), max beyond a step (deg), step (deg)]`.
    pub scan_angle: (u64, f64, f64, f64, f64),
    /// `[n, Σ q² (m²), max |q| (m)]`.
    pub recovery_residual: (u64, f64, f64),
    /// σ-map cell size, m.
    pub map_cell_m: f64,
    /// `[i, j, Σ σ_V (m), n]` per non-empty cell.
    pub map_cells: Vec<(i64, i64, f64, u64)>,
    /// IHO S-44 counts of the bathymetric soundings (absent: none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub iho: Option<IhoTally>,
    /// Plausibility findings (absent in tile reports written before they existed).
    #[serde(default)]
    pub plausibility: PlausibilityTally,
    /// Incidence-term sources and reasons.
    #[serde(default)]
    pub incidence: IncidenceTally,
    /// Warnings.
    #[serde(default)]
    pub warnings: Vec<lidarqa_model::Warning>,
}

impl From<&LogHistogram> for StoredHistogram {
    fn from(h: &LogHistogram) -> Self {
        let (below, above) = h.outside();
        StoredHistogram {
            n: h.count(),
            sum: h.sum(),
            min: h.min(),
            max: h.max(),
            below,
            above,
            bins: h.bins().collect(),
        }
    }
}

impl StoredHistogram {
    fn restore(&self) -> Result<LogHistogram, String> {
        LogHistogram::from_parts(
            self.n,
            self.sum,
            (self.min, self.max),
            (self.below, self.above),
            &self.bins,
        )
    }
}

impl From<&TpuSummary> for StoredSummary {
    fn from(s: &TpuSummary) -> Self {
        StoredSummary {
            scanner: s.scanner.to_string(),
            points_read: s.points_read,
            points_written: s.points_written,
            skipped: s
                .skipped
                .iter()
                .map(|(r, n)| (r.name().to_string(), *n))
                .collect(),
            sigma: s.sigma.iter().map(StoredHistogram::from).collect(),
            share_sums: s
                .share_sums
                .iter()
                .map(|(n, v)| (n.to_string(), *v))
                .collect(),
            with_normal: s.with_normal,
            scan_angle: (
                s.scan_angle.n,
                s.scan_angle.sum_sq_deg2,
                s.scan_angle.max_deg,
                s.scan_angle.max_beyond_step_deg,
                s.scan_angle.step_deg,
            ),
            recovery_residual: (
                s.recovery_residual.n,
                s.recovery_residual.sum_sq_m2,
                s.recovery_residual.max_abs_m,
            ),
            map_cell_m: s.map.cell_m,
            map_cells: s
                .map
                .cells
                .iter()
                .map(|((i, j), (sum, n))| (*i, *j, *sum, *n))
                .collect(),
            iho: (s.iho.soundings() > 0).then(|| s.iho.clone()),
            plausibility: s.plausibility.clone(),
            incidence: s.incidence,
            warnings: s.warnings.clone(),
        }
    }
}

/// The `&'static str` a name stands for: the summary keeps static names (the kernel's).
fn static_name(name: &str, known: impl IntoIterator<Item = &'static str>) -> Option<&'static str> {
    known.into_iter().find(|k| *k == name)
}

impl StoredSummary {
    /// Back to the in-memory summary; a message naming the key at fault otherwise.
    pub fn restore(&self) -> Result<TpuSummary, String> {
        let scanner = static_name(
            &self.scanner,
            ["linear", "conic"].into_iter().chain(BeamKind::NAMES),
        )
        .ok_or_else(|| format!("\"scanner\": unknown value \"{}\"", self.scanner))?;
        let mut skipped = BTreeMap::new();
        for (name, n) in &self.skipped {
            let r = SkipReason::ALL
                .into_iter()
                .find(|r| r.name() == name)
                .ok_or_else(|| format!("\"skipped\": unknown reason \"{name}\""))?;
            skipped.insert(r, *n);
        }
        let sigma = self
            .sigma
            .iter()
            .enumerate()
            .map(|(k, h)| h.restore().map_err(|m| format!("\"sigma\"[{k}]: {m}")))
            .collect::<Result<Vec<_>, _>>()?;
        let names = Source::ALL
            .iter()
            .map(|s| s.name())
            .chain([lidarqa_tpu::BEAM_FOOTPRINT_SOURCE, "incidence"])
            .collect::<Vec<_>>();
        let share_sums = self
            .share_sums
            .iter()
            .map(|(n, v)| {
                static_name(n, names.iter().copied())
                    .map(|s| (s, *v))
                    .ok_or_else(|| format!("\"share_sums\": unknown source \"{n}\""))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let (n, sum_sq_deg2, max_deg, max_beyond_step_deg, step_deg) = self.scan_angle;
        let (rn, sum_sq_m2, max_abs_m) = self.recovery_residual;
        let mut map = SigmaMap {
            cell_m: self.map_cell_m,
            ..SigmaMap::default()
        };
        for (i, j, s, n) in &self.map_cells {
            map.cells.insert((*i, *j), (*s, *n));
        }
        Ok(TpuSummary {
            scanner,
            points_read: self.points_read,
            points_written: self.points_written,
            skipped,
            sigma,
            share_sums,
            with_normal: self.with_normal,
            incidence: self.incidence,
            warnings: self.warnings.clone(),
            scan_angle: AngleCheck {
                n,
                sum_sq_deg2,
                max_deg,
                max_beyond_step_deg,
                step_deg,
            },
            recovery_residual: ResidualCheck {
                n: rn,
                sum_sq_m2,
                max_abs_m,
            },
            map,
            iho: self.iho.clone().unwrap_or_default(),
            plausibility: self.plausibility.clone(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summary_round_trips_bit_for_bit_through_json() {
        let mut s = TpuSummary::new("linear", vec!["gnss_north", "incidence"], 5);
        for k in 0..1000 {
            let v = 0.01 + f64::from(k) * 1.234_567_890_123e-5;
            for h in &mut s.sigma {
                h.add(v);
            }
            s.map.add(640_000.0 + f64::from(k), 2_800_000.0, v);
            s.scan_angle.add(v / 3.0);
            s.recovery_residual.add(-v / 7.0);
        }
        s.sigma[0].add(0.0);
        s.sigma[1].add(1e9);
        s.points_read = 1003;
        s.points_written = 1000;
        s.skipped.insert(SkipReason::OutsideTrajectory, 3);
        s.share_sums[0].1 = 123.456_789_012_345_67;
        s.share_sums[1].1 = 1.0 / 3.0;
        let text = serde_json::to_string(&StoredSummary::from(&s)).unwrap();
        let back: StoredSummary = serde_json::from_str(&text).unwrap();
        assert_eq!(back.restore().unwrap(), s);
        // An empty summary (a tile whose points were all skipped) keeps its infinite min / max.
        let e = TpuSummary::new("conic", vec!["incidence"], 7);
        let text = serde_json::to_string(&StoredSummary::from(&e)).unwrap();
        let back: StoredSummary = serde_json::from_str(&text).unwrap();
        assert_eq!(back.restore().unwrap(), e);
        // A beam scanner's type and its footprint share come back too.
        let mut b = TpuSummary::new(
            "spinning-multibeam",
            vec![
                "channel_elevation",
                lidarqa_tpu::BEAM_FOOTPRINT_SOURCE,
                "incidence",
            ],
            5,
        );
        b.share_sums[1].1 = 0.25;
        let text = serde_json::to_string(&StoredSummary::from(&b)).unwrap();
        let back: StoredSummary = serde_json::from_str(&text).unwrap();
        assert_eq!(back.restore().unwrap(), b);
    }

    #[test]
    fn unknown_names_are_refused_with_the_key() {
        let s = TpuSummary::new("linear", vec!["gnss_north"], 5);
        let mut st = StoredSummary::from(&s);
        st.share_sums[0].0 = "gnss_sideways".into();
        assert!(st.restore().unwrap_err().contains("share_sums"));
        let mut st = StoredSummary::from(&s);
        st.sigma[0].n = 5;
        assert!(st.restore().unwrap_err().contains("\"sigma\"[0]"));
    }
}
