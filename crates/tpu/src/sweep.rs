//! Sweeps: the same budget over a range of one geometry variable (scan angle, azimuth, height,
//! depth, …), as Li et al. (2016) Fig. 4 and Zhang & Jiang (2011) Figs. 1–3 plot.

use crate::error::{Error, Result};
use crate::geometry::{ConicRanges, Geometry, LinearRange};
use std::str::FromStr;

/// The variable a sweep runs over.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SweepVariable {
    /// Linear scan angle, degrees.
    ScanAngle,
    /// Conic scan azimuth, degrees.
    Azimuth,
    /// Height above ground / water surface, m.
    Height,
    /// Water depth, m.
    Depth,
    /// Linear slant range, m.
    Range,
    /// Conic air range, m.
    RangeAir,
    /// Conic water range, m.
    RangeWater,
    /// Platform roll, degrees.
    Roll,
    /// Platform pitch, degrees.
    Pitch,
    /// Platform heading, degrees.
    Heading,
}

impl SweepVariable {
    const NAMES: [(&'static str, SweepVariable); 10] = [
        ("scan-angle", SweepVariable::ScanAngle),
        ("azimuth", SweepVariable::Azimuth),
        ("height", SweepVariable::Height),
        ("depth", SweepVariable::Depth),
        ("range", SweepVariable::Range),
        ("range-air", SweepVariable::RangeAir),
        ("range-water", SweepVariable::RangeWater),
        ("roll", SweepVariable::Roll),
        ("pitch", SweepVariable::Pitch),
        ("heading", SweepVariable::Heading),
    ];

    /// The name used on the command line and in JSON (`scan-angle`, `azimuth`, …).
    pub fn name(self) -> &'static str {
        Self::NAMES
            .iter()
            .find(|(_, v)| *v == self)
            .map(|(n, _)| *n)
            .unwrap_or("?")
    }

    /// `"deg"` or `"m"`: the unit of the sweep values.
    pub fn unit(self) -> &'static str {
        match self {
            SweepVariable::ScanAngle
            | SweepVariable::Azimuth
            | SweepVariable::Roll
            | SweepVariable::Pitch
            | SweepVariable::Heading => "deg",
            _ => "m",
        }
    }
}

/// `NAME=START:STOP:STEP`, values in the variable's display unit (degrees or metres), both ends
/// included.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sweep {
    /// The variable.
    pub variable: SweepVariable,
    /// First value.
    pub start: f64,
    /// Last value (included when the steps land on it).
    pub stop: f64,
    /// Step, > 0.
    pub step: f64,
}

/// Most points one sweep may have.
pub const MAX_SWEEP_POINTS: usize = 100_000;

impl FromStr for Sweep {
    type Err = Error;

    fn from_str(spec: &str) -> Result<Sweep> {
        let bad = |reason: String| Error::InvalidSweep {
            spec: spec.to_string(),
            reason,
        };
        let (name, range) = spec
            .split_once('=')
            .ok_or_else(|| bad("expected NAME=START:STOP:STEP".into()))?;
        let variable = SweepVariable::NAMES
            .iter()
            .find(|(n, _)| *n == name.trim())
            .map(|(_, v)| *v)
            .ok_or_else(|| {
                let names: Vec<_> = SweepVariable::NAMES.iter().map(|(n, _)| *n).collect();
                bad(format!(
                    "unknown variable '{name}' (one of {})",
                    names.join(", ")
                ))
            })?;
        let parts: Vec<&str> = range.split(':').collect();
        if parts.len() != 3 {
            return Err(bad("expected START:STOP:STEP".into()));
        }
        let mut nums = [0.0; 3];
        for (slot, text) in nums.iter_mut().zip(&parts) {
            *slot = text
                .trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| bad(format!("'{text}' is not a number")))?;
        }
        let [start, stop, step] = nums;
        if step <= 0.0 {
            return Err(bad(format!("step must be > 0, got {step}")));
        }
        if stop < start {
            return Err(bad(format!("stop {stop} is below start {start}")));
        }
        let sweep = Sweep {
            variable,
            start,
            stop,
            step,
        };
        if sweep.count() > MAX_SWEEP_POINTS {
            return Err(bad(format!(
                "{} points; at most {MAX_SWEEP_POINTS}",
                sweep.count()
            )));
        }
        Ok(sweep)
    }
}

