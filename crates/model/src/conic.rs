//! The constant-angle conic prism scanner of Li et al. (2016) (CZMIL-like), with refraction through
//! the prism and at the water surface.
//!
//! The seed's formula images are missing; these conventions (SPEC §3) reproduce its Table 4:
//! - emitter direction in S: `l1 = [sin φls cos θls, sin φls sin θls, cos φls]`, fixed in S;
//! - prism normals along the propagation direction: top `p1 = [sin θf, 0, cos θf]`, bottom
//!   `p2 = [0, 0, 1]`, both turned by `Rz(θaz) · Rx(θfsx) Ry(θfsy) Rz(θfsz)`;
//! - vector Snell law `t = η l + (cos θt − η cos θi) n`, `cos θi = n·l`, `η = n_in / n_out`:
//!   `l2 = t(l1, p1, na/nf)`, `l3 = t(l2, p2, nf/na)`, `l4 = t(l3, p3, na/nw)`;
//! - `p3` is `[0, 0, 1]` in S (`scanner-frame`, the paper's model) or the local vertical in N
//!   (`level`, physically right: attitude then changes the incidence angle);
//! - ranges `ρ1 = c Δt1 / 2`, `ρ2 = c Δt2 / (2 nw)` with `c` the speed of light in air;
//!   `X_S = ρ1 l3 + ρ2 l4`, then boresight, lever arm and attitude as for the linear scanner;
//! - four more parameters for bathymetric soundings (not in Li et al. (2016)): the water-surface
//!   height δh at the refraction point (the point moves `δh / cos θi` back along `l3`, and the
//!   water leg gains that optical path, `ρ1 + nw ρ2` held: the total travel time is measured), its
//!   slope towards north and east (waves: `p3 ∝ p3₀ + (R_N R_M)ᵀ [tan s_N, tan s_E, 0]`), and the
//!   refraction index nw itself (Snell's law and `ρ2`). Their nominal values are 0, 0, 0 and the
//!   scanner's nw; none of them moves a topographic or water-surface return (`Δt2 = 0`).

use crate::error::{Error, Result};
use crate::frames::MountingPartials;
use crate::frames::{Attitude, Mounting};
use crate::georeferencer::{Georeferencer, gnss_offset_ned, platform_parameters, platform_then};
use crate::rotation::{
    rot_x, rot_y, rot_z, rotation_zyx, rotation_zyx_with_partials, zyx_partials_of,
};
use crate::scalar::{Scalar, c};
use crate::source::Source;
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};
use num_dual::{DualSVec64, jacobian};

/// Speed of light in air used by Li et al. (2016), m/s.
pub const SPEED_OF_LIGHT_AIR_M_PER_S: f64 = 299_552_816.0;

/// Number of parameters of the conic model.
pub const CONIC_N: usize = 25;

/// Where the water-surface normal `p3` is fixed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Refraction {
    /// `p3 = [0, 0, 1]` in the scanner frame: Li et al.'s (2016) model (reproduces its Table 4).
    #[default]
    ScannerFrame,
    /// `p3` = local vertical in N: roll and pitch change the incidence angle, as they physically do.
    Level,
}

impl Refraction {
    /// `"scanner-frame"` or `"level"`, as in the sensor file and JSON.
    pub fn name(self) -> &'static str {
        match self {
            Refraction::ScannerFrame => "scanner-frame",
            Refraction::Level => "level",
        }
    }

    /// Parse `"scanner-frame"` or `"level"`.
    pub fn from_name(name: &str) -> Option<Refraction> {
        match name {
            "scanner-frame" => Some(Refraction::ScannerFrame),
            "level" => Some(Refraction::Level),
            _ => None,
        }
    }
}

/// Li et al.'s (2016) defaults: prism 1.461, air 1.0003, water 1.33.
pub const DEFAULT_N_PRISM: f64 = 1.461;
/// Default refraction index of air.
pub const DEFAULT_N_AIR: f64 = 1.0003;
/// Default refraction index of sea water.
pub const DEFAULT_N_WATER: f64 = 1.33;

/// Constants of a conic prism scanner (checked by [`ConicScanner::new`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConicScanner {
    prism_slope_rad: f64,
    n_prism: f64,
    n_air: f64,
    n_water: f64,
    refraction: Refraction,
    /// The air beam and its Jacobian at the nominal prism and emitter, azimuth 0.
    nominal: NominalBeam,
}

/// The air beam `l3` and `∂l3/∂(p[12..19])` at the nominal prism and emitter (prism turned
/// by 0, emitter on the S Z axis) and azimuth 0, computed once per scanner: the prism turns
/// about S Z and the emitter beam lies on that axis, so at any azimuth `az` the beam is
/// `Rz(az) l3₀` and its derivatives are those at 0 turned by `Rz(az)`, except the emitter
/// zenith's, which depends on the direction it tilts the emitter in relative to the prism
/// (`Rz(−az) e_x`): from the two derivatives at emitter azimuths 0 and 90°.
#[derive(Debug, Clone, Copy, PartialEq)]
struct NominalBeam {
    l3: Vector3<f64>,
    jacobian: SMatrix<f64, 3, 7>,
    /// ∂l3/∂(emitter zenith) at emitter azimuth 90°, azimuth 0.
    zenith_y: Vector3<f64>,
}

/// Refract direction `l` (unit) through a surface with unit normal `n` pointing along the propagation
/// direction, `eta = n_in / n_out` (vector Snell law, Glassner 1989; Li et al. (2016), ref. 14):
/// `t = η l + (cos θt − η cos θi) n`, `cos θi = n·l`, `cos θt = √(1 − η² (1 − cos² θi))`.
/// Returns NaN components on total internal reflection.
pub fn refract<D: Scalar>(l: &Vector3<D>, n: &Vector3<D>, eta: D) -> Vector3<D> {
    let cos_i = n.dot(l);
    let cos_t = (c::<D>(1.0) - eta * eta * (c::<D>(1.0) - cos_i * cos_i)).sqrt();
    l * eta + n * (cos_t - eta * cos_i)
}

impl ConicScanner {
    /// The sources the conic scanner adds after the platform's (prism, scan azimuth, emitter,
    /// travel times, water surface); the linear scanner has none of them.
    pub const SCANNER_SOURCES: [Source; 13] = [
        Source::PrismSlope,
        Source::PrismX,
        Source::PrismY,
        Source::PrismZ,
        Source::ScanAzimuth,
        Source::EmitterZenith,
        Source::EmitterAzimuth,
        Source::TimeAir,
        Source::TimeWater,
        Source::WaterSurfaceHeight,
        Source::WaterSurfaceSlopeNorth,
        Source::WaterSurfaceSlopeEast,
        Source::NWater,
    ];

