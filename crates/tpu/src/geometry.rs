//! One observation geometry (attitude plus the scanner's own observation) and its full evaluation:
//! footprint, budget, and optionally the effect of systematic errors.

use crate::axes::{Axes, Displacement};
use crate::bias::{BiasEffect, Biases, bias_effect};
use crate::budget::{SourceTerm, budget};
use crate::error::{Error, Result};
use crate::montecarlo::{MonteCarlo, monte_carlo};
use lidarqa_model::{
    Attitude, ConicObservation, ConicScanner, Georeferencer, LinearObservation, LinearScanner,
    Refraction, Scanner, Sensor, linear_range_for_height,
};
use lidarqa_products::Budget;
use nalgebra::{SVector, Vector3};

/// How the linear scanner's range is given.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LinearRange {
    /// Slant range ρ, m.
    Range(f64),
    /// Height of the GNSS/INS reference point above level ground, m; ρ follows from the ray.
    Height(f64),
}

/// How the conic scanner's ranges are given.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ConicRanges {
    /// Air range ρ1 and water range ρ2, m.
    Ranges {
        /// ρ1, m.
        air_m: f64,
        /// ρ2, m.
        water_m: f64,
    },
    /// Height above the water surface and water depth, m; the ranges follow from the rays.
    HeightDepth {
        /// Height of the GNSS/INS reference point above the (level) water surface, m.
        height_m: f64,
        /// Depth of the (level) bottom below the surface, m.
        depth_m: f64,
    },
}

/// One observation geometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Geometry {
    /// Linear scanner.
    Linear {
        /// Platform attitude.
        attitude: Attitude,
        /// Scan angle θ, rad, positive to the right wing.
        scan_angle_rad: f64,
        /// Range or height.
        range: LinearRange,
    },
    /// Conic scanner.
    Conic {
        /// Platform attitude.
        attitude: Attitude,
        /// Scan azimuth θaz, rad.
        azimuth_rad: f64,
        /// Ranges or height and depth.
        ranges: ConicRanges,
    },
}

impl Geometry {
    /// The platform attitude of either kind.
    pub fn attitude(&self) -> Attitude {
        match self {
            Geometry::Linear { attitude, .. } | Geometry::Conic { attitude, .. } => *attitude,
        }
    }

    /// The same geometry with another attitude.
    pub fn with_attitude(mut self, a: Attitude) -> Geometry {
        match &mut self {
            Geometry::Linear { attitude, .. } | Geometry::Conic { attitude, .. } => *attitude = a,
        }
        self
    }
}

/// Geometry facts reported beside the budget and the footprint: lidarqa-products' types, the
/// ones `budget.json` is written with.
pub use lidarqa_products::{Footprint, GeometryFacts};

/// Everything `lidarqa budget` reports for one geometry (its JSON, [`Evaluation::to_budget`], is
/// SPEC §6's contract).
#[derive(Debug, Clone, PartialEq)]
pub struct Evaluation {
    /// `"linear"` or `"conic"`.
    pub scanner: &'static str,
    /// `"scanner-frame"`, `"level"`, or null for the linear scanner.
    pub refraction: Option<&'static str>,
    /// The footprint relative to the GNSS/INS reference point.
    pub footprint: Footprint,
    /// Geometry facts.
    pub geometry: GeometryFacts,
    /// Every source of the model with its effect.
    pub sources: Vec<SourceTerm>,
    /// Total propagated uncertainty (1σ), m.
    pub total: Axes,
    /// Exact displacement caused by the requested biases (lidar − true), m.
    pub bias: Option<Displacement>,
    /// The same to first order (`J · b`), m.
    pub bias_first_order: Option<Displacement>,
}

impl Evaluation {
    /// The budget as `lidarqa budget --format json` writes it (SPEC §6).
    pub fn to_budget(&self) -> Budget {
        Budget {
            scanner: self.scanner.to_string(),
            refraction: self.refraction.map(str::to_string),
            footprint: self.footprint,
            geometry: self.geometry,
            sources: self
                .sources
                .iter()
                .map(SourceTerm::to_budget_source)
                .collect(),
            total: self.total,
            bias: self.bias,
            bias_first_order: self.bias_first_order,
        }
    }
}

/// A resolved geometry: the model and its nominal parameter vector.
enum Resolved<'a> {
    Linear(SVector<f64, 14>, GeometryFacts),
    Conic(&'a ConicScanner, SVector<f64, 25>, GeometryFacts),
}

