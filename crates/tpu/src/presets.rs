//! Built-in sensors and geometries from the source papers (`lidarqa budget --preset`): `zhang2018`
//! (Zhang et al. 2018, ISPRS Archives) and `czmil` (Li et al. 2016, Acta Geodaetica et
//! Cartographica Sinica).

use crate::geometry::{ConicRanges, Geometry, LinearRange};
use lidarqa_model::{
    Attitude, ConicScanner, DEFAULT_N_AIR, DEFAULT_N_PRISM, DEFAULT_N_WATER, Mounting, Refraction,
    Scanner, Sensor, Sigmas, Source,
};

/// A named preset.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Preset {
    /// Zhang et al. (2018), Table 1 σ; linear scanner; scan angle 30°, range 80/cos 30° m.
    /// Named `zhang2018` on the command line (formerly `seed000`, still accepted).
    Zhang2018,
    /// Li et al. (2016), Table 3 σ; conic scanner, exit angle 20°, scanner-frame refraction; azimuth 0,
    /// ρ1 = 425.7 m, ρ2 = 51.7 m.
    Czmil,
}

impl Preset {
    /// Every preset.
    pub const ALL: [Preset; 2] = [Preset::Zhang2018, Preset::Czmil];

    /// The preset's name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Preset::Zhang2018 => "zhang2018",
            Preset::Czmil => "czmil",
        }
    }

    /// Look a preset up by name; a former name ([`Preset::deprecated_alias`]) is accepted too.
    pub fn from_name(name: &str) -> Option<Preset> {
        Preset::ALL
            .into_iter()
            .find(|p| p.name() == name)
            .or_else(|| Preset::deprecated_alias(name))
    }

    /// The preset a former name stands for, so that scripts written for it keep working: the
    /// caller says the name is deprecated (this library does not print).
    pub fn deprecated_alias(name: &str) -> Option<Preset> {
        match name {
            "seed000" => Some(Preset::Zhang2018),
            _ => None,
        }
    }

    /// The preset's sensor.
    pub fn sensor(self) -> Sensor {
        let deg = |d: f64| d.to_radians();
        let table: &[(Source, f64)] = match self {
            Preset::Zhang2018 => &[
                (Source::Range, 0.005),
                (Source::ScanAngle, deg(0.0028)),
                (Source::Heading, deg(0.008)),
                (Source::Pitch, deg(0.005)),
                (Source::Roll, deg(0.005)),
                (Source::BoresightYaw, deg(0.01)),
                (Source::BoresightPitch, deg(0.008)),
                (Source::BoresightRoll, deg(0.008)),
                (Source::LeverX, 0.001),
                (Source::LeverY, 0.001),
                (Source::LeverZ, 0.001),
                (Source::GnssNorth, 0.05),
                (Source::GnssEast, 0.05),
                (Source::GnssUp, 0.10),
            ],
            Preset::Czmil => &[
                (Source::GnssNorth, 0.05),
                (Source::GnssEast, 0.05),
                (Source::GnssUp, 0.075),
                (Source::Roll, deg(0.0025)),
                (Source::Pitch, deg(0.0025)),
                (Source::Heading, deg(0.005)),
                (Source::BoresightRoll, deg(0.0028)),
                (Source::BoresightPitch, deg(0.0028)),
                (Source::BoresightYaw, deg(0.0083)),
                (Source::ScanAzimuth, deg(0.005)),
                (Source::PrismSlope, deg(0.005)),
                (Source::PrismX, deg(0.005)),
                (Source::PrismY, deg(0.005)),
                (Source::PrismZ, deg(0.005)),
                (Source::EmitterZenith, deg(0.005)),
                (Source::EmitterAzimuth, deg(0.005)),
                (Source::TimeAir, 0.1e-9),
                (Source::TimeWater, 0.9e-9),
            ],
        };
        let mut sigma = Sigmas::zero();
        for (s, v) in table {
            sigma
                .set(*s, *v)
                .expect("preset sigmas are finite and non-negative");
        }
        let scanner = match self {
            Preset::Zhang2018 => Scanner::Linear,
            Preset::Czmil => Scanner::Conic(
                ConicScanner::from_exit_angle(
                    20f64.to_radians(),
                    DEFAULT_N_PRISM,
                    DEFAULT_N_AIR,
                    DEFAULT_N_WATER,
                    Refraction::ScannerFrame,
                )
                .expect("a 20° exit angle is reachable"),
            ),
        };
        Sensor {
            scanner,
            mounting: Mounting::default(),
            sigma,
            correlation: None,
        }
    }

    /// The preset's geometry (level flight).
    pub fn geometry(self) -> Geometry {
        match self {
            Preset::Zhang2018 => Geometry::Linear {
                attitude: Attitude::default(),
                scan_angle_rad: 30f64.to_radians(),
                range: LinearRange::Range(80.0 / 30f64.to_radians().cos()),
            },
            Preset::Czmil => Geometry::Conic {
                attitude: Attitude::default(),
                azimuth_rad: 0.0,
                ranges: ConicRanges::Ranges {
                    air_m: 425.7,
                    water_m: 51.7,
                },
            },
        }
    }
}