    /// Check and build from the prism slope θf (rad) and the three refraction indices.
    pub fn new(
        prism_slope_rad: f64,
        n_prism: f64,
        n_air: f64,
        n_water: f64,
        refraction: Refraction,
    ) -> Result<ConicScanner> {
        check_index("n_prism", n_prism, false)?;
        check_index("n_air", n_air, true)?;
        check_index("n_water", n_water, false)?;
        let mut s = ConicScanner {
            prism_slope_rad,
            n_prism,
            n_air,
            n_water,
            refraction,
            nominal: NominalBeam {
                l3: Vector3::zeros(),
                jacobian: SMatrix::zeros(),
                zenith_y: Vector3::zeros(),
            },
        };
        let (_, jacobian) = s.air_beam_jacobian(&s.nominal_prism(0.0));
        // The beam itself by the f64 code path, so that it is bit for bit what `rays` gives.
        let q = s.nominal_prism(0.0);
        let l3 = s.air_beam(&[q[0], q[1], q[2], q[3], q[4], q[5], q[6]]);
        let mut q = s.nominal_prism(0.0);
        q[6] = std::f64::consts::FRAC_PI_2;
        let (_, j_y) = s.air_beam_jacobian(&q);
        s.nominal = NominalBeam {
            l3,
            jacobian,
            zenith_y: j_y.column(5).into_owned(),
        };
        let ok = prism_slope_rad.is_finite()
            && prism_slope_rad > 0.0
            && prism_slope_rad < std::f64::consts::FRAC_PI_2
            && s.exit_angle_rad().is_finite();
        if !ok {
            return Err(Error::InvalidPrismSlope {
                prism_slope_deg: prism_slope_rad.to_degrees(),
            });
        }
        Ok(s)
    }

    /// Build from the wanted exit angle (angle of the beam leaving the prism from the S Z axis), solving
    /// for the prism slope. Li et al. (2016): 20° ⇒ θf = 39.16°.
    pub fn from_exit_angle(
        exit_angle_rad: f64,
        n_prism: f64,
        n_air: f64,
        n_water: f64,
        refraction: Refraction,
    ) -> Result<ConicScanner> {
        let slope = prism_slope_for_exit_angle(exit_angle_rad, n_prism, n_air)?;
        ConicScanner::new(slope, n_prism, n_air, n_water, refraction)
    }

    /// Prism top-surface slope θf, rad.
    pub fn prism_slope_rad(&self) -> f64 {
        self.prism_slope_rad
    }
    /// Refraction index of the prism.
    pub fn n_prism(&self) -> f64 {
        self.n_prism
    }
    /// Refraction index of air.
    pub fn n_air(&self) -> f64 {
        self.n_air
    }
    /// Refraction index of water.
    pub fn n_water(&self) -> f64 {
        self.n_water
    }
    /// Water-surface refraction mode.
    pub fn refraction(&self) -> Refraction {
        self.refraction
    }

    /// Nominal exit angle (beam leaving the prism vs S Z axis), rad.
    pub fn exit_angle_rad(&self) -> f64 {
        nominal_exit_angle(self.prism_slope_rad, self.n_prism, self.n_air)
    }

    /// Air range from the two-way air travel time: `ρ1 = c Δt1 / 2`, m.
    pub fn range_air_m(&self, time_air_s: f64) -> f64 {
        SPEED_OF_LIGHT_AIR_M_PER_S * time_air_s / 2.0
    }
    /// Water range from the two-way water travel time: `ρ2 = c Δt2 / (2 nw)`, m.
    pub fn range_water_m(&self, time_water_s: f64) -> f64 {
        SPEED_OF_LIGHT_AIR_M_PER_S * time_water_s / (2.0 * self.n_water)
    }
    /// Inverse of [`ConicScanner::range_air_m`], s.
    pub fn time_air_s(&self, range_air_m: f64) -> f64 {
        2.0 * range_air_m / SPEED_OF_LIGHT_AIR_M_PER_S
    }
    /// Inverse of [`ConicScanner::range_water_m`], s.
    pub fn time_water_s(&self, range_water_m: f64) -> f64 {
        2.0 * self.n_water * range_water_m / SPEED_OF_LIGHT_AIR_M_PER_S
    }

    /// Beam directions in S: `(l3, l4)`, in air after the prism and in water after the surface, for
    /// the parameter vector `p` (see [`Georeferencer::SOURCES`] for the order).
    pub fn beam_directions<D: Scalar>(&self, p: &SVector<D, CONIC_N>) -> (Vector3<D>, Vector3<D>) {
        let r = self.rays(p);
        (r.l3, r.l4)
    }

    /// The air beam after the prism, in S, from the prism and emitter parameters
    /// `p[12..19]` (slope, prism x/y/z, scan azimuth, emitter zenith and azimuth).
    fn air_beam<D: Scalar>(&self, q: &[D; 7]) -> Vector3<D> {
        let (o, l) = (D::zero(), D::one());
        let turn = rot_z(q[4]) * rot_x(q[1]) * rot_y(q[2]) * rot_z(q[3]);
        let (st, ct) = q[0].sin_cos();
        let p1 = turn * Vector3::new(st, o, ct);
        let p2 = turn * Vector3::new(o, o, l);
        let (sz, cz) = q[5].sin_cos();
        let (sa, ca) = q[6].sin_cos();
        let l1 = Vector3::new(sz * ca, sz * sa, cz);
        let (na, nf) = (c::<D>(self.n_air), c::<D>(self.n_prism));
        let l2 = refract(&l1, &p1, na / nf);
        refract(&l2, &p2, nf / na)
    }

    /// `p[12..19]` at the nominal prism and emitter and scan azimuth `azimuth_rad`.
    fn nominal_prism(&self, azimuth_rad: f64) -> SVector<f64, 7> {
        SVector::from([self.prism_slope_rad, 0.0, 0.0, 0.0, azimuth_rad, 0.0, 0.0])
    }

    /// [`ConicScanner::air_beam`] and its Jacobian by a 7-direction dual pass.
    fn air_beam_jacobian(&self, q: &SVector<f64, 7>) -> (Vector3<f64>, SMatrix<f64, 3, 7>) {
        jacobian(
            |v: SVector<DualSVec64<7>, 7>| {
                self.air_beam(&[v[0], v[1], v[2], v[3], v[4], v[5], v[6]])
            },
            q,
        )
    }

