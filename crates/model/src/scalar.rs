//! The scalar every georeferencing function is generic over.

use nalgebra::RealField;

/// A real scalar: `f64` for values, `num_dual::DualSVec64<N>` (or any other dual number) for exact
/// derivatives of the same code.
///
/// The bound is nalgebra's [`RealField`] (which num-dual implements for its dual numbers) rather than
/// `num_dual::DualNum`, so that method calls such as `x.sin()` resolve to one trait only.
pub trait Scalar: RealField + Copy + From<f64> {}

impl<T: RealField + Copy + From<f64>> Scalar for T {}

/// Lift a constant into the scalar type.
#[inline]
pub fn c<D: Scalar>(x: f64) -> D {
    D::from(x)
}
