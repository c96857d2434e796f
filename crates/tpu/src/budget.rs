//! Linear error propagation through a [`Georeferencer`], with exact Jacobians from dual numbers.
//!
//! Per source (SPEC §6): `|∂P/∂p_i| · σ_i` per axis. Total: `√diag(J Σ Jᵀ)`, which is the
//! root-sum-square of the per-source values when `Σ` is diagonal.

use crate::axes::Axes;
use crate::error::{Error, Result};
use lidarqa_model::{Georeferencer, Source};
use lidarqa_products::BudgetSource;
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

/// One source's share of the budget.
#[derive(Debug, Clone, PartialEq)]
pub struct SourceTerm {
    /// The source.
    pub source: Source,
    /// Its 1-sigma, SI units (`unit`).
    pub sigma_si: f64,
    /// `m`, `rad` or `s`.
    pub unit: &'static str,
    /// ∂(footprint NED)/∂p, metres per SI unit of the source.
    pub partial_ned: Vector3<f64>,
    /// `|∂P/∂p| · σ` per axis, metres.
    pub effect: Axes,
}

impl SourceTerm {
    /// Its entry in the budget's `sources` (the source by its snake_case name).
    pub fn to_budget_source(&self) -> BudgetSource {
        BudgetSource {
            name: self.source.name().to_string(),
            sigma: self.sigma_si,
            unit: self.unit.to_string(),
            effect: self.effect,
        }
    }
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