    /// The air beam and its Jacobian: from the scanner's nominal beam turned to the azimuth
    /// when the prism and emitter are nominal (as [`Georeferencer::parameters`] sets them),
    /// else by a dual pass.
    fn air_beam_at(&self, q: &SVector<f64, 7>) -> (Vector3<f64>, SMatrix<f64, 3, 7>) {
        if *q != self.nominal_prism(q[4]) {
            return self.air_beam_jacobian(q);
        }
        self.nominal_beam_at(q[4])
    }

    /// The air beam and its Jacobian at the nominal prism and emitter, scan azimuth
    /// `azimuth_rad`: the scanner's nominal beam turned by `Rz(az)` (one `sin_cos`).
    fn nominal_beam_at(&self, azimuth_rad: f64) -> (Vector3<f64>, SMatrix<f64, 3, 7>) {
        let n = &self.nominal;
        let (s, c) = azimuth_rad.sin_cos();
        let rz = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
        let mut j = rz * n.jacobian;
        // Emitter zenith: the emitter tilts along Rz(−az) e_x = cos az e_x − sin az e_y of the
        // prism's own frame.
        j.set_column(5, &(rz * (n.jacobian.column(5) * c - n.zenith_y * s)));
        (rz * n.l3, j)
    }

    /// The air beam `l3` in S at scan azimuth 0 with the nominal prism and emitter (computed
    /// once per scanner); at azimuth `az` it is `Rz(az)` times this.
    pub fn nominal_air_beam(&self) -> Vector3<f64> {
        self.nominal.l3
    }

    /// The air and water beams `(l3, l4)` in S of a pulse at scan azimuth `azimuth_rad` with
    /// the nominal prism, emitter and water surface (level, index `n_water`), where
    /// `scanner_to_ned` is `R_N R_M`: [`ConicScanner::beam_directions`] at the parameters
    /// [`Georeferencer::parameters`] gives, from the nominal beam and the matrix itself (one
    /// `sin_cos`, no rotation built from angles).
    pub fn nominal_beams(
        &self,
        azimuth_rad: f64,
        scanner_to_ned: &Matrix3<f64>,
    ) -> (Vector3<f64>, Vector3<f64>) {
        let (s, c) = azimuth_rad.sin_cos();
        let l0 = &self.nominal.l3;
        let l3 = Vector3::new(c * l0.x - s * l0.y, s * l0.x + c * l0.y, l0.z);
        let base = match self.refraction {
            Refraction::ScannerFrame => Vector3::z(),
            // The local vertical in S: (R_N R_M)ᵀ e_z, the matrix's third row.
            Refraction::Level => scanner_to_ned.row(2).transpose(),
        };
        let l4 = refract(&l3, &base.normalize(), self.n_air / self.n_water);
        (l3, l4)
    }

    /// The rays and the surface normals of one pulse (all in S).
    fn rays<D: Scalar>(&self, p: &SVector<D, CONIC_N>) -> Rays<D> {
        let (o, l) = (D::zero(), D::one());
        let l3 = self.air_beam(&[p[12], p[13], p[14], p[15], p[16], p[17], p[18]]);
        let (na, nw) = (c::<D>(self.n_air), p[24]);
        // S → N: R_N R_M.
        let r = rotation_zyx(p[3], p[4], p[5]) * rotation_zyx(p[6], p[7], p[8]);
        let base = match self.refraction {
            Refraction::ScannerFrame => Vector3::new(o, o, l),
            // Local vertical (N down) expressed in S: (R_N R_M)ᵀ [0, 0, 1].
            Refraction::Level => r.transpose() * Vector3::new(o, o, l),
        };
        // Wave slope: the surface rises by tan(slope) per metre towards north / east, so its
        // normal along the propagation (down) is ∝ base + [tan s_N, tan s_E, 0] in N.
        let tilt = r.transpose() * Vector3::new(p[22].tan(), p[23].tan(), o);
        let p3 = (base + tilt).normalize();
        let l4 = refract(&l3, &p3, na / nw);
        Rays { l3, l4, base }
    }

    /// The scanner origin → footprint vector in N, `R X_S` with `R = R_N R_M`, from the air
    /// beam `L = R l3` and the untilted surface normal `B = R base`, both in N, and
    /// `x = [Δt1, Δt2, δh, s_N, s_E, nw]`. Snell's law and the ranges do not depend on the
    /// frame they are written in, so after the rotation the water leg is a function of these
    /// twelve numbers only; `wet` is `Δt2 > 0` (the water-surface height moves only a
    /// sounding). The reference for [`ConicScanner::leg_jacobian`]'s closed form.
    #[cfg(test)]
    fn leg_ned_at<D: Scalar>(
        &self,
        l: &Vector3<D>,
        b: &Vector3<D>,
        x: &[D; 6],
        wet: bool,
    ) -> Vector3<D> {
        let [t_air, t_water, dh, slope_n, slope_e, nw] = *x;
        let tilt = Vector3::new(slope_n.tan(), slope_e.tan(), D::zero());
        let p3 = (b + tilt).normalize();
        let l4 = refract(l, &p3, c::<D>(self.n_air) / nw);
        let speed = c::<D>(SPEED_OF_LIGHT_AIR_M_PER_S);
        let mut rho1 = speed * t_air * c::<D>(0.5);
        let mut rho2 = speed * t_water / (nw * c::<D>(2.0));
        if wet {
            let shift = dh / l.dot(b);
            rho1 -= shift;
            rho2 += shift / nw;
        }
        l * rho1 + l4 * rho2
    }

