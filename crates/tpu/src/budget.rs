//! Linear error propagation through a [`Georeferencer`], with exact Jacobians from dual numbers.
//!
//! Per source (SPEC §6): `|∂P/∂p_i| · σ_i` per axis. Total: `√diag(J Σ Jᵀ)`, which is the
//! root-sum-square of the per-source values when `Σ` is diagonal.

use crate::axes::Axes;
use crate::error::{Error, Result};
use lidarqa_model::{Georeferencer, Source};
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};
use serde::Serialize;

/// One source's share of the budget.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SourceTerm {
    /// The source (serialised as its snake_case name).
    #[serde(rename = "name", serialize_with = "serialize_source")]
    pub source: Source,
    /// Its 1-sigma, SI units (`unit`).
    #[serde(rename = "sigma")]
    pub sigma_si: f64,
    /// `m`, `rad` or `s`.
    pub unit: &'static str,
    /// ∂(footprint NED)/∂p, metres per SI unit of the source.
    #[serde(skip)]
    pub partial_ned: Vector3<f64>,
    /// `|∂P/∂p| · σ` per axis, metres.
    #[serde(flatten)]
    pub effect: Axes,
}

fn serialize_source<S: serde::Serializer>(
    s: &Source,
    ser: S,
) -> std::result::Result<S::Ok, S::Error> {
    ser.serialize_str(s.name())
}

/// The propagated uncertainty of one footprint.
#[derive(Debug, Clone, PartialEq)]
pub struct Budget {
    /// Footprint relative to the GNSS/INS reference point, NED metres.
    pub footprint_ned: Vector3<f64>,
    /// Every source of the model, in the model's order.
    pub sources: Vec<SourceTerm>,
    /// `J Σ Jᵀ`, NED, m².
    pub covariance_ned: Matrix3<f64>,
    /// √diag of [`Budget::covariance_ned`], per axis.
    pub total: Axes,
}

/// Footprint (NED, m) and its exact Jacobian (m per SI unit) at parameters `p`.
pub fn footprint_jacobian<G: Georeferencer<N>, const N: usize>(
    g: &G,
    p: &SVector<f64, N>,
) -> (Vector3<f64>, SMatrix<f64, 3, N>) {
    g.footprint_jacobian(p)
}

/// `J Σ Jᵀ`: the NED covariance (m²) of the footprint from the parameter covariance.
pub fn propagate_covariance<const N: usize>(
    j: &SMatrix<f64, 3, N>,
    cov: &SMatrix<f64, N, N>,
) -> Matrix3<f64> {
    j * cov * j.transpose()
}

/// The full budget at parameters `p` with parameter covariance `cov` (SI units squared, in
/// `G::SOURCES` order).
pub fn budget<G: Georeferencer<N>, const N: usize>(
    g: &G,
    p: &SVector<f64, N>,
    cov: &SMatrix<f64, N, N>,
) -> Result<Budget> {
    let (footprint_ned, j) = footprint_jacobian(g, p);
    if !(footprint_ned.iter().all(|v| v.is_finite()) && j.iter().all(|v| v.is_finite())) {
        return Err(Error::NotFinite {
            what: "footprint or its Jacobian",
        });
    }
    let sources = G::SOURCES
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let sigma_si = cov[(i, i)].max(0.0).sqrt();
            let partial_ned: Vector3<f64> = j.column(i).into();
            let e = partial_ned * sigma_si;
            SourceTerm {
                source: *s,
                sigma_si,
                unit: s.unit().si_symbol(),
                partial_ned,
                effect: Axes::from_magnitudes(e.x, e.y, e.z),
            }
        })
        .collect();
    let covariance_ned = propagate_covariance(&j, cov);
    Ok(Budget {
        footprint_ned,
        sources,
        total: Axes::from_ned_covariance(&covariance_ned),
        covariance_ned,
    })
}