/// Longest range (or height) a budget is computed for: airborne LiDAR ranges are a few km, so a
/// larger value is a unit or typing error, and at 1e300 m the budget would print `inf`.
pub const MAX_RANGE_M: f64 = 100_000.0;

/// Refuses a range or height beyond [`MAX_RANGE_M`].
fn within_reach(name: &str, v: f64) -> Result<()> {
    if v > MAX_RANGE_M {
        return Err(Error::Geometry(format!(
            "{name} {} m is beyond the {MAX_RANGE_M} m an airborne LiDAR reaches (a unit error?)",
            if v < 1e9 {
                format!("{v}")
            } else {
                format!("{v:e}")
            }
        )));
    }
    Ok(())
}

fn resolve<'a>(sensor: &'a Sensor, geometry: &Geometry) -> Result<Resolved<'a>> {
    let m = &sensor.mounting;
    match (&sensor.scanner, geometry) {
        (
            Scanner::Linear,
            Geometry::Linear {
                attitude,
                scan_angle_rad,
                range,
            },
        ) => {
            finite("scan_angle_deg", *scan_angle_rad)?;
            let range_m = match *range {
                LinearRange::Range(r) => {
                    if !(r.is_finite() && r > 0.0) {
                        return Err(lidarqa_model::Error::NotPositive {
                            name: "range_m",
                            value: r,
                        }
                        .into());
                    }
                    r
                }
                LinearRange::Height(h) => {
                    within_reach("height", h)?;
                    linear_range_for_height(attitude, m, *scan_angle_rad, h)?
                }
            };
            within_reach("range", range_m)?;
            let obs = LinearObservation {
                range_m,
                scan_angle_rad: *scan_angle_rad,
            };
            let p = LinearScanner.parameters(attitude, m, &obs);
            let f = LinearScanner.footprint_ned(&p);
            if f.z.is_nan() || f.z <= 0.0 {
                return Err(Error::Geometry(format!(
                    "the ray at scan angle {:.3}° (roll {:.3}°, pitch {:.3}°) does not point down: the footprint would be {:.3} m above the sensor; |scan angle + roll| must stay below 90°",
                    scan_angle_rad.to_degrees(),
                    attitude.roll_rad.to_degrees(),
                    attitude.pitch_rad.to_degrees(),
                    -f.z
                )));
            }
            let facts = GeometryFacts::Linear {
                scan_angle_deg: scan_angle_rad.to_degrees(),
                range_m,
                height_m: f.z,
            };
            Ok(Resolved::Linear(p, facts))
        }
        (
            Scanner::Conic(c),
            Geometry::Conic {
                attitude,
                azimuth_rad,
                ranges,
            },
        ) => {
            finite("azimuth_deg", *azimuth_rad)?;
            let (air_m, water_m) = match *ranges {
                ConicRanges::Ranges { air_m, water_m } => {
                    if !(air_m.is_finite() && air_m > 0.0) {
                        return Err(lidarqa_model::Error::NotPositive {
                            name: "range_air_m",
                            value: air_m,
                        }
                        .into());
                    }
                    if !(water_m.is_finite() && water_m >= 0.0) {
                        return Err(lidarqa_model::Error::NotPositive {
                            name: "range_water_m",
                            value: water_m,
                        }
                        .into());
                    }
                    (air_m, water_m)
                }
                ConicRanges::HeightDepth { height_m, depth_m } => {
                    within_reach("height", height_m)?;
                    within_reach("depth", depth_m)?;
                    c.ranges_for_height_depth(attitude, m, *azimuth_rad, height_m, depth_m)?
                }
            };
            within_reach("air range", air_m)?;
            within_reach("water range", water_m)?;
            let obs = ConicObservation {
                azimuth_rad: *azimuth_rad,
                time_air_s: c.time_air_s(air_m),
                time_water_s: c.time_water_s(water_m),
            };
            let p = c.parameters(attitude, m, &obs);
            let (l3, l4) = c.beam_directions(&p);
            let r_sn = attitude.body_to_ned() * m.scanner_to_body();
            let normal_s = match c.refraction() {
                Refraction::ScannerFrame => Vector3::z(),
                Refraction::Level => r_sn.transpose() * Vector3::z(),
            };
            let angle = |v: &Vector3<f64>| v.dot(&normal_s).clamp(-1.0, 1.0).acos().to_degrees();
            let f = c.footprint_ned(&p);
            if !f.iter().all(|v| v.is_finite()) {
                return Err(Error::NotFinite { what: "footprint" });
            }
            let surface_down = f.z - water_m * (r_sn * l4).z;
            let facts = GeometryFacts::Conic {
                azimuth_deg: azimuth_rad.to_degrees(),
                prism_slope_deg: c.prism_slope_rad().to_degrees(),
                exit_angle_deg: angle(&l3),
                water_angle_deg: angle(&l4),
                range_air_m: air_m,
                range_water_m: water_m,
                time_air_ns: obs.time_air_s * 1e9,
                time_water_ns: obs.time_water_s * 1e9,
                height_m: surface_down,
                depth_m: f.z - surface_down,
            };
            Ok(Resolved::Conic(c, p, facts))
        }
        (s, _) => Err(Error::Geometry(format!(
            "the sensor has a {} scanner but the geometry is for the other kind (use {})",
            s.kind(),
            match s {
                Scanner::Linear => "--scan-angle with --range or --height",
                Scanner::Conic(_) => "--azimuth with --range-air/--range-water or --height/--depth",
                Scanner::Beam(_) =>
                    "a linear or conic sensor: budget and sweep do not take a beam scanner (run `lidarqa tpu` on its points)",
            }
        ))),
    }
}

