//! Closed-form eigen-decomposition of a symmetric 3 × 3 matrix, for the per-point plane fits.
//!
//! # Why it is hand-written
//! Every point of a tile with an incidence term gets a plane fit, so this runs millions of times
//! per file. nalgebra's `symmetric_eigen` is a general iterative (tridiagonalisation + implicit
//! QR) solver: correct, but several times slower than needed for 3 × 3, and it was the largest
//! cost of the plane fits after the neighbour search. No crate on hand gives a fast *and* robust
//! 3 × 3 symmetric solver: the textbook trigonometric formulas lose the eigenvectors when two
//! eigenvalues are close (exactly the near-collinear or near-isotropic neighbourhoods a plane
//! fit must survive), and the `nalgebra` / `glam` families offer no closed form.
//!
//! This is D. Eberly's non-iterative algorithm ("A Robust Eigensolver for 3 × 3 Symmetric
//! Matrices", Geometric Tools, 2014, the `NISymmetricEigensolver3x3` of the Geometric Tools
//! Engine): the matrix is scaled by its largest entry and shifted by its mean eigenvalue, the
//! *better separated* extreme eigenvalue is a root of the depressed characteristic cubic (found
//! by Newton steps from a polynomial fit of the trigonometric solution, which would cost an
//! `acos` and a `cos`), its eigenvector the largest cross product of two rows of `A − λI`, the
//! other two eigenvalues and the middle vector come from a 2 × 2 problem in that vector's
//! orthogonal complement, and the third vector from a cross product. Each eigenvector's error is
//! of order `ε‖A‖ / gap`, as for an iterative solver; a test compares it with nalgebra's on
//! random and near-degenerate matrices. The plane fits' judgement of a neighbourhood needs only
//! the values and, for a plane, the smallest one's vector: [`symmetric_eigenvalues3`] and
//! [`symmetric_eigenvector3`] give those without the 2 × 2 problem.

use nalgebra::{Matrix3, Vector3};

/// Eigenvalues in increasing order and their unit eigenvectors, of the symmetric part of `a`
/// (only the upper triangle is read).
pub fn symmetric_eigen3(a: &Matrix3<f64>) -> ([f64; 3], [Vector3<f64>; 3]) {
    let identity = [Vector3::x(), Vector3::y(), Vector3::z()];
    let Cubic {
        m,
        max_abs,
        q,
        p,
        half_det,
    } = match Cubic::of(a) {
        Ok(c) => c,
        Err(values) => return (values, identity),
    };
    // The extreme eigenvalue farther from the mean (β2 when det ≥ 0) is well separated and
    // accurate; the other two come from the 2 × 2 problem in its eigenvector's complement, which
    // keeps them (and their vectors) accurate when they are close together, where the
    // values from the cubic lose half their digits.
    let (vals, vecs) = if half_det >= 0.0 {
        let e2 = q + p * largest_root(2.0 * half_det);
        let v2 = m.eigenvector_from_rows(e2);
        let ([e0, e1], v1) = m.eigen_in_complement(&v2, true);
        ([e0, e1, e2], [v1.cross(&v2), v1, v2])
    } else {
        let e0 = q - p * largest_root(-2.0 * half_det);
        let v0 = m.eigenvector_from_rows(e0);
        let ([e1, e2], v1) = m.eigen_in_complement(&v0, false);
        ([e0, e1, e2], [v0, v1, v0.cross(&v1)])
    };
    (vals.map(|e| e * max_abs), vecs)
}

/// The eigenvalues of [`symmetric_eigen3`] (increasing) without the vectors, all three from the
/// characteristic cubic: the one farther from the mean as there, the other two from the sum and
/// product of the roots. Cheaper, and as accurate but for two nearly equal eigenvalues, which
/// keep only about half their digits relative to the largest (their difference is
/// ill-conditioned in the cubic; [`symmetric_eigen3`] gets it from a 2 × 2 problem).
pub fn symmetric_eigenvalues3(a: &Matrix3<f64>) -> [f64; 3] {
    let Cubic {
        max_abs,
        q,
        p,
        half_det,
        ..
    } = match Cubic::of(a) {
        Ok(c) => c,
        Err(values) => return values,
    };
    // Roots β of β³ − 3β − det: they sum to 0 and, given one (β), the other two are
    // (−β ± √(3(4 − β²)))/2.
    let pair = |b: f64| {
        let half_gap = 0.5 * (3.0 * (4.0 - b * b)).max(0.0).sqrt();
        (-0.5 * b - half_gap, -0.5 * b + half_gap)
    };
    let betas = if half_det >= 0.0 {
        let b2 = largest_root(2.0 * half_det);
        let (b0, b1) = pair(b2);
        [b0, b1, b2]
    } else {
        let b0 = -largest_root(-2.0 * half_det);
        let (b1, b2) = pair(b0);
        [b0, b1, b2]
    };
    betas.map(|b| (q + p * b) * max_abs)
}

