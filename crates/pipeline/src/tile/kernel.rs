//! The georeferencing model of the tile's scanner with its propagator.

use super::*;

/// The georeferencing model with its propagator.
// One per tile, built once and borrowed: the size difference costs nothing.
#[allow(clippy::large_enum_variant)]
pub(super) enum Kernel {
    Linear(PointPropagator<LinearScanner, 14>),
    Conic(PointPropagator<ConicScanner, 25>, ConicScanner),
    /// A beam scanner.
    Beam(BeamPropagator),
}

impl Kernel {
    pub(super) fn new(ctx: &TpuContext) -> Result<Kernel> {
        let bad = |source| Error::Input {
            path: ctx.trajectory_path.clone(),
            source,
        };
        Ok(match &ctx.sensor.scanner {
            Scanner::Linear => Kernel::Linear(
                PointPropagator::new(LinearScanner, &ctx.sensor, ctx.beam_divergence_rad)
                    .map_err(bad)?,
            ),
            Scanner::Conic(c) => Kernel::Conic(
                PointPropagator::new(*c, &ctx.sensor, ctx.beam_divergence_rad).map_err(bad)?,
                *c,
            ),
            Scanner::Beam(b) => Kernel::Beam(
                BeamPropagator::new(b.clone(), &ctx.sensor, ctx.beam_divergence_rad)
                    .map_err(bad)?,
            ),
        })
    }
    pub(super) fn kind(&self) -> &'static str {
        match self {
            Kernel::Linear(_) => "linear",
            Kernel::Conic(..) => "conic",
            Kernel::Beam(b) => b.scanner().kind.name(),
        }
    }
    pub(super) fn n_sigma(&self) -> usize {
        match self {
            Kernel::Linear(_) | Kernel::Beam(_) => 5,
            Kernel::Conic(..) => 7,
        }
    }
    /// σ columns plus, for conic sensors, `depth` and `iho_order`.
    pub(super) fn n_dims(&self) -> usize {
        match self {
            Kernel::Linear(_) | Kernel::Beam(_) => 5,
            Kernel::Conic(..) => 9,
        }
    }
    pub(super) fn has_incidence(&self) -> bool {
        match self {
            Kernel::Linear(p) => p.has_incidence(),
            Kernel::Conic(p, _) => p.has_incidence(),
            Kernel::Beam(b) => b.has_incidence(),
        }
    }
    pub(super) fn source_names(&self) -> Vec<&'static str> {
        let mut v: Vec<&'static str> = match self {
            Kernel::Linear(_) => LinearScanner::SOURCES.iter().map(|s| s.name()).collect(),
            Kernel::Conic(..) => ConicScanner::SOURCES.iter().map(|s| s.name()).collect(),
            Kernel::Beam(_) => BeamPropagator::share_names(),
        };
        v.push("incidence");
        v
    }
}
