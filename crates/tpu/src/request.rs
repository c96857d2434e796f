//! A budget request as a user states it (degrees and metres, each value optional, a preset's
//! geometry as the default) turned into the [`Geometry`] that [`evaluate`] takes, and a sweep
//! evaluated point by point: the work behind `lidarqa budget`, here so that it is tested and
//! reachable without the binary.

use crate::bias::Biases;
use crate::error::{Error, Result};
use crate::geometry::{ConicRanges, Evaluation, Geometry, GeometryFacts, LinearRange, evaluate};
use crate::sweep::{Sweep, SweepVariable};
use lidarqa_model::{Attitude, Scanner, Sensor};
use lidarqa_products::{BudgetSweep, BudgetSweepPoint};

/// The observation geometry as asked for: every value optional (degrees and metres, as typed);
/// what is not given comes from the preset's geometry, else level flight heading north, scan
/// angle 0 (linear) or azimuth 0 (conic).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct GeometryRequest {
    /// Platform heading, degrees.
    pub heading_deg: Option<f64>,
    /// Platform pitch, degrees (nose up positive).
    pub pitch_deg: Option<f64>,
    /// Platform roll, degrees (right wing down positive).
    pub roll_deg: Option<f64>,
    /// Linear scanner: scan angle, degrees, positive towards the right wing.
    pub scan_angle_deg: Option<f64>,
    /// Linear scanner: slant range, metres.
    pub range_m: Option<f64>,
    /// Height above level ground (conic: above the water surface), metres.
    pub height_m: Option<f64>,
    /// Conic scanner: scan azimuth, degrees.
    pub azimuth_deg: Option<f64>,
    /// Conic scanner: range in air, metres (with `range_water_m`).
    pub range_air_m: Option<f64>,
    /// Conic scanner: range in water, metres (with `range_air_m`).
    pub range_water_m: Option<f64>,
    /// Conic scanner: water depth below the surface, metres (with `height_m`).
    pub depth_m: Option<f64>,
}

impl GeometryRequest {
    /// The geometry for `sensor`, defaults from `preset` (a preset's own geometry). For a height or
    /// depth `sweep` of a conic preset given by its ranges, the geometry starts from the preset's
    /// own height above the water and depth (Li et al. 2016, §3 (3): at a fixed flying height the
    /// budget is a function of depth).
    ///
    /// # Errors
    /// A value of the other scanner type, a missing range, or a geometry the model refuses.
    pub fn resolve(
        &self,
        sensor: &Sensor,
        preset: Option<Geometry>,
        sweep: Option<&Sweep>,
    ) -> Result<Geometry> {
        let base_attitude = preset.map(|g| g.attitude()).unwrap_or_default();
        let attitude = Attitude {
            roll_rad: self
                .roll_deg
                .map_or(base_attitude.roll_rad, f64::to_radians),
            pitch_rad: self
                .pitch_deg
                .map_or(base_attitude.pitch_rad, f64::to_radians),
            heading_rad: self
                .heading_deg
                .map_or(base_attitude.heading_rad, f64::to_radians),
        };
        let geometry = match &sensor.scanner {
            Scanner::Beam(b) => {
                return Err(Error::Geometry(format!(
                    "budget and sweep take a linear or conic scanner, not a {} scanner: for its σ run `lidarqa tpu` on its points, or `lidarqa simulate` a scenario with this sensor and `lidarqa tpu` on the strip",
                    b.kind.name()
                )));
            }
            Scanner::Linear => {
                for (flag, given) in [
                    ("--azimuth", self.azimuth_deg.is_some()),
                    ("--range-air", self.range_air_m.is_some()),
                    ("--range-water", self.range_water_m.is_some()),
                    ("--depth", self.depth_m.is_some()),
                ] {
                    if given {
                        return Err(Error::Geometry(format!(
                            "{flag} is for a conic scanner; this sensor is linear (use --scan-angle with --range or --height)"
                        )));
                    }
                }
                let (base_scan, base_range) = match preset {
                    Some(Geometry::Linear {
                        scan_angle_rad,
                        range,
                        ..
                    }) => (scan_angle_rad, Some(range)),
                    _ => (0.0, None),
                };
                let range = match (self.range_m, self.height_m, base_range) {
                    (Some(r), _, _) => LinearRange::Range(r),
                    (None, Some(h), _) => LinearRange::Height(h),
                    (None, None, Some(r)) => r,
                    (None, None, None) => {
                        return Err(Error::Geometry("give --range M or --height M".into()));
                    }
                };
                Geometry::Linear {
                    attitude,
                    scan_angle_rad: self.scan_angle_deg.map_or(base_scan, f64::to_radians),
                    range,
                }
            }
            Scanner::Conic(_) => {
                if self.scan_angle_deg.is_some() || self.range_m.is_some() {
                    return Err(Error::Geometry(
                        "--scan-angle and --range are for a linear scanner; this sensor is conic (use --azimuth with --range-air/--range-water or --height/--depth)".into(),
                    ));
                }
                let (base_az, base_ranges) = match preset {
                    Some(Geometry::Conic {
                        azimuth_rad,
                        ranges,
                        ..
                    }) => (azimuth_rad, Some(ranges)),
                    _ => (0.0, None),
                };
                let ranges = match (
                    self.range_air_m,
                    self.range_water_m,
                    self.height_m,
                    base_ranges,
                ) {
                    (Some(air_m), Some(water_m), _, _) => ConicRanges::Ranges { air_m, water_m },
                    (_, _, Some(height_m), _) => ConicRanges::HeightDepth {
                        height_m,
                        depth_m: self.depth_m.unwrap_or(0.0),
                    },
                    (_, _, None, Some(r)) => r,
                    _ => {
                        return Err(Error::Geometry(
                            "give --range-air M --range-water M, or --height M [--depth M]".into(),
                        ));
                    }
                };
                Geometry::Conic {
                    attitude,
                    azimuth_rad: self.azimuth_deg.map_or(base_az, f64::to_radians),
                    ranges,
                }
            }
        };
        Ok(match (sweep, geometry) {
            (
                Some(Sweep {
                    variable: SweepVariable::Height | SweepVariable::Depth,
                    ..
                }),
                Geometry::Conic {
                    attitude,
                    azimuth_rad,
                    ranges: ConicRanges::Ranges { .. },
                },
            ) if self.range_air_m.is_none() => match evaluate(sensor, &geometry, None)?.geometry {
                GeometryFacts::Conic {
                    height_m, depth_m, ..
                } => Geometry::Conic {
                    attitude,
                    azimuth_rad,
                    ranges: ConicRanges::HeightDepth { height_m, depth_m },
                },
                GeometryFacts::Linear { .. } => geometry,
            },
            (_, g) => g,
        })
    }
}