    /// The water leg `v = ρ1 L + ρ2 l4` (see `leg_ned_at` in the tests) and its Jacobian in
    /// closed form: columns `∂v/∂L` (3), `∂v/∂B` (3), then `Δt1, Δt2, δh, s_N, s_E, nw`.
    ///
    /// With `p3 = u/|u|`, `u = B + [tan s_N, tan s_E, 0]`, `η = na/nw`, `cᵢ = p3·L`,
    /// `cₜ = √(1 − η²(1 − cᵢ²))` and `l4 = η L + (cₜ − η cᵢ) p3` (vector Snell law):
    /// `∂l4/∂L = η I + (a − η) p3 p3ᵀ`, `∂l4/∂p3 = (cₜ − η cᵢ) I + (a − η) p3 Lᵀ` with
    /// `a = ∂cₜ/∂cᵢ = η² cᵢ/cₜ`, `∂p3/∂u = (I − p3 p3ᵀ)/|u|`,
    /// `∂l4/∂η = L + (−η(1 − cᵢ²)/cₜ − cᵢ) p3`; a sounding's surface-height shift `δh/g`
    /// (`g = L·B`) moves `ρ1` by `−δh/g` and `ρ2` by `δh/(g nw)`, so `∂v/∂g = δh/g² (L − l4/nw)`.
    /// A few 3 × 3 products where a 12-direction dual pass spent most of the conic kernel's
    /// time; a test checks it against that pass.
    fn leg_jacobian(
        &self,
        l: &Vector3<f64>,
        b: &Vector3<f64>,
        x: &[f64; 6],
        wet: bool,
    ) -> (Vector3<f64>, SMatrix<f64, 3, 12>) {
        let [t_air, t_water, dh, slope_n, slope_e, nw] = *x;
        // tan 0 = 0 without the call: the per-point TPU is always at the nominal surface.
        let tan = |s: f64| if s == 0.0 { 0.0 } else { s.tan() };
        let (tn, te) = (tan(slope_n), tan(slope_e));
        let u = b + Vector3::new(tn, te, 0.0);
        let norm_u = u.norm();
        let p3 = u / norm_u;
        let eta = self.n_air / nw;
        let ci = p3.dot(l);
        let ct = (1.0 - eta * eta * (1.0 - ci * ci)).sqrt();
        let l4 = l * eta + p3 * (ct - eta * ci);
        let speed = SPEED_OF_LIGHT_AIR_M_PER_S;
        let mut rho1 = speed * t_air * 0.5;
        let mut rho2 = speed * t_water / (nw * 2.0);
        let (mut d_g, mut d_dh) = (Vector3::zeros(), Vector3::zeros());
        if wet {
            let g = l.dot(b);
            let shift = dh / g;
            rho1 -= shift;
            rho2 += shift / nw;
            let along = l - l4 / nw;
            d_g = along * (dh / (g * g));
            d_dh = -along / g;
        }
        let v = l * rho1 + l4 * rho2;

        let a = eta * eta * ci / ct;
        let d_l4_l = Matrix3::from_diagonal_element(eta) + p3 * p3.transpose() * (a - eta);
        let d_l4_p = Matrix3::from_diagonal_element(ct - eta * ci) + p3 * l.transpose() * (a - eta);
        let d_p_u = (Matrix3::identity() - p3 * p3.transpose()) / norm_u;
        // ∂v/∂u: the surface normal's direction moves only l4.
        let d_u = d_l4_p * d_p_u * rho2;
        let d_l4_eta = l + p3 * (-eta * (1.0 - ci * ci) / ct - ci);

        let mut h = SMatrix::<f64, 3, 12>::zeros();
        h.fixed_columns_mut::<3>(0).copy_from(
            &(Matrix3::from_diagonal_element(rho1) + d_l4_l * rho2 + d_g * b.transpose()),
        );
        h.fixed_columns_mut::<3>(3)
            .copy_from(&(d_u + d_g * l.transpose()));
        h.set_column(6, &(l * (0.5 * speed)));
        h.set_column(7, &(l4 * (speed / (2.0 * nw))));
        h.set_column(8, &d_dh);
        h.set_column(9, &(d_u.column(0) * (1.0 + tn * tn)));
        h.set_column(10, &(d_u.column(1) * (1.0 + te * te)));
        // η = na/nw and ρ2 ∝ 1/nw.
        h.set_column(11, &((d_l4_eta * (-eta) - l4) * (rho2 / nw)));
        (v, h)
    }

    /// The footprint (zero GNSS offsets) and its Jacobian by the chain rule from the stages:
    /// `R_N` with its partials in roll, pitch and heading, the mounting's, the air beam `l3`
    /// with its partials in the prism and emitter parameters `p[12..19]`, and the water leg in
    /// N ([`ConicScanner::leg_jacobian`]) at `x = p[19..25]`.
    fn compose(
        &self,
        (r_n, d_r_n): (&Matrix3<f64>, &[Matrix3<f64>; 3]),
        m: &MountingPartials,
        (l3, d_l3): (&Vector3<f64>, &SMatrix<f64, 3, 7>),
        x: &[f64; 6],
    ) -> (Vector3<f64>, SMatrix<f64, 3, CONIC_N>) {
        // B moves with the attitude only when the surface is fixed in S.
        let scanner_frame = self.refraction == Refraction::ScannerFrame;
        let r = r_n * m.r_m;
        let b = if scanner_frame {
            r.column(2).into_owned()
        } else {
            Vector3::z()
        };
        let (v, h) = self.leg_jacobian(&(r * l3), &b, x, x[1] > 0.0);
        let h_l = h.fixed_columns::<3>(0).into_owned();
        let h_b = h.fixed_columns::<3>(3).into_owned();
        let f = r_n * m.lever_m + v;
        // ∂(R X_S)/∂θ through L = R l3 and (scanner-frame) B = R e_z, for ∂R/∂θ · (l3, e_z)
        // given as `(d_l, d_b)`.
        let through_r = |d_l: Vector3<f64>, d_b: Vector3<f64>| {
            let mut col = h_l * d_l;
            if scanner_frame {
                col += h_b * d_b;
            }
            col
        };
        let (m_l3, m_z) = (m.r_m * l3, m.r_m.column(2).into_owned());
        let mut j = SMatrix::<f64, 3, CONIC_N>::zeros();
        j[(0, 0)] = 1.0;
        j[(1, 1)] = 1.0;
        j[(2, 2)] = -1.0;
        for (k, (d, dm)) in d_r_n.iter().zip(&m.d_r_m).enumerate() {
            j.set_column(3 + k, &(d * m.lever_m + through_r(d * m_l3, d * m_z)));
            j.set_column(6 + k, &through_r(r_n * (dm * l3), r_n * dm.column(2)));
            j.set_column(9 + k, &r_n.column(k).into_owned());
        }
        j.fixed_columns_mut::<7>(12).copy_from(&(h_l * r * d_l3));
        j.fixed_columns_mut::<6>(19)
            .copy_from(&h.fixed_columns::<6>(6));
        (f, j)
    }

    /// The footprint and its Jacobian by the chain rule ([`ConicScanner::compose`]): `R_N`
    /// and `R_M` from [`rotation_zyx_with_partials`], the air beam from the scanner's nominal
    /// beam (a 7-direction dual pass for an off-nominal prism or emitter), the water leg in
    /// closed form. One 25-direction dual pass over the whole model (the trait's default)
    /// gives the same Jacobian at many times the cost; a test checks the two agree.
    fn staged_jacobian(
        &self,
        p: &SVector<f64, CONIC_N>,
    ) -> (Vector3<f64>, SMatrix<f64, 3, CONIC_N>) {
        let (r_n, d_r_n) = rotation_zyx_with_partials(p[3], p[4], p[5]);
        let mounting = MountingPartials::new(&Mounting {
            boresight_roll_rad: p[6],
            boresight_pitch_rad: p[7],
            boresight_yaw_rad: p[8],
            lever_arm_m: Vector3::new(p[9], p[10], p[11]),
        });
        let q = SVector::<f64, 7>::from([p[12], p[13], p[14], p[15], p[16], p[17], p[18]]);
        let (l3, d_l3) = self.air_beam_at(&q);
        let x = [p[19], p[20], p[21], p[22], p[23], p[24]];
        let (f, j) = self.compose((&r_n, &d_r_n), &mounting, (&l3, &d_l3), &x);
        (f + gnss_offset_ned(p[0], p[1], p[2]), j)
    }

