//! `budget.json` and `budget_sweep_*.json` (`lidarqa budget --format json`, SPEC §6): the
//! propagated uncertainty of one footprint per source, at one geometry or over a sweep.

use lidarqa_model::{Axes, Warning};
use serde::{Deserialize, Serialize};

/// Footprint relative to the GNSS/INS reference point, m.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Footprint {
    /// North, m.
    pub north: f64,
    /// East, m.
    pub east: f64,
    /// Up, m (negative below the sensor).
    pub up: f64,
}

/// Geometry facts reported beside the budget, in display units (the keys carry the unit).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(untagged, deny_unknown_fields)]
pub enum GeometryFacts {
    /// Linear scanner.
    Linear {
        /// Scan angle, degrees.
        scan_angle_deg: f64,
        /// Slant range, m.
        range_m: f64,
        /// Height of the GNSS/INS reference point above the footprint, m.
        height_m: f64,
    },
    /// Conic scanner.
    Conic {
        /// Scan azimuth, degrees.
        azimuth_deg: f64,
        /// Prism slope θf, degrees.
        prism_slope_deg: f64,
        /// Incidence angle of the beam on the water surface, degrees.
        exit_angle_deg: f64,
        /// Angle of the refracted beam from the surface normal, degrees.
        water_angle_deg: f64,
        /// Air range ρ1, m.
        range_air_m: f64,
        /// Water range ρ2, m.
        range_water_m: f64,
        /// Two-way air travel time Δt1, ns.
        time_air_ns: f64,
        /// Two-way water travel time Δt2, ns.
        time_water_ns: f64,
        /// Height of the GNSS/INS reference point above the water surface, m.
        height_m: f64,
        /// Depth of the footprint below the water surface, m.
        depth_m: f64,
    },
}

impl GeometryFacts {
    /// Each fact as `(key, value)`, in the file's order (for display).
    pub fn entries(&self) -> Vec<(&'static str, f64)> {
        match *self {
            GeometryFacts::Linear {
                scan_angle_deg,
                range_m,
                height_m,
            } => vec![
                ("scan_angle_deg", scan_angle_deg),
                ("range_m", range_m),
                ("height_m", height_m),
            ],
            GeometryFacts::Conic {
                azimuth_deg,
                prism_slope_deg,
                exit_angle_deg,
                water_angle_deg,
                range_air_m,
                range_water_m,
                time_air_ns,
                time_water_ns,
                height_m,
                depth_m,
            } => vec![
                ("azimuth_deg", azimuth_deg),
                ("prism_slope_deg", prism_slope_deg),
                ("exit_angle_deg", exit_angle_deg),
                ("water_angle_deg", water_angle_deg),
                ("range_air_m", range_air_m),
                ("range_water_m", range_water_m),
                ("time_air_ns", time_air_ns),
                ("time_water_ns", time_water_ns),
                ("height_m", height_m),
                ("depth_m", depth_m),
            ],
        }
    }
}

/// A signed displacement, metres: north / east / up, and along / across track (across positive
/// towards the right wing).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Displacement {
    /// North, m.
    pub north: f64,
    /// East, m.
    pub east: f64,
    /// Up, m.
    pub up: f64,
    /// Along the heading, m.
    pub along_track: f64,
    /// Across the heading, positive to the right wing, m.
    pub across_track: f64,
}

/// One source's share of the budget: `|∂P/∂p| · σ` per axis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BudgetSource {
    /// The source's snake_case name (SPEC §4).
    pub name: String,
    /// Its 1 σ, SI units (`unit`).
    pub sigma: f64,
    /// `m`, `rad` or `s`.
    pub unit: String,
    /// The effect per axis, m.
    #[serde(flatten)]
    pub effect: Axes,
}

/// The budget of one geometry (what the Python bindings return; the file adds
/// [`BudgetDocument`]'s keys).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Budget {
    /// `"linear"` or `"conic"`.
    pub scanner: String,
    /// `"scanner-frame"`, `"level"`, or null for the linear scanner.
    pub refraction: Option<String>,
    /// The footprint relative to the GNSS/INS reference point.
    pub footprint: Footprint,
    /// Geometry facts.
    pub geometry: GeometryFacts,
    /// Every source of the model with its effect, in the model's order.
    pub sources: Vec<BudgetSource>,
    /// Total propagated uncertainty (1 σ), m.
    pub total: Axes,
    /// Exact displacement caused by the requested biases (lidar − true), m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bias: Option<Displacement>,
    /// The same to first order (`J · b`), m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bias_first_order: Option<Displacement>,
}

/// The Monte Carlo cross-check of the linear propagation (`--monte-carlo`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MonteCarloSigma {
    /// Samples drawn.
    pub samples: u64,
    /// Sample standard deviation per axis, m.
    pub sigma: Axes,
}

/// `budget.json`: `lidarqa budget --format json` of one geometry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BudgetDocument {
    /// The budget.
    #[serde(flatten)]
    pub budget: Budget,
    /// The Monte Carlo cross-check, when asked for.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub monte_carlo: Option<MonteCarloSigma>,
    /// Doubtful findings: `{code, message}`, empty when none.
    pub warnings: Vec<Warning>,
}

/// The budget at one value of a sweep.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BudgetSweepPoint {
    /// The swept variable's value, in the sweep's unit.
    pub at: f64,
    /// The budget there.
    #[serde(flatten)]
    pub budget: Budget,
}

/// The budget over a sweep (what the Python bindings return; the file adds
/// [`BudgetSweepDocument`]'s keys).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BudgetSweep {
    /// The swept variable (`scan-angle`, `azimuth`, `height`, `depth`, ...).
    pub sweep: String,
    /// Unit of `at` (`deg` or `m`).
    pub unit: String,
    /// The budgets, in sweep order.
    pub points: Vec<BudgetSweepPoint>,
}

impl BudgetSweep {
    /// Smallest and largest of one total (`f`, e.g. horizontal σ) over the sweep, m;
    /// (∞, −∞) for no points.
    pub fn total_range(&self, f: fn(&Axes) -> f64) -> (f64, f64) {
        self.points
            .iter()
            .map(|p| f(&p.budget.total))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |a, v| {
                (a.0.min(v), a.1.max(v))
            })
    }
}

/// `budget_sweep_<variable>.json`: `lidarqa budget --sweep NAME=… --format json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BudgetSweepDocument {
    /// The sweep.
    #[serde(flatten)]
    pub sweep: BudgetSweep,
    /// Doubtful findings: `{code, message}`, empty when none.
    pub warnings: Vec<Warning>,
}
