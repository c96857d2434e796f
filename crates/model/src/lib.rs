//! lidarqa-model: the sensor geometry of airborne LiDAR, with no I/O.
//!
//! - rotations in the orders of SPEC §3 ([`rotation_zyx`]),
//! - the linear scanner of Zhang et al. (2018) eq. (2), `P = P0 + R_N (R_M S + ΔP)`
//!   ([`LinearScanner`]),
//! - the constant-angle conic prism scanner of Li et al. (2016) with vector Snell refraction
//!   through the prism and at the water surface ([`ConicScanner`]),
//! - the beam model of every scanner that measures a range along an encoder-given beam (rotating
//!   mirror, spinning multi-beam, Risley prism pair, elliptical) ([`BeamScanner`]),
//! - the checked [`Sensor`] that computation crates accept,
//! - the workspace's one Levenberg–Marquardt ([`lm`]) and one plane fit ([`fit_plane`], normal
//!   `n_z ≥ 0`).
//!
//! Every georeferencing function is generic over the scalar ([`Scalar`]): with `f64` it returns
//! values, with num-dual's dual numbers the exact Jacobian of the same code, so no crate keeps a
//! hand-derived copy of the partial derivatives.
//!
//! ```
//! use lidarqa_model::{Attitude, Georeferencer, LinearObservation, LinearScanner, Mounting};
//! use nalgebra::SVector;
//! use num_dual::{jacobian, DualSVec64};
//!
//! // Zhang et al. (2018): level flight, scan angle 30°, 80 m below.
//! let obs = LinearObservation { range_m: 80.0 / 30f64.to_radians().cos(), scan_angle_rad: 30f64.to_radians() };
//! let p = LinearScanner.parameters(&Attitude::default(), &Mounting::default(), &obs);
//! let (footprint, j) = jacobian(|q: SVector<DualSVec64<14>, 14>| LinearScanner.footprint_ned(&q), &p);
//! assert!((footprint[1] - 46.188).abs() < 1e-3); // east
//! // ∂north/∂(boresight pitch) = ρ cos θ = 80 m: 0.008° of boresight pitch moves the point 1.117 cm north.
//! assert!((j[(0, 7)] - 80.0).abs() < 1e-9);
//! ```

mod axes;
mod beam;
mod beam_invert;
mod beam_sigma;
mod confidence;
mod conic;
mod control;
mod eigen3;
mod error;
mod frames;
mod georeferencer;
mod histogram;
mod linear;
pub mod lm;
mod numeric;
mod plane;
mod rotation;
mod scalar;
mod sensor;
mod source;
mod stats;
mod warning;

pub use axes::Axes;
pub use beam::{BEAM_N, BeamKind, BeamObservation, BeamScanner, beam_jacobian};
pub use beam_invert::BeamInversion;
pub use confidence::{CIRCULAR_95_FACTOR, NORMAL_95_FACTOR};
pub use conic::{
    CONIC_N, ConicObservation, ConicScanner, DEFAULT_N_AIR, DEFAULT_N_PRISM, DEFAULT_N_WATER,
    Refraction, SPEED_OF_LIGHT_AIR_M_PER_S, refract,
};
pub use control::ControlPoint;
pub use eigen3::{symmetric_eigen3, symmetric_eigenvalues3, symmetric_eigenvector3};
pub use error::{Error, Result};
pub use frames::{Attitude, Ecef, Enu, Grid, Mounting, MountingPartials, Ned};
pub use georeferencer::{Georeferencer, TRAJECTORY_SOURCES};
pub use histogram::LogHistogram;
pub use linear::{
    LINEAR_N, LinearObservation, LinearScanner, OffPlaneLinearScanner, linear_jacobian_at_beam,
    linear_range_for_height, scanner_vector,
};
pub use numeric::{floor_f64, floor_i64};
pub use plane::{Plane, fit_plane, normal_of_scatter, plane_of_scatter};
pub use rotation::{
    ecef_from_ned, ecef_from_ned_sin_cos, ned_from_ecef, rot_x, rot_y, rot_z, rotation_zyx,
    rotation_zyx_with_partials, zyx_angles, zyx_axes_of, zyx_partials_of,
};
pub use scalar::Scalar;
pub use sensor::{Correlation, Scanner, Sensor, Sigmas};
pub use source::{Source, Unit};
pub use stats::{MAD_TO_SIGMA, median};
pub use warning::Warning;
