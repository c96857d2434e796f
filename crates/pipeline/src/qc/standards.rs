//! The standards a delivery is judged by: USGS quality levels and their limits, the
//! `--standard` names, and the documents they cite.

use super::*;

/// A USGS quality level.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum QualityLevel {
    /// QL0.
    Ql0,
    /// QL1.
    Ql1,
    /// QL2.
    Ql2,
    /// QL3.
    Ql3,
}

/// The USGS Lidar Base Specification's numbers for one quality level (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QlLimits {
    /// Intraswath smooth-surface repeatability (max diff), m.
    pub intraswath_m: f64,
    /// Swath overlap RMSDz, m.
    pub rmsdz_m: f64,
    /// Swath overlap max |dz|, m.
    pub max_dz_m: f64,
    /// NVA RMSEz, m.
    pub nva_rmse_m: f64,
    /// Aggregate nominal pulse density, pulses per m².
    pub anpd_per_m2: f64,
    /// Aggregate nominal pulse spacing, m.
    pub anps_m: f64,
}

impl QualityLevel {
    /// The limits (module docs).
    pub fn limits(self) -> QlLimits {
        let l = |intraswath_m, rmsdz_m, max_dz_m, nva_rmse_m, anpd_per_m2, anps_m| QlLimits {
            intraswath_m,
            rmsdz_m,
            max_dz_m,
            nva_rmse_m,
            anpd_per_m2,
            anps_m,
        };
        match self {
            QualityLevel::Ql0 => l(0.03, 0.04, 0.08, 0.05, 8.0, 0.35),
            QualityLevel::Ql1 => l(0.06, 0.08, 0.16, 0.10, 8.0, 0.35),
            QualityLevel::Ql2 => l(0.06, 0.08, 0.16, 0.10, 2.0, 0.71),
            QualityLevel::Ql3 => l(0.12, 0.16, 0.32, 0.20, 0.5, 1.41),
        }
    }

    pub(super) fn name(self) -> &'static str {
        match self {
            QualityLevel::Ql0 => "QL0",
            QualityLevel::Ql1 => "QL1",
            QualityLevel::Ql2 => "QL2",
            QualityLevel::Ql3 => "QL3",
        }
    }
}

/// A standard to judge the delivery by.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Standard {
    /// USGS Lidar Base Specification (2024), at a quality level.
    UsgsLbs2024(QualityLevel),
    /// ASPRS Positional Accuracy Standards, Edition 2 (2023), vertical accuracy class (RMSEz, m);
    /// `None`: the USGS quality level's NVA RMSEz, or 10 cm.
    Asprs2023(Option<f64>),
    /// IHO S-44 Edition 6 (2020), an order.
    IhoS44(lidarqa_tpu::IhoOrder),
}

impl FromStr for Standard {
    type Err = Error;

    /// `usgs-lbs-2024:QL0…QL3`, `asprs-2023` or `asprs-2023:<class cm>`,
    /// `iho-s44:exclusive|special|1a|1b|2`.
    fn from_str(s: &str) -> Result<Self> {
        let bad = |why: &str| {
            Error::InvalidOption(format!(
                "standard `{s}`: {why} (usgs-lbs-2024:QL0…QL3, asprs-2023[:<class cm>], \
                 iho-s44:exclusive|special|1a|1b|2)"
            ))
        };
        let (name, arg) = s.split_once(':').map_or((s, None), |(a, b)| (a, Some(b)));
        match name.to_ascii_lowercase().as_str() {
            "usgs-lbs-2024" | "usgs-lbs" | "usgs" => {
                let ql = match arg.map(str::to_ascii_uppercase).as_deref() {
                    Some("QL0") => QualityLevel::Ql0,
                    Some("QL1") => QualityLevel::Ql1,
                    Some("QL2") | None => QualityLevel::Ql2,
                    Some("QL3") => QualityLevel::Ql3,
                    Some(_) => return Err(bad("unknown quality level")),
                };
                Ok(Standard::UsgsLbs2024(ql))
            }
            "asprs-2023" | "asprs" => match arg {
                None => Ok(Standard::Asprs2023(None)),
                Some(a) => {
                    let cm: f64 = a
                        .trim_end_matches("cm")
                        .parse()
                        .map_err(|_| bad("the class is a number of centimetres"))?;
                    if !(cm.is_finite() && cm > 0.0) {
                        return Err(bad("the class is a number of centimetres > 0"));
                    }
                    Ok(Standard::Asprs2023(Some(cm / 100.0)))
                }
            },
            "iho-s44" | "iho" => {
                use lidarqa_tpu::IhoOrder::*;
                let o = match arg.map(str::to_ascii_lowercase).as_deref() {
                    Some("exclusive") => Exclusive,
                    Some("special") => Special,
                    Some("1a") | None => Order1a,
                    Some("1b") => Order1b,
                    Some("2") => Order2,
                    Some(_) => return Err(bad("unknown order")),
                };
                Ok(Standard::IhoS44(o))
            }
            _ => Err(bad("unknown standard")),
        }
    }
}

impl Standard {
    pub(super) fn label(&self) -> String {
        match self {
            Standard::UsgsLbs2024(q) => format!("usgs-lbs-2024:{}", q.name()),
            Standard::Asprs2023(None) => "asprs-2023".into(),
            Standard::Asprs2023(Some(c)) => format!("asprs-2023:{}cm", c * 100.0),
            Standard::IhoS44(o) => format!("iho-s44:{}", o.name()),
        }
    }
}

pub(super) const USGS_CITATION: &str = "U.S. Geological Survey, Lidar Base Specification (Techniques and Methods 11-B4), 2024 revision: relative vertical accuracy, absolute vertical accuracy and nominal pulse density tables";
pub(super) const ASPRS_CITATION: &str = "ASPRS Positional Accuracy Standards for Digital Geospatial Data, Edition 2, Version 1.0 (2023): vertical accuracy of elevation data";
pub(super) const IHO_CITATION: &str = "IHO S-44 Standards for Hydrographic Surveys, Edition 6.0.0 (2020): Table 1 (minimum bathymetry standards) and §2.7 (95 % confidence: 1.96 σ in depth, 2.45 σ in position)";
