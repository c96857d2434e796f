//! Per-axis values in the local level frame at the point ([`Axes`], defined in lidarqa-model) and
//! signed displacements along and across track ([`Displacement`], defined in lidarqa-products).

use nalgebra::Vector3;

/// The one six-axis struct of the workspace (σ, |displacement|, RMSE per axis), from
/// lidarqa-model.
pub use lidarqa_model::Axes;

/// A signed displacement along and across track: lidarqa-products' type, the one the budget
/// writes and the report reads.
pub use lidarqa_products::Displacement;

/// The displacement of an NED vector (m) with the platform heading (rad).
pub fn displacement_from_ned(v: &Vector3<f64>, heading_rad: f64) -> Displacement {
    let (s, c) = heading_rad.sin_cos();
    Displacement {
        north: v.x,
        east: v.y,
        up: -v.z,
        along_track: v.x * c + v.y * s,
        across_track: -v.x * s + v.y * c,
    }
}