/// Unit eigenvector of `a` (upper triangle) for its eigenvalue `lambda`, which must be simple
/// (e.g. the smallest from [`symmetric_eigenvalues3`] when well below the other two): the
/// largest cross product of two rows of `A − λI`, as [`symmetric_eigen3`] gets its first one.
/// Its error is of order `ε‖A‖ / gap`. `x` for a zero or non-finite `a`.
pub fn symmetric_eigenvector3(a: &Matrix3<f64>, lambda: f64) -> Vector3<f64> {
    match Cubic::of(a) {
        Ok(c) => c.m.eigenvector_from_rows(lambda / c.max_abs),
        Err(_) => Vector3::x(),
    }
}

/// A symmetric matrix scaled to its largest entry, with the mean `q` of its eigenvalues, their
/// spread `p` and the determinant of `B = (A − qI)/p` halved: B's eigenvalues are the roots of
/// `β³ − 3β − det B`, in [−2, 2].
struct Cubic {
    m: Sym,
    max_abs: f64,
    q: f64,
    p: f64,
    half_det: f64,
}

impl Cubic {
    /// The cubic of the upper triangle of `a`, or the eigenvalues where there is none to solve:
    /// zero (any basis), non-finite (NaN/∞ reach the caller through the values), a multiple of
    /// the identity.
    #[inline]
    fn of(a: &Matrix3<f64>) -> Result<Cubic, [f64; 3]> {
        let (a00, a01, a02) = (a[(0, 0)], a[(0, 1)], a[(0, 2)]);
        let (a11, a12, a22) = (a[(1, 1)], a[(1, 2)], a[(2, 2)]);
        let max_abs = a00
            .abs()
            .max(a01.abs())
            .max(a02.abs())
            .max(a11.abs())
            .max(a12.abs())
            .max(a22.abs());
        if max_abs == 0.0 || !max_abs.is_finite() {
            let v = if max_abs == 0.0 { 0.0 } else { f64::NAN };
            return Err([v; 3]);
        }
        // Scale to [−1, 1] to avoid overflow and underflow.
        let inv = 1.0 / max_abs;
        let (a00, a01, a02, a11, a12, a22) = (
            a00 * inv,
            a01 * inv,
            a02 * inv,
            a11 * inv,
            a12 * inv,
            a22 * inv,
        );
        let norm = a01 * a01 + a02 * a02 + a12 * a12;
        let q = (a00 + a11 + a22) / 3.0;
        let (b00, b11, b22) = (a00 - q, a11 - q, a22 - q);
        let p = ((b00 * b00 + b11 * b11 + b22 * b22 + 2.0 * norm) / 6.0).sqrt();
        if p == 0.0 {
            return Err([q * max_abs; 3]);
        }
        let c00 = b11 * b22 - a12 * a12;
        let c01 = a01 * b22 - a12 * a02;
        let c02 = a01 * a12 - b11 * a02;
        let det = (b00 * c00 - a01 * c01 + a02 * c02) / (p * p * p);
        Ok(Cubic {
            m: Sym {
                a00,
                a01,
                a02,
                a11,
                a12,
                a22,
            },
            max_abs,
            q,
            p,
            half_det: (det * 0.5).clamp(-1.0, 1.0),
        })
    }
}

/// The largest root of `β³ − 3β − d` for `d` in [0, 2] (the trigonometric solution is
/// `2 cos(acos(d/2)/3)`, in [√3, 2]): a cubic fit of it to 1.4·10⁻⁴, then Newton steps. There
/// `f′ = 3(β² − 1) ≥ 6`, so the root is simple and well conditioned, each step squares the
/// error (times < 1), and the third leaves it within rounding: cheaper than `acos` and `cos`.
/// (For d < 0 the smallest root is `−largest_root(−d)`.)
fn largest_root(d: f64) -> f64 {
    let t = d - 1.0;
    let mut b = 1.879_428_123_785_594
        + t * (0.131_615_075_670_366_23
            + t * (-0.013_284_389_109_439_364 + t * 0.002_343_621_131_006_183));
    for _ in 0..3 {
        b -= (b * (b * b - 3.0) - d) / (3.0 * (b * b - 1.0));
    }
    b
}

