//! The checked sensor description that computation crates accept (built from a sensor file by
//! lidarqa-io, or from a preset).

use crate::beam::BeamScanner;
use crate::conic::ConicScanner;
use crate::error::{Error, Result};
use crate::frames::Mounting;
use crate::source::Source;
use nalgebra::{DMatrix, SMatrix};

/// Which scanner the sensor has.
// One per sensor file, built once and borrowed: the conic scanner's cached nominal beam makes
// that variant large, which costs nothing here.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, PartialEq)]
pub enum Scanner {
    /// Linear oscillating-mirror scanner of Zhang et al. (2018): `S = [0, ρ sin θ, ρ cos θ]`.
    Linear,
    /// Constant-angle conic prism scanner of Li et al. (2016).
    Conic(ConicScanner),
    /// A scanner of the beam model (rotating mirror, spinning multi-beam, Risley, elliptical).
    Beam(BeamScanner),
}

impl Scanner {
    /// `"linear"`, `"conic"` or a beam kind's name, as in the sensor file and JSON.
    pub fn kind(&self) -> &'static str {
        match self {
            Scanner::Linear => "linear",
            Scanner::Conic(_) => "conic",
            Scanner::Beam(b) => b.kind.name(),
        }
    }
}

/// 1-sigma of every source, SI units (m, rad, s); a source not given has σ = 0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sigmas {
    values: [f64; Source::COUNT],
}

impl Default for Sigmas {
    fn default() -> Self {
        Sigmas::zero()
    }
}

impl Sigmas {
    /// All sources at σ = 0.
    pub fn zero() -> Sigmas {
        Sigmas {
            values: [0.0; Source::COUNT],
        }
    }

    /// Set the σ of `source` (SI units); refuses a negative or non-finite value.
    pub fn set(&mut self, source: Source, sigma_si: f64) -> Result<()> {
        if !(sigma_si.is_finite() && sigma_si >= 0.0) {
            return Err(Error::InvalidSigma {
                source_name: source.name(),
                value: sigma_si,
            });
        }
        self.values[source.index()] = sigma_si;
        Ok(())
    }

    /// Builder form of [`Sigmas::set`].
    pub fn with(mut self, source: Source, sigma_si: f64) -> Result<Sigmas> {
        self.set(source, sigma_si)?;
        Ok(self)
    }

    /// σ of `source`, SI units.
    pub fn get(&self, source: Source) -> f64 {
        self.values[source.index()]
    }

    /// Sources with σ > 0, in [`Source::ALL`] order.
    pub fn nonzero(&self) -> impl Iterator<Item = (Source, f64)> + '_ {
        Source::ALL
            .iter()
            .map(|s| (*s, self.get(*s)))
            .filter(|(_, v)| *v > 0.0)
    }
}

/// Correlation coefficients between some sources (e.g. from a calibration, SPEC §8); the σ stay in
/// [`Sigmas`], so the matrix is unitless.
#[derive(Debug, Clone, PartialEq)]
pub struct Correlation {
    sources: Vec<Source>,
    matrix: DMatrix<f64>,
}

impl Correlation {
    /// Check and build: square, the size of `sources`, no repeated source, symmetric to 1e-9, unit
    /// diagonal, entries in [−1, 1], positive semi-definite.
    pub fn new(sources: Vec<Source>, matrix: DMatrix<f64>) -> Result<Correlation> {
        let n = sources.len();
        let bad = |m: String| Err(Error::InvalidCorrelation(m));
        if matrix.nrows() != n || matrix.ncols() != n {
            return bad(format!(
                "{} sources but a {}x{} matrix",
                n,
                matrix.nrows(),
                matrix.ncols()
            ));
        }
        for (i, s) in sources.iter().enumerate() {
            if sources[..i].contains(s) {
                return bad(format!("source {s} is listed twice"));
            }
        }
        for i in 0..n {
            if (matrix[(i, i)] - 1.0).abs() > 1e-9 {
                return bad(format!(
                    "diagonal entry for {} is {}, not 1",
                    sources[i],
                    matrix[(i, i)]
                ));
            }
            for j in 0..n {
                let v = matrix[(i, j)];
                if !v.is_finite() || v.abs() > 1.0 + 1e-12 {
                    return bad(format!(
                        "entry ({}, {}) = {v} is outside [-1, 1]",
                        sources[i], sources[j]
                    ));
                }
                if (v - matrix[(j, i)]).abs() > 1e-9 {
                    return bad(format!("not symmetric at ({}, {})", sources[i], sources[j]));
                }
            }
        }
        let min_eig = matrix.clone().symmetric_eigenvalues().min();
        if min_eig < -1e-9 {
            return bad(format!(
                "not positive semi-definite (smallest eigenvalue {min_eig:.3e})"
            ));
        }
        Ok(Correlation { sources, matrix })
    }

