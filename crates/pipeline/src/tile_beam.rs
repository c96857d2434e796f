//! The per-point TPU of a beam scanner's return inside a tile (called from `tile.rs`): the
//! range, encoder angles and channel recovered from the point ([`lidarqa_tpu::Recoverer::beam`])
//! and propagated through the beam model ([`lidarqa_tpu::BeamPropagator`]), the trajectory's σ
//! and the incidence term as for the linear scanner.

use lidarqa_model::{BEAM_N, BeamScanner, Georeferencer, Mounting};
use lidarqa_tpu::{
    BEAM_FOOTPRINT_SOURCE, BeamPropagator, BeamRecovery, Incidence, PoseAt, PoseSigma,
};
use nalgebra::Matrix3;

/// The per-source share names: the beam model's sixteen, the footprint, the incidence term.
pub(crate) fn source_names() -> Vec<&'static str> {
    <BeamScanner as Georeferencer<BEAM_N>>::SOURCES
        .iter()
        .map(|s| s.name())
        .chain([BEAM_FOOTPRINT_SOURCE])
        .collect()
}

/// The covariance (N at P0, m²) of the recovered return and each term's variance in the order
/// of [`source_names`] plus the incidence term's.
pub(crate) fn propagate(
    propagator: &BeamPropagator,
    pose: &PoseAt,
    mounting: &Mounting,
    recovery: &BeamRecovery,
    sigma: Option<&PoseSigma>,
    incidence: Option<&Incidence>,
) -> lidarqa_tpu::Result<(Matrix3<f64>, [f64; BEAM_N + 2])> {
    let u = propagator.propagate(
        &pose.attitude(),
        mounting,
        &recovery.inversion,
        sigma,
        incidence,
    )?;
    let mut shares = [0.0; BEAM_N + 2];
    shares[..BEAM_N].copy_from_slice(u.source_variance_m2.as_slice());
    shares[BEAM_N] = u.footprint_variance_m2;
    shares[BEAM_N + 1] = u.incidence_variance_m2;
    Ok((u.covariance_ned, shares))
}