    /// The footprint (zero GNSS offsets) and Jacobian of a pulse with observation `obs` at the
    /// attitude `body_to_ned` (`R_N`) and the prepared `mounting`: the same as
    /// [`Georeferencer::footprint_jacobian`] at [`Georeferencer::parameters`]' vector (nominal
    /// prism, emitter and water surface), with `R_N`'s partials from the matrix itself
    /// ([`zyx_partials_of`]) and the mounting's prepared once: the per-point TPU's conic kernel,
    /// one `sin_cos` (the azimuth) and a few square roots a point.
    pub fn jacobian_at_pose(
        &self,
        body_to_ned: &Matrix3<f64>,
        mounting: &MountingPartials,
        obs: &ConicObservation,
    ) -> (Vector3<f64>, SMatrix<f64, 3, CONIC_N>) {
        let d_r_n = zyx_partials_of(body_to_ned);
        let (l3, d_l3) = self.nominal_beam_at(obs.azimuth_rad);
        let x = [
            obs.time_air_s,
            obs.time_water_s,
            0.0,
            0.0,
            0.0,
            self.n_water,
        ];
        self.compose((body_to_ned, &d_r_n), mounting, (&l3, &d_l3), &x)
    }

    /// Air and water ranges (m) that put the footprint on a level water surface `height_m` below the
    /// GNSS/INS reference point and a level bottom `depth_m` below that surface.
    pub fn ranges_for_height_depth(
        &self,
        attitude: &Attitude,
        mounting: &Mounting,
        azimuth_rad: f64,
        height_m: f64,
        depth_m: f64,
    ) -> Result<(f64, f64)> {
        if !(height_m.is_finite() && height_m > 0.0) {
            return Err(Error::NotPositive {
                name: "height_m",
                value: height_m,
            });
        }
        if !(depth_m.is_finite() && depth_m >= 0.0) {
            return Err(Error::NotPositive {
                name: "depth_m",
                value: depth_m,
            });
        }
        let obs = ConicObservation {
            azimuth_rad,
            time_air_s: 0.0,
            time_water_s: 0.0,
        };
        let p = self.parameters(attitude, mounting, &obs);
        let (l3, l4) = self.beam_directions(&p);
        let r_n = attitude.body_to_ned();
        let r = r_n * mounting.scanner_to_body();
        let origin_down = (r_n * mounting.lever_arm_m).z;
        let rho1 = range_to_level(height_m - origin_down, &(r * l3), height_m)?;
        let rho2 = if depth_m == 0.0 {
            0.0
        } else {
            range_to_level(depth_m, &(r * l4), depth_m)?
        };
        Ok((rho1, rho2))
    }
}

fn check_index(name: &'static str, value: f64, allow_one: bool) -> Result<()> {
    let ok = value.is_finite() && (value > 1.0 || (allow_one && value == 1.0));
    if ok {
        Ok(())
    } else {
        Err(Error::InvalidRefractionIndex { name, value })
    }
}

/// The prism slope θf (rad) whose nominal beam leaves the prism at `exit_angle_rad` from S Z.
fn prism_slope_for_exit_angle(exit_angle_rad: f64, n_prism: f64, n_air: f64) -> Result<f64> {
    // Checked here too: a bad index would otherwise read as an unreachable exit angle.
    check_index("n_prism", n_prism, false)?;
    check_index("n_air", n_air, true)?;
    let exit = |slope: f64| nominal_exit_angle(slope, n_prism, n_air);
    // The exit angle grows monotonically with the slope up to total internal reflection.
    let (lo, _) = bisect(0.0, std::f64::consts::FRAC_PI_2, |slope| {
        exit(slope).is_finite()
    });
    let max = exit(lo);
    if !(exit_angle_rad.is_finite() && exit_angle_rad > 0.0 && exit_angle_rad < max) {
        return Err(Error::UnreachableExitAngle {
            exit_angle_deg: exit_angle_rad.to_degrees(),
            max_deg: max.to_degrees(),
        });
    }
    let (a, b) = bisect(0.0, lo, |slope| exit(slope) < exit_angle_rad);
    Ok(0.5 * (a + b))
}

/// 200 halvings of `[lo, hi]` (f64 resolution), keeping `below` true at the lower end and false
/// at the upper one; the final bracket.
fn bisect(mut lo: f64, mut hi: f64, below: impl Fn(f64) -> bool) -> (f64, f64) {
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if below(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (lo, hi)
}

fn nominal_exit_angle(slope: f64, n_prism: f64, n_air: f64) -> f64 {
    let l1 = Vector3::new(0.0, 0.0, 1.0);
    let p1 = Vector3::new(slope.sin(), 0.0, slope.cos());
    let l2 = refract(&l1, &p1, n_air / n_prism);
    let l3 = refract(&l2, &Vector3::z(), n_prism / n_air);
    l3.z.clamp(-1.0, 1.0).acos()
}

/// Distance along unit direction `dir` (NED) to a level surface `drop_m` below the start;
/// `height_m` is only for the error message.
pub(crate) fn range_to_level(drop_m: f64, dir: &Vector3<f64>, height_m: f64) -> Result<f64> {
    let dir = dir.normalize();
    if dir.z <= 1e-9 || drop_m <= 0.0 {
        return Err(Error::BeamMissesSurface {
            height_m,
            elevation_deg: (-dir.z).clamp(-1.0, 1.0).asin().to_degrees(),
        });
    }
    Ok(drop_m / dir.z)
}

/// The rays of one pulse, scanner frame.
struct Rays<D> {
    /// In air, after the prism.
    l3: Vector3<D>,
    /// In water, after the surface.
    l4: Vector3<D>,
    /// The untilted surface normal (down): S Z (`scanner-frame`) or the local vertical (`level`).
    base: Vector3<D>,
}

/// Raw observation of one conic-scanner pulse.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConicObservation {
    /// Scan azimuth θaz of the prism, rad (0 = forward, positive towards the right wing).
    pub azimuth_rad: f64,
    /// Two-way travel time in air Δt1, s.
    pub time_air_s: f64,
    /// Two-way travel time in water Δt2, s (0 for a topographic or water-surface return).
    pub time_water_s: f64,
}