fn finite(name: &'static str, v: f64) -> Result<()> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(lidarqa_model::Error::NotFinite { name, value: v }.into())
    }
}

fn evaluate_with<G: Georeferencer<N>, const N: usize>(
    g: &G,
    p: &SVector<f64, N>,
    sensor: &Sensor,
    facts: GeometryFacts,
    refraction: Option<&'static str>,
    heading_rad: f64,
    biases: Option<&Biases>,
) -> Result<Evaluation> {
    let cov = sensor.covariance(&G::SOURCES);
    let b = budget(g, p, &cov)?;
    let effect: Option<BiasEffect> = biases
        .map(|bs| bias_effect(g, p, bs, heading_rad))
        .transpose()?;
    Ok(Evaluation {
        scanner: sensor.scanner.kind(),
        refraction,
        footprint: Footprint {
            north: b.footprint_ned.x,
            east: b.footprint_ned.y,
            up: -b.footprint_ned.z,
        },
        geometry: facts,
        sources: b.sources,
        total: b.total,
        bias: effect.map(|e| e.exact),
        bias_first_order: effect.map(|e| e.first_order),
    })
}

/// Evaluate the budget (and the effect of `biases`, if given) of `sensor` at `geometry`.
pub fn evaluate(
    sensor: &Sensor,
    geometry: &Geometry,
    biases: Option<&Biases>,
) -> Result<Evaluation> {
    let heading = geometry.attitude().heading_rad;
    match resolve(sensor, geometry)? {
        Resolved::Linear(p, facts) => {
            evaluate_with(&LinearScanner, &p, sensor, facts, None, heading, biases)
        }
        Resolved::Conic(c, p, facts) => evaluate_with(
            c,
            &p,
            sensor,
            facts,
            Some(c.refraction().name()),
            heading,
            biases,
        ),
    }
}

/// Most Monte Carlo samples [`evaluate_monte_carlo`] draws: the σ it estimates is then within
/// ~0.1 % of its limit (relative error 1/√(2N)), and more samples only cost time.
pub const MAX_MONTE_CARLO_SAMPLES: usize = 1_000_000;

/// Monte Carlo cross-check of [`evaluate`]'s totals at `geometry`.
///
/// # Errors
/// [`Error::Geometry`] for fewer than 2 or more than [`MAX_MONTE_CARLO_SAMPLES`] samples; as
/// [`evaluate`].
pub fn evaluate_monte_carlo(
    sensor: &Sensor,
    geometry: &Geometry,
    samples: usize,
    seed: u64,
) -> Result<MonteCarlo> {
    if !(2..=MAX_MONTE_CARLO_SAMPLES).contains(&samples) {
        return Err(Error::Geometry(format!(
            "{samples} Monte Carlo samples: give 2 to {MAX_MONTE_CARLO_SAMPLES} (σ to ~0.1 % at the most)"
        )));
    }
    match resolve(sensor, geometry)? {
        Resolved::Linear(p, _) => {
            let cov = sensor.covariance(&LinearScanner::SOURCES);
            monte_carlo(&LinearScanner, &p, &cov, samples, seed)
        }
        Resolved::Conic(c, p, _) => {
            let cov = sensor.covariance(&ConicScanner::SOURCES);
            monte_carlo(c, &p, &cov, samples, seed)
        }
    }
}