    /// The sources the matrix covers, in matrix order.
    pub fn sources(&self) -> &[Source] {
        &self.sources
    }

    /// The correlation matrix.
    pub fn matrix(&self) -> &DMatrix<f64> {
        &self.matrix
    }

    /// Correlation between two sources (1 on the diagonal, 0 when either is not covered).
    pub fn between(&self, a: Source, b: Source) -> f64 {
        if a == b {
            return 1.0;
        }
        let i = self.sources.iter().position(|s| *s == a);
        let j = self.sources.iter().position(|s| *s == b);
        match (i, j) {
            (Some(i), Some(j)) => self.matrix[(i, j)],
            _ => 0.0,
        }
    }
}

/// A checked sensor: scanner geometry, nominal mounting and the a-priori uncertainty of every source.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensor {
    /// Scanner type and its constants.
    pub scanner: Scanner,
    /// Nominal mounting applied when georeferencing.
    pub mounting: Mounting,
    /// 1-sigma of every source, SI.
    pub sigma: Sigmas,
    /// Optional correlations between sources (replaces the diagonal for the sources it names).
    pub correlation: Option<Correlation>,
}

impl Sensor {
    /// Covariance matrix (SI units squared) of the given sources, in their order:
    /// `Σ_ij = ρ_ij σ_i σ_j`.
    pub fn covariance<const N: usize>(&self, sources: &[Source; N]) -> SMatrix<f64, N, N> {
        SMatrix::from_fn(|i, j| {
            let (a, b) = (sources[i], sources[j]);
            let rho = match &self.correlation {
                Some(c) => c.between(a, b),
                None => f64::from(u8::from(a == b)),
            };
            rho * self.sigma.get(a) * self.sigma.get(b)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn negative_sigma_is_refused_with_its_name() {
        let e = Sigmas::zero().with(Source::Range, -0.1).unwrap_err();
        assert_eq!(
            e.to_string(),
            "sigma of range must be a finite number >= 0, got -0.1"
        );
    }

    #[test]
    fn correlation_checks() {
        let s = vec![Source::BoresightRoll, Source::LeverY];
        let ok = DMatrix::from_row_slice(2, 2, &[1.0, 0.5, 0.5, 1.0]);
        assert!(Correlation::new(s.clone(), ok).is_ok());
        let asym = DMatrix::from_row_slice(2, 2, &[1.0, 0.5, 0.4, 1.0]);
        assert!(Correlation::new(s.clone(), asym).is_err());
        let big = DMatrix::from_row_slice(2, 2, &[1.0, 1.5, 1.5, 1.0]);
        assert!(Correlation::new(s, big).is_err());
    }

    #[test]
    fn covariance_uses_correlation() {
        let sigma = Sigmas::zero()
            .with(Source::BoresightRoll, 2.0)
            .unwrap()
            .with(Source::LeverY, 3.0)
            .unwrap();
        let corr = Correlation::new(
            vec![Source::BoresightRoll, Source::LeverY],
            DMatrix::from_row_slice(2, 2, &[1.0, -0.5, -0.5, 1.0]),
        )
        .unwrap();
        let sensor = Sensor {
            scanner: Scanner::Linear,
            mounting: Mounting::default(),
            sigma,
            correlation: Some(corr),
        };
        let c = sensor.covariance(&[Source::BoresightRoll, Source::LeverY, Source::Range]);
        assert_eq!(c[(0, 0)], 4.0);
        assert_eq!(c[(0, 1)], -3.0);
        assert_eq!(c[(1, 1)], 9.0);
        assert_eq!(c[(2, 2)], 0.0);
    }
}