impl Sweep {
    fn count(&self) -> usize {
        ((self.stop - self.start) / self.step + 1e-9).floor() as usize + 1
    }

    /// The values, start to stop inclusive.
    pub fn values(&self) -> Vec<f64> {
        (0..self.count())
            .map(|i| self.start + i as f64 * self.step)
            .collect()
    }

    /// `geometry` with the variable set to `value` (display units).
    pub fn apply(&self, geometry: &Geometry, value: f64) -> Result<Geometry> {
        let mut g = *geometry;
        let wrong = |what: &str| {
            Err(Error::Geometry(format!(
                "cannot sweep {} with {what}",
                self.variable.name()
            )))
        };
        let mut attitude = g.attitude();
        match self.variable {
            SweepVariable::Roll => attitude.roll_rad = value.to_radians(),
            SweepVariable::Pitch => attitude.pitch_rad = value.to_radians(),
            SweepVariable::Heading => attitude.heading_rad = value.to_radians(),
            _ => {}
        }
        g = g.with_attitude(attitude);
        match (&mut g, self.variable) {
            (_, SweepVariable::Roll | SweepVariable::Pitch | SweepVariable::Heading) => {}
            (Geometry::Linear { scan_angle_rad, .. }, SweepVariable::ScanAngle) => {
                *scan_angle_rad = value.to_radians()
            }
            (Geometry::Linear { range, .. }, SweepVariable::Height) => {
                *range = LinearRange::Height(value)
            }
            (Geometry::Linear { range, .. }, SweepVariable::Range) => {
                *range = LinearRange::Range(value)
            }
            (Geometry::Conic { azimuth_rad, .. }, SweepVariable::Azimuth) => {
                *azimuth_rad = value.to_radians()
            }
            (Geometry::Conic { ranges, .. }, SweepVariable::Height | SweepVariable::Depth) => {
                match ranges {
                    ConicRanges::HeightDepth { height_m, depth_m } => {
                        if self.variable == SweepVariable::Height {
                            *height_m = value
                        } else {
                            *depth_m = value
                        }
                    }
                    ConicRanges::Ranges { .. } => {
                        return wrong("ranges; give --height and --depth instead");
                    }
                }
            }
            (
                Geometry::Conic { ranges, .. },
                SweepVariable::RangeAir | SweepVariable::RangeWater,
            ) => match ranges {
                ConicRanges::Ranges { air_m, water_m } => {
                    if self.variable == SweepVariable::RangeAir {
                        *air_m = value
                    } else {
                        *water_m = value
                    }
                }
                ConicRanges::HeightDepth { .. } => {
                    return wrong("height and depth; give --range-air and --range-water instead");
                }
            },
            (Geometry::Linear { .. }, _) => return wrong("a linear scanner"),
            (Geometry::Conic { .. }, _) => return wrong("a conic scanner"),
        }
        Ok(g)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_lists_values() {
        let s: Sweep = "azimuth=0:90:45".parse().unwrap();
        assert_eq!(s.variable, SweepVariable::Azimuth);
        assert_eq!(s.values(), vec![0.0, 45.0, 90.0]);
        let s: Sweep = "scan-angle=-30:30:1".parse().unwrap();
        assert_eq!(s.values().len(), 61);
        assert_eq!(s.values()[60], 30.0);
    }

    #[test]
    fn refuses_bad_specs() {
        for spec in [
            "azimuth",
            "tilt=0:1:1",
            "azimuth=0:90",
            "azimuth=0:x:1",
            "azimuth=0:90:0",
            "azimuth=90:0:1",
            "azimuth=0:1e9:1e-3",
        ] {
            let e = spec.parse::<Sweep>().unwrap_err();
            assert!(e.to_string().contains(spec), "{e}");
        }
    }
}