impl Georeferencer<CONIC_N> for ConicScanner {
    type Observation = ConicObservation;

    const SOURCES: [Source; CONIC_N] = platform_then(ConicScanner::SCANNER_SOURCES);

    fn parameters(
        &self,
        a: &Attitude,
        m: &Mounting,
        o: &ConicObservation,
    ) -> SVector<f64, CONIC_N> {
        let mut p = platform_parameters(a, m);
        p[12] = self.prism_slope_rad;
        p[16] = o.azimuth_rad;
        p[19] = o.time_air_s;
        p[20] = o.time_water_s;
        p[24] = self.n_water;
        p
    }

    fn footprint_ned<D: Scalar>(&self, p: &SVector<D, CONIC_N>) -> Vector3<D> {
        let rays = self.rays(p);
        let speed = c::<D>(SPEED_OF_LIGHT_AIR_M_PER_S);
        let mut rho1 = speed * p[19] * c::<D>(0.5);
        let mut rho2 = speed * p[20] / (p[24] * c::<D>(2.0));
        if p[20] > D::zero() {
            // The surface δh above where Δt1 puts it, total time held: the refraction point
            // moves δh / cos θi back along the air beam and the water leg gains that optical
            // path, ρ1 + nw ρ2 = const.
            let shift = p[21] / rays.l3.dot(&rays.base);
            rho1 -= shift;
            rho2 += shift / p[24];
        }
        let x_s = rays.l3 * rho1 + rays.l4 * rho2;
        let r_n = rotation_zyx(p[3], p[4], p[5]);
        let r_m = rotation_zyx(p[6], p[7], p[8]);
        let lever = Vector3::new(p[9], p[10], p[11]);
        gnss_offset_ned(p[0], p[1], p[2]) + r_n * (r_m * x_s + lever)
    }