/// One value of a sweep and the budget there.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepPoint {
    /// The swept variable's value, in the sweep's unit (degrees or metres).
    pub at: f64,
    /// The budget at `at`.
    pub evaluation: Evaluation,
}

/// The budget over a sweep: its JSON ([`SweepEvaluation::to_sweep`]) is
/// `lidarqa budget --sweep … --format json`'s (`{"sweep", "unit", "points": [{"at",
/// …budget…}]}`, SPEC §6).
#[derive(Debug, Clone, PartialEq)]
pub struct SweepEvaluation {
    /// The swept variable (`scan-angle`, `azimuth`, `depth`, …).
    pub sweep: &'static str,
    /// Unit of `at` (`deg` or `m`).
    pub unit: &'static str,
    /// The budgets, in sweep order.
    pub points: Vec<SweepPoint>,
}

impl SweepEvaluation {
    /// The sweep as `lidarqa budget --sweep … --format json` writes it.
    pub fn to_sweep(&self) -> BudgetSweep {
        BudgetSweep {
            sweep: self.sweep.to_string(),
            unit: self.unit.to_string(),
            points: self
                .points
                .iter()
                .map(|p| BudgetSweepPoint {
                    at: p.at,
                    budget: p.evaluation.to_budget(),
                })
                .collect(),
        }
    }
}

/// The budget at every value of `sweep` from `geometry`, in order.
///
/// # Errors
/// The first value whose geometry cannot be evaluated, naming the variable and the value.
pub fn evaluate_sweep(
    sensor: &Sensor,
    geometry: &Geometry,
    sweep: &Sweep,
    biases: Option<&Biases>,
) -> Result<SweepEvaluation> {
    let mut points = Vec::new();
    for at in sweep.values() {
        let g = sweep.apply(geometry, at)?;
        let evaluation = evaluate(sensor, &g, biases)
            .map_err(|e| Error::Geometry(format!("{} = {at}: {e}", sweep.variable.name())))?;
        points.push(SweepPoint { at, evaluation });
    }
    Ok(SweepEvaluation {
        sweep: sweep.variable.name(),
        unit: sweep.variable.unit(),
        points,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::presets::Preset;

    #[test]
    fn scan_angle_is_degrees_and_overrides_the_preset() {
        let request = GeometryRequest {
            scan_angle_deg: Some(-12.5),
            height_m: Some(500.0),
            ..GeometryRequest::default()
        };
        let p = Preset::Zhang2018;
        match request
            .resolve(&p.sensor(), Some(p.geometry()), None)
            .unwrap()
        {
            Geometry::Linear {
                scan_angle_rad,
                range,
                ..
            } => {
                assert!((scan_angle_rad - (-12.5f64).to_radians()).abs() < 1e-15);
                assert_eq!(range, LinearRange::Height(500.0));
            }
            _ => panic!("linear expected"),
        }
    }

    #[test]
    fn conic_height_without_depth_is_a_surface_point() {
        let request = GeometryRequest {
            height_m: Some(400.0),
            ..GeometryRequest::default()
        };
        let p = Preset::Czmil;
        let g = request
            .resolve(&p.sensor(), Some(p.geometry()), None)
            .unwrap();
        assert!(matches!(
            g,
            Geometry::Conic {
                ranges: ConicRanges::HeightDepth { depth_m, .. },
                ..
            } if depth_m == 0.0
        ));
    }

    #[test]
    fn values_of_the_other_scanner_are_refused() {
        let czmil = Preset::Czmil;
        let e = GeometryRequest {
            scan_angle_deg: Some(10.0),
            ..GeometryRequest::default()
        }
        .resolve(&czmil.sensor(), Some(czmil.geometry()), None)
        .unwrap_err();
        assert!(e.to_string().contains("linear scanner"), "{e}");
        let zhang2018 = Preset::Zhang2018;
        let e = GeometryRequest {
            azimuth_deg: Some(10.0),
            ..GeometryRequest::default()
        }
        .resolve(&zhang2018.sensor(), Some(zhang2018.geometry()), None)
        .unwrap_err();
        assert!(e.to_string().contains("conic scanner"), "{e}");
    }
}
