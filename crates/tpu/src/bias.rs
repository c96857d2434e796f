//! Systematic errors: what a given boresight, lever-arm or other bias does to a point
//! (Zhang & Jiang 2011, §2.1).
//!
//! The exact displacement re-georeferences with and without the bias; the first-order one is
//! `J · b`. Both are reported so a user sees where linearisation stops being good enough.

use crate::axes::{Displacement, displacement_from_ned};
use crate::budget::footprint_jacobian;
use crate::error::{Error, Result};
use lidarqa_model::{Georeferencer, Source};
use nalgebra::SVector;
use serde::Serialize;

/// `KEY=VALUE,...` with sensor-file `[sigma]` keys and their units (`boresight_roll_deg=0.1,
/// lever_x_m=-0.05,time_water_ns=1`), converted to SI; each key at most once.
impl std::str::FromStr for Biases {
    type Err = Error;

    fn from_str(text: &str) -> Result<Biases> {
        let mut biases = Biases::default();
        let mut seen: Vec<Source> = Vec::new();
        for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let (key, value) = item
                .split_once('=')
                .ok_or_else(|| Error::InvalidBias(format!("'{item}' is not KEY=VALUE")))?;
            let key = key.trim();
            let source = Source::from_config_key(key).ok_or_else(|| {
                Error::InvalidBias(format!(
                    "unknown key '{key}' (a [sigma] key with its unit, e.g. boresight_roll_deg, lever_x_m)"
                ))
            })?;
            let value: f64 = value
                .trim()
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite())
                .ok_or_else(|| {
                    Error::InvalidBias(format!("{key} = '{}' is not a number", value.trim()))
                })?;
            if seen.contains(&source) {
                return Err(Error::InvalidBias(format!(
                    "{key} is given twice; give each key once"
                )));
            }
            seen.push(source);
            biases.set(source, value * source.unit().config_to_si())?;
        }
        Ok(biases)
    }
}

/// Signed systematic errors of any sources, SI units (m, rad, s); unset sources are 0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Biases {
    values: [f64; Source::COUNT],
}

impl Default for Biases {
    fn default() -> Self {
        Biases {
            values: [0.0; Source::COUNT],
        }
    }
}

impl Biases {
    /// Set the bias of `source` (SI units); refuses a non-finite value.
    pub fn set(&mut self, source: Source, value_si: f64) -> Result<()> {
        if !value_si.is_finite() {
            return Err(Error::Geometry(format!(
                "bias of {source} must be a finite number, got {value_si}"
            )));
        }
        self.values[source.index()] = value_si;
        Ok(())
    }

    /// Bias of `source`, SI units.
    pub fn get(&self, source: Source) -> f64 {
        self.values[source.index()]
    }

    /// Sources with a non-zero bias.
    pub fn nonzero(&self) -> impl Iterator<Item = (Source, f64)> + '_ {
        Source::ALL
            .iter()
            .map(|s| (*s, self.get(*s)))
            .filter(|(_, v)| *v != 0.0)
    }

    /// The bias vector in the order of `sources`.
    pub fn vector<const N: usize>(&self, sources: &[Source; N]) -> SVector<f64, N> {
        SVector::from_fn(|i, _| self.get(sources[i]))
    }
}

/// The displacement (lidar − true) that a set of biases causes at one footprint.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BiasEffect {
    /// `f(p + b) − f(p)`, exact.
    pub exact: Displacement,
    /// `J · b`, to first order.
    pub first_order: Displacement,
}

/// Displacement caused by `biases` at parameters `p`; `heading_rad` orients along/across track.
///
/// Biases on sources that the model does not have are an error (e.g. `time_water` on a linear
/// scanner), never silently ignored.
pub fn bias_effect<G: Georeferencer<N>, const N: usize>(
    g: &G,
    p: &SVector<f64, N>,
    biases: &Biases,
    heading_rad: f64,
) -> Result<BiasEffect> {
    if let Some((s, _)) = biases.nonzero().find(|(s, _)| !G::SOURCES.contains(s)) {
        return Err(Error::Geometry(format!(
            "bias on {s}, which this scanner does not have"
        )));
    }
    let b = biases.vector(&G::SOURCES);
    let (nominal, j) = footprint_jacobian(g, p);
    let exact = g.footprint_ned(&(p + b)) - nominal;
    let first = j * b;
    if !(exact.iter().all(|v| v.is_finite())) {
        return Err(Error::NotFinite {
            what: "the biased footprint",
        });
    }
    Ok(BiasEffect {
        exact: displacement_from_ned(&exact, heading_rad),
        first_order: displacement_from_ned(&first, heading_rad),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bias_keys_carry_units() {
        let b: Biases = "boresight_roll_deg=0.1, lever_x_m=-0.05,time_water_ns=1"
            .parse()
            .unwrap();
        assert!((b.get(Source::BoresightRoll) - 0.1f64.to_radians()).abs() < 1e-18);
        assert_eq!(b.get(Source::LeverX), -0.05);
        assert!((b.get(Source::TimeWater) - 1e-9).abs() < 1e-24);
        let e = "boresight_roll=0.1"
            .parse::<Biases>()
            .unwrap_err()
            .to_string();
        assert!(e.contains("unknown key 'boresight_roll'"), "{e}");
        let e = "lever_x_m=1,lever_x_m=2"
            .parse::<Biases>()
            .unwrap_err()
            .to_string();
        assert!(e.contains("given twice"), "{e}");
    }
}