    /// The same Jacobian as the default, composed by the chain rule from three stages (the
    /// rotation partials, the air beam from the scanner's nominal beam, the water leg in N by
    /// a small dual pass): the conic TPU's kernel, many times cheaper than the default.
    fn footprint_jacobian(
        &self,
        p: &SVector<f64, CONIC_N>,
    ) -> (Vector3<f64>, SMatrix<f64, 3, CONIC_N>) {
        self.staged_jacobian(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn czmil(mode: Refraction) -> ConicScanner {
        ConicScanner::from_exit_angle(
            20f64.to_radians(),
            DEFAULT_N_PRISM,
            DEFAULT_N_AIR,
            DEFAULT_N_WATER,
            mode,
        )
        .unwrap()
    }

    #[test]
    fn exit_angle_20_deg_gives_prism_slope_39_16_deg() {
        let s = czmil(Refraction::ScannerFrame);
        // Li et al. (2016) §1.1: 39.16°; to more digits from the closed form
        // θ4 = asin(nf/na · sin(θf − asin(na/nf · sin θf))).
        assert_relative_eq!(s.prism_slope_rad().to_degrees(), 39.1603, epsilon = 5e-5);
        let tf = s.prism_slope_rad();
        let closed = (DEFAULT_N_PRISM / DEFAULT_N_AIR
            * (tf - (DEFAULT_N_AIR / DEFAULT_N_PRISM * tf.sin()).asin()).sin())
        .asin();
        assert_relative_eq!(closed.to_degrees(), 20.0, epsilon = 1e-9);
    }

    #[test]
    fn refraction_keeps_unit_length_and_obeys_snell() {
        let l = Vector3::new(0.3, -0.2, 0.9).normalize();
        let n = Vector3::new(0.1, 0.05, 1.0).normalize();
        let eta = 1.0003 / 1.33;
        let t = refract(&l, &n, eta);
        assert_relative_eq!(t.norm(), 1.0, epsilon = 1e-14);
        let sin_i = l.cross(&n).norm();
        let sin_t = t.cross(&n).norm();
        assert_relative_eq!(sin_i * 1.0003, sin_t * 1.33, epsilon = 1e-14);
        // Incident ray, normal and refracted ray are coplanar.
        assert_relative_eq!(l.cross(&n).dot(&t), 0.0, epsilon = 1e-15);
    }

    #[test]
    fn circle_on_level_water_at_level_flight() {
        let s = czmil(Refraction::ScannerFrame);
        for az in [0.0f64, 45.0, 90.0, 200.0] {
            let (r1, _) = s
                .ranges_for_height_depth(
                    &Attitude::default(),
                    &Mounting::default(),
                    az.to_radians(),
                    400.0,
                    0.0,
                )
                .unwrap();
            let obs = ConicObservation {
                azimuth_rad: az.to_radians(),
                time_air_s: s.time_air_s(r1),
                time_water_s: 0.0,
            };
            let f =
                s.footprint_ned(&s.parameters(&Attitude::default(), &Mounting::default(), &obs));
            assert_relative_eq!(f.z, 400.0, epsilon = 1e-9);
            let radius = (f.x * f.x + f.y * f.y).sqrt();
            assert_relative_eq!(radius, 400.0 * 20f64.to_radians().tan(), epsilon = 1e-6);
            // Azimuth 0 looks forward, 90° to the right wing.
            assert_relative_eq!(
                f.y.atan2(f.x).to_degrees().rem_euclid(360.0),
                az,
                epsilon = 1e-6
            );
        }
    }

    #[test]
    fn modes_agree_at_level_attitude_and_differ_with_roll() {
        let sf = czmil(Refraction::ScannerFrame);
        let lv = czmil(Refraction::Level);
        let obs = ConicObservation {
            azimuth_rad: 0.3,
            time_air_s: sf.time_air_s(425.7),
            time_water_s: sf.time_water_s(51.7),
        };
        let m = Mounting::default();
        let a0 = Attitude::default();
        assert_relative_eq!(
            sf.footprint_ned(&sf.parameters(&a0, &m, &obs)),
            lv.footprint_ned(&lv.parameters(&a0, &m, &obs)),
            epsilon = 1e-9
        );
        let a1 = Attitude::from_degrees(5.0, 0.0, 0.0);
        let d = sf.footprint_ned(&sf.parameters(&a1, &m, &obs))
            - lv.footprint_ned(&lv.parameters(&a1, &m, &obs));
        assert!(d.norm() > 0.1, "5° roll must change the in-water path: {d}");
    }

    fn sounding(s: &ConicScanner, a: &Attitude) -> SVector<f64, CONIC_N> {
        let obs = ConicObservation {
            azimuth_rad: 0.7,
            time_air_s: s.time_air_s(425.7),
            time_water_s: s.time_water_s(30.0),
        };
        s.parameters(a, &Mounting::default(), &obs)
    }

    #[test]
    fn water_surface_height_holds_the_total_travel_time() {
        for mode in [Refraction::ScannerFrame, Refraction::Level] {
            let s = czmil(mode);
            let a = Attitude::from_degrees(1.0, -2.0, 30.0);
            let p = sounding(&s, &a);
            let mut q = p;
            q[21] = 0.2; // the surface 20 cm higher
            let (f0, f1) = (s.footprint_ned(&p), s.footprint_ned(&q));
            // Same beam: the refraction point moves up the air leg by 0.2 / cos θi, the water
            // leg gains 0.2 / (cos θi · nw); the bottom point moves by that difference.
            let (l3, l4) = s.beam_directions(&p);
            let r = rotation_zyx(a.roll_rad, a.pitch_rad, a.heading_rad);
            let base = match mode {
                Refraction::ScannerFrame => Vector3::z(),
                Refraction::Level => r.transpose() * Vector3::z(),
            };
            let d = 0.2 / l3.dot(&base);
            let want = r * (l4 * (d / DEFAULT_N_WATER) - l3 * d);
            assert_relative_eq!(f1 - f0, want, epsilon = 1e-9);
            // A topographic return does not move.
            let (mut t0, mut t1) = (p, q);
            t0[20] = 0.0;
            t1[20] = 0.0;
            assert_eq!(s.footprint_ned(&t0), s.footprint_ned(&t1));
        }
    }

    #[test]
    fn level_slope_is_snell_at_the_tilted_surface() {
        let s = czmil(Refraction::Level);
        let a = Attitude::from_degrees(2.0, 1.0, 10.0);
        let mut p = sounding(&s, &a);
        p[22] = 0.03;
        p[23] = -0.02;
        // Independently: the air beam in N refracted at the normal ∝ [tan sN, tan sE, 1].
        let r = rotation_zyx(a.roll_rad, a.pitch_rad, a.heading_rad);
        let (l3, l4) = s.beam_directions(&p);
        let n = Vector3::new(0.03f64.tan(), (-0.02f64).tan(), 1.0).normalize();
        let want = refract(&(r * l3), &n, DEFAULT_N_AIR / DEFAULT_N_WATER);
        assert_relative_eq!(r * l4, want, epsilon = 1e-12);
    }

    #[test]
    fn n_water_enters_snell_and_the_water_range() {
        let s = czmil(Refraction::Level);
        let a = Attitude::default();
        let mut p = sounding(&s, &a);
        let f0 = s.footprint_ned(&p);
        p[24] = 1.34;
        let other = ConicScanner::new(
            s.prism_slope_rad(),
            DEFAULT_N_PRISM,
            DEFAULT_N_AIR,
            1.34,
            Refraction::Level,
        )
        .unwrap();
        let q = other.parameters(
            &a,
            &Mounting::default(),
            &ConicObservation {
                azimuth_rad: 0.7,
                time_air_s: s.time_air_s(425.7),
                time_water_s: s.time_water_s(30.0),
            },
        );
        assert_relative_eq!(s.footprint_ned(&p), other.footprint_ned(&q), epsilon = 1e-9);
        // A larger index: a shorter, steeper water leg (the bottom comes up).
        assert!(s.footprint_ned(&p).z < f0.z);
    }

    /// A mounting with every boresight angle and lever component non-zero.
    fn mounting() -> Mounting {
        Mounting {
            boresight_roll_rad: 0.01,
            boresight_pitch_rad: -0.02,
            boresight_yaw_rad: 0.015,
            lever_arm_m: Vector3::new(0.3, -0.2, 1.1),
        }
    }

    /// Asserts that `(f, j)` is the footprint and Jacobian of one 25-direction dual pass over
    /// the whole model at `p` (every column within 1e-9 of its length) and returns that pass's
    /// Jacobian.
    fn assert_one_pass_agrees(
        s: &ConicScanner,
        p: &SVector<f64, CONIC_N>,
        (f, j): (Vector3<f64>, SMatrix<f64, 3, CONIC_N>),
    ) -> SMatrix<f64, 3, CONIC_N> {
        let (f1, j1) = jacobian(
            |q: SVector<DualSVec64<CONIC_N>, CONIC_N>| s.footprint_ned(&q),
            p,
        );
        assert_relative_eq!(f1, f, epsilon = 1e-9);
        for k in 0..CONIC_N {
            let (a, b) = (j1.column(k), j.column(k));
            assert!(
                (a - b).norm() <= 1e-9 * a.norm().max(1e-300)
                    || (a.norm() == 0.0 && b.norm() == 0.0),
                "{:?} column {k}: {a} vs {b}",
                s.refraction()
            );
        }
        j1
    }

    #[test]
    fn staged_jacobian_equals_one_pass_dual_jacobian() {
        for mode in [Refraction::ScannerFrame, Refraction::Level] {
            let s = czmil(mode);
            let m = mounting();
            let cases = [
                (
                    Attitude::from_degrees(1.0, -2.0, 30.0),
                    s.time_water_s(30.0),
                ),
                (
                    Attitude::from_degrees(-4.0, 3.0, 250.0),
                    s.time_water_s(5.0),
                ),
                (Attitude::from_degrees(2.0, 1.0, 10.0), 0.0),
            ];
            for ((att, water_s), nominal) in cases.into_iter().flat_map(|c| [(c, true), (c, false)])
            {
                let obs = ConicObservation {
                    azimuth_rad: 2.3,
                    time_air_s: s.time_air_s(425.7),
                    time_water_s: water_s,
                };
                let mut p = s.parameters(&att, &m, &obs);
                // The nominal prism and emitter take the scanner's cached beam; off-nominal
                // ones, and a tilted surface, use every term of the chain.
                if !nominal {
                    for (k, v) in [
                        (13, 0.002),
                        (14, -0.003),
                        (15, 0.004),
                        (17, 0.001),
                        (18, 0.5),
                    ] {
                        p[k] = v;
                    }
                    (p[21], p[22], p[23]) = (0.1, 0.03, -0.02);
                }
                assert_eq!(
                    nominal,
                    s.nominal_prism(p[16]).as_slice() == &p.as_slice()[12..19]
                );
                let j1 = assert_one_pass_agrees(&s, &p, s.footprint_jacobian(&p));
                // Not vacuous: the surface and attitude columns move the point.
                assert!(j1.column(3).norm() > 1.0 && j1.column(12).norm() > 1.0);
                assert!(
                    j1.column(17).norm() > 1.0,
                    "the emitter zenith moves the point"
                );
                assert_eq!(water_s > 0.0, j1.column(21).norm() > 0.1);
            }
        }
    }

    #[test]
    fn closed_form_water_leg_equals_its_dual_pass() {
        // Off-nominal on purpose: tilted surface, a surface-height shift, another index; the
        // beam and normal of a 20° cone through a rolled scanner.
        let l = Vector3::new(0.21, -0.28, 0.93).normalize();
        let b = Vector3::new(-0.03, 0.05, 1.0).normalize();
        for mode in [Refraction::ScannerFrame, Refraction::Level] {
            let s = czmil(mode);
            for (x, wet) in [
                ([2.8e-6, 3.1e-7, 0.12, 0.02, -0.035, 1.337], true),
                ([2.8e-6, 1.0e-7, 0.0, 0.0, 0.0, DEFAULT_N_WATER], true),
                ([2.8e-6, 0.0, 0.3, 0.01, 0.0, DEFAULT_N_WATER], false),
            ] {
                let y0 = SVector::<f64, 12>::from_fn(|i, _| match i {
                    0..3 => l[i],
                    3..6 => b[i - 3],
                    _ => x[i - 6],
                });
                let (v1, h1) = jacobian(
                    |y: SVector<DualSVec64<12>, 12>| {
                        s.leg_ned_at(
                            &Vector3::new(y[0], y[1], y[2]),
                            &Vector3::new(y[3], y[4], y[5]),
                            &[y[6], y[7], y[8], y[9], y[10], y[11]],
                            wet,
                        )
                    },
                    &y0,
                );
                let (v2, h2) = s.leg_jacobian(&l, &b, &x, wet);
                assert_relative_eq!(v1, v2, epsilon = 1e-12);
                for k in 0..12 {
                    let (a, c) = (h1.column(k), h2.column(k));
                    assert!(
                        (a - c).norm() <= 1e-12 * a.norm().max(1.0),
                        "{mode:?} {x:?} column {k}: {a} vs {c}"
                    );
                }
                // Not vacuous: with a water leg the slope and index columns move the point,
                // and the height column exactly when the leg is wet.
                if x[1] > 0.0 {
                    assert!(h1.column(9).norm() > 1.0 && h1.column(11).norm() > 1.0);
                }
                assert_eq!(wet, h1.column(8).norm() > 0.1);
            }
        }
    }

    #[test]
    fn jacobian_at_pose_equals_the_one_pass_dual_jacobian() {
        for mode in [Refraction::ScannerFrame, Refraction::Level] {
            let s = czmil(mode);
            let m = mounting();
            let prepared = MountingPartials::new(&m);
            for (att, water_s, az) in [
                (
                    Attitude::from_degrees(1.0, -2.0, 30.0),
                    s.time_water_s(30.0),
                    2.3,
                ),
                (
                    Attitude::from_degrees(-4.0, 3.0, 250.0),
                    s.time_water_s(5.0),
                    -0.4,
                ),
                (Attitude::from_degrees(2.0, 1.0, -170.0), 0.0, 3.1),
            ] {
                let obs = ConicObservation {
                    azimuth_rad: az,
                    time_air_s: s.time_air_s(425.7),
                    time_water_s: water_s,
                };
                let p = s.parameters(&att, &m, &obs);
                let j1 = assert_one_pass_agrees(
                    &s,
                    &p,
                    s.jacobian_at_pose(&att.body_to_ned(), &prepared, &obs),
                );
                // The water terms are there at the nominal surface.
                assert_eq!(water_s > 0.0, j1.column(21).norm() > 0.1);
                assert!(j1.column(22).norm() > 1.0 || water_s == 0.0);
            }
        }
    }

    #[test]
    fn nominal_beams_are_the_rays_beams() {
        for mode in [Refraction::ScannerFrame, Refraction::Level] {
            let s = czmil(mode);
            let m = Mounting {
                boresight_roll_rad: 0.01,
                boresight_pitch_rad: -0.02,
                boresight_yaw_rad: 0.015,
                lever_arm_m: Vector3::zeros(),
            };
            let a = Attitude::from_degrees(3.0, -1.0, 40.0);
            for az in [0.0, 1.2, -2.9] {
                let obs = ConicObservation {
                    azimuth_rad: az,
                    time_air_s: 0.0,
                    time_water_s: 0.0,
                };
                let (l3, l4) = s.beam_directions(&s.parameters(&a, &m, &obs));
                let r = a.body_to_ned() * m.scanner_to_body();
                let (n3, n4) = s.nominal_beams(az, &r);
                assert_relative_eq!(l3, n3, epsilon = 1e-15);
                assert_relative_eq!(l4, n4, epsilon = 1e-15);
                // Snell at the surface: na sin θa = nw sin θw about its normal in S.
                let up = match mode {
                    Refraction::ScannerFrame => Vector3::z(),
                    Refraction::Level => r.row(2).transpose(),
                };
                let (sa, sw) = (n3.cross(&up).norm(), n4.cross(&up).norm());
                assert_relative_eq!(DEFAULT_N_AIR * sa, DEFAULT_N_WATER * sw, epsilon = 1e-14);
            }
        }
    }

    #[test]
    fn nominal_air_beam_is_the_rays_beam_at_azimuth_0() {
        for mode in [Refraction::ScannerFrame, Refraction::Level] {
            let s = czmil(mode);
            let obs = ConicObservation {
                azimuth_rad: 0.0,
                time_air_s: 0.0,
                time_water_s: 0.0,
            };
            let a = Attitude::from_degrees(3.0, -1.0, 40.0);
            let p = s.parameters(&a, &Mounting::default(), &obs);
            assert_eq!(s.nominal_air_beam(), s.beam_directions(&p).0);
            // 20° off the S Z axis.
            assert_relative_eq!(
                s.nominal_air_beam().z.acos().to_degrees(),
                20.0,
                epsilon = 1e-9
            );
        }
    }

    #[test]
    fn bad_indices_and_slopes_are_refused() {
        assert!(matches!(
            ConicScanner::new(0.6, 1.461, 1.0003, 0.9, Refraction::Level),
            Err(Error::InvalidRefractionIndex {
                name: "n_water",
                ..
            })
        ));
        assert!(ConicScanner::new(1.55, 1.461, 1.0003, 1.33, Refraction::Level).is_err());
        assert!(matches!(
            ConicScanner::from_exit_angle(
                90.5f64.to_radians(),
                1.461,
                1.0003,
                1.33,
                Refraction::Level
            ),
            Err(Error::UnreachableExitAngle { .. })
        ));
    }
}