/// The upper triangle of a scaled symmetric matrix.
struct Sym {
    a00: f64,
    a01: f64,
    a02: f64,
    a11: f64,
    a12: f64,
    a22: f64,
}

impl Sym {
    fn mul(&self, v: &Vector3<f64>) -> Vector3<f64> {
        Vector3::new(
            self.a00 * v.x + self.a01 * v.y + self.a02 * v.z,
            self.a01 * v.x + self.a11 * v.y + self.a12 * v.z,
            self.a02 * v.x + self.a12 * v.y + self.a22 * v.z,
        )
    }

    /// Unit eigenvector of a simple eigenvalue `e`: `A − eI` has rank 2, its rows span the
    /// complement of the eigenvector, and the largest of their pairwise cross products is the
    /// best conditioned.
    fn eigenvector_from_rows(&self, e: f64) -> Vector3<f64> {
        let r0 = Vector3::new(self.a00 - e, self.a01, self.a02);
        let r1 = Vector3::new(self.a01, self.a11 - e, self.a12);
        let r2 = Vector3::new(self.a02, self.a12, self.a22 - e);
        let (c01, c02, c12) = (r0.cross(&r1), r0.cross(&r2), r1.cross(&r2));
        let (d01, d02, d12) = (c01.norm_squared(), c02.norm_squared(), c12.norm_squared());
        let (c, d) = if d01 >= d02 && d01 >= d12 {
            (c01, d01)
        } else if d02 >= d12 {
            (c02, d02)
        } else {
            (c12, d12)
        };
        if d > 0.0 {
            c / d.sqrt()
        } else {
            // Rank < 2 only for a multiple of the identity, handled by the caller; keep a unit
            // vector anyway.
            Vector3::x()
        }
    }

    /// The two eigenvalues (increasing) orthogonal to the unit eigenvector `w`, and the unit
    /// eigenvector of the larger (`larger`) or smaller one: a 2 × 2 symmetric problem in an
    /// orthonormal basis (u, v) of w's complement.
    fn eigen_in_complement(&self, w: &Vector3<f64>, larger: bool) -> ([f64; 2], Vector3<f64>) {
        let u = if w.x.abs() > w.y.abs() {
            let inv = 1.0 / (w.x * w.x + w.z * w.z).sqrt();
            Vector3::new(-w.z * inv, 0.0, w.x * inv)
        } else {
            let inv = 1.0 / (w.y * w.y + w.z * w.z).sqrt();
            Vector3::new(0.0, w.z * inv, -w.y * inv)
        };
        let v = w.cross(&u);
        let (au, av) = (self.mul(&u), self.mul(&v));
        let (b00, b01, b11) = (u.dot(&au), u.dot(&av), v.dot(&av));
        let mean = 0.5 * (b00 + b11);
        // The entries are scaled to at most 1: no overflow, and an underflow only where the two
        // eigenvalues are equal to ~1e-154 of the largest (any vector of the pair is then right).
        let h = 0.5 * (b00 - b11);
        let half = (h * h + b01 * b01).sqrt();
        let vals = [mean - half, mean + half];
        let e = if larger { vals[1] } else { vals[0] };
        let mut m00 = b00 - e;
        let mut m01 = b01;
        let mut m11 = b11 - e;
        let (abs00, abs01, abs11) = (m00.abs(), m01.abs(), m11.abs());
        if abs00 >= abs11 {
            if abs00.max(abs01) > 0.0 {
                if abs00 >= abs01 {
                    m01 /= m00;
                    m00 = 1.0 / (1.0 + m01 * m01).sqrt();
                    m01 *= m00;
                } else {
                    m00 /= m01;
                    m01 = 1.0 / (1.0 + m00 * m00).sqrt();
                    m00 *= m01;
                }
                (vals, u * m01 - v * m00)
            } else {
                (vals, u)
            }
        } else if abs11.max(abs01) > 0.0 {
            if abs11 >= abs01 {
                m01 /= m11;
                m11 = 1.0 / (1.0 + m01 * m01).sqrt();
                m01 *= m11;
            } else {
                m11 /= m01;
                m01 = 1.0 / (1.0 + m11 * m11).sqrt();
                m11 *= m01;
            }
            (vals, u * m11 - v * m01)
        } else {
            (vals, u)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Checks values against nalgebra's and each vector where its eigenvalue is separated from
    /// the others by more than `min_gap` (relative to the largest).
    fn check(a: &Matrix3<f64>, min_gap: f64) {
        let (vals, vecs) = symmetric_eigen3(a);
        let reference = a.symmetric_eigen();
        let mut want: Vec<(f64, Vector3<f64>)> = (0..3)
            .map(|i| {
                (
                    reference.eigenvalues[i],
                    reference.eigenvectors.column(i).into_owned(),
                )
            })
            .collect();
        want.sort_by(|x, y| x.0.total_cmp(&y.0));
        let scale = a.abs().max().max(f64::MIN_POSITIVE);
        for i in 0..3 {
            assert!(
                (vals[i] - want[i].0).abs() <= 1e-13 * scale,
                "value {i}: {} vs {} for {a}",
                vals[i],
                want[i].0
            );
            assert!((vecs[i].norm() - 1.0).abs() < 1e-14);
            // A · v = λ v to rounding, whatever the gap.
            let r = a * vecs[i] - vecs[i] * vals[i];
            assert!(r.norm() <= 1e-13 * scale, "residual {r} for {a}");
            let gap = (0..3)
                .filter(|&j| j != i)
                .map(|j| (want[i].0 - want[j].0).abs())
                .fold(f64::INFINITY, f64::min);
            if gap > min_gap * scale {
                let d = (vecs[i] - want[i].1)
                    .norm()
                    .min((vecs[i] + want[i].1).norm());
                assert!(
                    d <= 1e-13 * scale / gap + 1e-14,
                    "vector {i}: off by {d} (gap {gap}) for {a}"
                );
            }
        }
        // Orthonormal basis.
        assert!(vecs[0].dot(&vecs[1]).abs() < 1e-13);
        assert!(vecs[0].dot(&vecs[2]).abs() < 1e-13);
        assert!(vecs[1].dot(&vecs[2]).abs() < 1e-13);
    }

    fn rotated(rng: &mut ChaCha8Rng, vals: [f64; 3]) -> Matrix3<f64> {
        let r = Rotation3::from_euler_angles(
            rng.random_range(-3.2..3.2),
            rng.random_range(-1.6..1.6),
            rng.random_range(-3.2..3.2),
        );
        let m = r.matrix() * Matrix3::from_diagonal(&vals.into()) * r.matrix().transpose();
        (m + m.transpose()) * 0.5
    }

    #[test]
    fn random_symmetric_matrices_agree_with_nalgebra() {
        let mut rng = ChaCha8Rng::seed_from_u64(20);
        for _ in 0..20_000 {
            let mut m = Matrix3::from_fn(|_, _| rng.random_range(-1.0..1.0));
            m = (m + m.transpose()) * rng.random_range(0.001..1000.0);
            check(&m, 1e-6);
        }
    }

    #[test]
    fn near_degenerate_scatter_matrices_agree_with_nalgebra() {
        let mut rng = ChaCha8Rng::seed_from_u64(21);
        for case in 0..20_000 {
            let s: f64 = rng.random_range(0.01..100.0);
            let tiny = 10f64.powf(rng.random_range(-14.0..-2.0)) * s;
            let vals = match case % 6 {
                // Plane with a little roughness (the usual plane fit).
                0 => [tiny, s * rng.random_range(0.2..1.0), s],
                // Exactly planar.
                1 => [0.0, s * rng.random_range(0.2..1.0), s],
                // Nearly collinear.
                2 => [tiny * 0.3, tiny, s],
                // Two equal largest (isotropic plane).
                3 => [tiny, s, s],
                // Two equal smallest.
                4 => [tiny, tiny, s],
                // Nearly isotropic.
                _ => [s, s * (1.0 + tiny / s), s * (1.0 + 2.0 * tiny / s)],
            };
            check(&rotated(&mut rng, vals), 1e-6);
        }
        // Exact special cases.
        check(&Matrix3::zeros(), 1e-6);
        check(&Matrix3::identity(), 1e-6);
        check(&Matrix3::from_diagonal(&Vector3::new(3.0, 1.0, 2.0)), 1e-6);
        check(&Matrix3::from_diagonal(&Vector3::new(0.0, 0.0, 5.0)), 1e-6);
    }

    #[test]
    fn values_alone_and_one_vector_agree_with_the_full_solver() {
        // Random and near-degenerate matrices (as above): the values within 1e-13 of the
        // largest, plus rounding / the smallest gap (a close pair's difference is
        // ill-conditioned in the cubic), within 1e-7 where two are within 1e-6 of each other;
        // the vector of a separated eigenvalue within that error / its gap of the full solver's.
        let mut rng = ChaCha8Rng::seed_from_u64(23);
        let mut separated = 0;
        for case in 0..30_000 {
            let s: f64 = rng.random_range(0.01..100.0);
            let tiny = 10f64.powf(rng.random_range(-14.0..-2.0)) * s;
            let mid = s * rng.random_range(0.2..1.0);
            let a = match case % 5 {
                0 => {
                    let m = Matrix3::from_fn(|_, _| rng.random_range(-1.0..1.0));
                    (m + m.transpose()) * s
                }
                1 => rotated(&mut rng, [tiny, mid, s]),
                2 => rotated(&mut rng, [tiny * 0.3, tiny, s]),
                3 => rotated(&mut rng, [tiny, s, s]),
                _ => rotated(&mut rng, [tiny, tiny, s]),
            };
            let (want, vecs) = symmetric_eigen3(&a);
            let got = symmetric_eigenvalues3(&a);
            let scale = a.abs().max();
            let gap = |i: usize| {
                (0..3)
                    .filter(|&j| j != i)
                    .map(|j| (want[i] - want[j]).abs())
                    .fold(f64::INFINITY, f64::min)
            };
            let min_gap = (0..3).map(gap).fold(f64::INFINITY, f64::min);
            let tol = if min_gap <= 1e-6 * scale {
                1e-7 * scale
            } else {
                (1e-13 + 1e-15 * scale / min_gap) * scale
            };
            for i in 0..3 {
                assert!(
                    (got[i] - want[i]).abs() <= tol,
                    "{got:?} vs {want:?} for {a}"
                );
                if gap(i) > 1e-3 * scale {
                    let v = symmetric_eigenvector3(&a, got[i]);
                    let d = (v - vecs[i]).norm().min((v + vecs[i]).norm());
                    // The error of its value (tol) over its gap.
                    assert!(d <= 2.0 * tol / gap(i), "vector {i}: {d} for {a}");
                    separated += 1;
                }
            }
        }
        assert!(separated > 40_000, "{separated}");
        assert_eq!(symmetric_eigenvalues3(&Matrix3::zeros()), [0.0; 3]);
        assert_eq!(
            symmetric_eigenvalues3(&(Matrix3::identity() * 2.0)),
            [2.0; 3]
        );
        let d = symmetric_eigenvalues3(&Matrix3::from_diagonal(&Vector3::new(3.0, 1.0, 2.0)));
        assert!(
            (d[0] - 1.0).abs() < 1e-15 && (d[1] - 2.0).abs() < 1e-15 && (d[2] - 3.0).abs() < 1e-15
        );
        assert!(symmetric_eigenvalues3(&Matrix3::from_element(f64::NAN))[0].is_nan());
    }

    #[test]
    fn the_cubic_root_is_the_trigonometric_one_to_rounding() {
        // Against 2 cos(acos(d/2)/3) (which is itself a few ulps off near d = 2) and against
        // the cubic's own residual, on a fine grid of d and at the ends.
        let n = 200_000;
        for i in 0..=n {
            let d = 2.0 * f64::from(i) / f64::from(n);
            let b = largest_root(d);
            let trig = 2.0 * ((d * 0.5).acos() / 3.0).cos();
            assert!((b - trig).abs() <= 4.0 * f64::EPSILON, "{d}: {b} vs {trig}");
            // |f(β)| / f′(β): the distance to the exact root, to the rounding of f.
            let f = b * (b * b - 3.0) - d;
            assert!(
                f.abs() / (3.0 * (b * b - 1.0)) <= 3.0 * f64::EPSILON,
                "{d}: {f}"
            );
        }
        assert_eq!(largest_root(2.0), 2.0);
        assert!((largest_root(0.0) - 3f64.sqrt()).abs() <= f64::EPSILON);
    }

    #[test]
    fn plane_normals_match_nalgebra_to_1e_12() {
        // Scatter of a noisy plane: the smallest eigenvector within 1e-12 rad of nalgebra's.
        let mut rng = ChaCha8Rng::seed_from_u64(22);
        for _ in 0..5_000 {
            let pts: Vec<Vector3<f64>> = (0..10)
                .map(|_| {
                    let (x, y) = (rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
                    Vector3::new(x, y, 0.3 * x - 0.2 * y + rng.random_range(-1e-3..1e-3))
                })
                .collect();
            let mean = pts.iter().sum::<Vector3<f64>>() / 10.0;
            let s: Matrix3<f64> = pts
                .iter()
                .map(|p| (p - mean) * (p - mean).transpose())
                .sum();
            let (_, v) = symmetric_eigen3(&s);
            let e = s.symmetric_eigen();
            let i = e.eigenvalues.imin();
            let w = e.eigenvectors.column(i);
            assert!((v[0] - w).norm().min((v[0] + w).norm()) < 1e-12);
        }
    }
}
