//! The analytic scene: terrain with gentle relief, flat paved areas with painted markings,
//! gable-roofed buildings, circular targets and a water basin with a sloping bottom.
//!
//! Everything is defined in local grid coordinates `x` = easting − origin easting,
//! `y` = northing − origin northing (metres of the UTM grid) and ellipsoidal height `h` (metres).
//! The terrain extends beyond the scene rectangle; the rectangle only bounds the objects.
//!
//! A ray is handed to the scene as the exact curve it follows in (x, y, h): because the map from
//! the local NED frame to grid coordinates is smooth, the ray is a parabola
//! `g(ρ) = A + B ρ + C ρ²` in (x, y, h) (lidarqa-io's `NedToGrid`), which planes meet at the root
//! of a quadratic and the terrain at the root found by Newton's method to rounding (the secant
//! method when it does not converge). Consecutive rays of a scan are a [`Sweep`]: each starts its
//! search from the last ones' ground, and the relief's sines and cosines near the last hit come
//! from its own by angle addition, which glibc's `sin_cos` per evaluation cost several times.

use crate::check::{finite, non_negative, positive};
use crate::error::{Error, Result};
use crate::ray::{Curve, Hit, dot};
use crate::scene_file::SceneFile;
use crate::vegetation::Vegetation;
use std::f64::consts::PI;

/// ASPRS class of terrain and paved areas (ground).
pub const CLASS_GROUND: u8 = 2;
/// ASPRS class of building roofs and walls.
pub const CLASS_BUILDING: u8 = 6;
pub use lidarqa_io::{CLASS_BATHYMETRY, CLASS_WATER_SURFACE};
/// Class of target-plate returns: 64, the first user-definable class of LAS 1.4.
pub const CLASS_TARGET: u8 = 64;

/// Reflectivity of grass / bare terrain.
pub const REFLECTIVITY_TERRAIN: f64 = 0.30;
/// Reflectivity of asphalt.
pub const REFLECTIVITY_ASPHALT: f64 = 0.10;
/// Reflectivity of white road paint.
pub const REFLECTIVITY_PAINT: f64 = 0.70;
/// Reflectivity of roofs.
pub const REFLECTIVITY_ROOF: f64 = 0.35;
/// Reflectivity of walls.
pub const REFLECTIVITY_WALL: f64 = 0.25;
/// Reflectivity of the high-reflectivity target plates.
pub const REFLECTIVITY_TARGET: f64 = 0.95;
/// Reflectivity of the water surface.
pub const REFLECTIVITY_WATER: f64 = 0.05;
/// Reflectivity of the seabed before attenuation in the water column.
pub const REFLECTIVITY_BED: f64 = 0.25;
/// Diffuse attenuation of the water column, 1/m (two-way loss e^(−2 k d)).
pub const WATER_ATTENUATION_PER_M: f64 = 0.08;

/// Width over which a paved area blends into the terrain, m.
const PAVED_BLEND_M: f64 = 5.0;

/// Step of the forward differences of the ground's slope at a hit, m.
const GRADIENT_STEP_M: f64 = 0.5;

/// What consecutive rays of one sweep share ([`Scene::sweep`], [`Scene::trace_in`]): the
/// heights of the last two ground hits, from which the next ray's root search starts (a
/// neighbouring pulse's ground is centimetres away, so one Newton step lands within rounding),
/// the relief's phases at the last hit, the paved areas near it, the height range of the objects
/// and the sines and cosines of the relief's phase steps over the slope's forward differences.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sweep {
    /// The heights of the last two ground hits, m.
    ground_m: [Option<f64>; 2],
    /// The paved areas that may reach within [`PAVED_NEAR_M`] of a point: (the point, mask).
    paved: Option<([f64; 2], u64)>,
    /// The lowest and the highest height of the buildings and raised plates, m.
    objects_m: Option<[f64; 2]>,
    anchor: Option<Anchor>,
    steps: [(f64, f64); 3],
}

/// The relief's phases at `xy`: those of points within [`ANCHOR_REACH_RAD`] of phase from it
/// follow by angle addition with a short Taylor series instead of three `sin_cos`, the
/// neighbouring pulses' ground points too. Each hit's phases become the next anchor, `chain`
/// counting the additions since the last exact evaluation (each adds a rounding error, so after
/// [`ANCHOR_CHAIN`] the phases are evaluated again).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Anchor {
    xy: [f64; 2],
    phases: Phases,
    chain: u32,
}

/// Every paved area, as the mask of `Scene::pave_and_cut`.
const ALL_PAVED: u64 = u64::MAX;

/// Half size of the square around a ray's ground about which [`Sweep`] keeps the paved areas
/// that may reach into it, m.
const PAVED_NEAR_M: f64 = 32.0;

impl Sweep {
    /// The mask of the paved areas that may reach (x, y): the kept one when (x, y) is in its
    /// square, else all.
    #[inline]
    fn paved_at(&self, x: f64, y: f64) -> u64 {
        match self.paved {
            Some((c, mask))
                if (x - c[0]).abs() <= PAVED_NEAR_M && (y - c[1]).abs() <= PAVED_NEAR_M =>
            {
                mask
            }
            _ => ALL_PAVED,
        }
    }
}

/// Largest phase difference bridged from an [`Anchor`], rad: the Taylor series of
/// [`small_sin_cos`] is exact to rounding up to it.
pub(crate) const ANCHOR_REACH_RAD: f64 = 0.01;

/// Angle additions chained from one exact evaluation before the next (a few ulp each).
pub(crate) const ANCHOR_CHAIN: u32 = 16;

/// Painted markings of a paved area.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Markings {
    /// A zebra crossing (0.5 m stripes, 0.5 m gaps, 4 m long, across the middle) and edge lines.
    Zebra,
    /// A dashed centre line (3 m dashes, 3 m gaps, 0.15 m wide) and edge lines.
    CentreLine,
    /// No paint.
    None,
}

/// A flat paved rectangle.
#[derive(Debug, Clone, PartialEq)]
pub struct Paved {
    /// Centre, local m.
    pub center_m: [f64; 2],
    /// Unit vector of the length axis in (x, y).
    pub axis: [f64; 2],
    /// Half length and half width, m.
    pub half_m: [f64; 2],
    /// Ellipsoidal height of the pavement, m.
    pub height_m: f64,
    /// Markings.
    pub markings: Markings,
}

/// A rectangular building with a symmetric gable roof.
#[derive(Debug, Clone, PartialEq)]
pub struct Building {
    /// Centre, local m.
    pub center_m: [f64; 2],
    /// Unit vector of the ridge in (x, y).
    pub axis: [f64; 2],
    /// Half length (along the ridge) and half width, m.
    pub half_m: [f64; 2],
    /// Ellipsoidal height of the floor (the ground at the centre), m.
    pub base_m: f64,
    /// Eave height above the floor, m.
    pub eave_m: f64,
    /// tan(roof slope).
    pub tan_slope: f64,
}

impl Building {
    /// Ellipsoidal height of the ridge, m.
    pub fn ridge_height_m(&self) -> f64 {
        self.base_m + self.eave_m + self.half_m[1] * self.tan_slope
    }
}

/// A horizontal circular target plate.
#[derive(Debug, Clone, PartialEq)]
pub struct Target {
    /// Target id.
    pub id: String,
    /// Centre, local m.
    pub center_m: [f64; 2],
    /// Radius, m.
    pub radius_m: f64,
    /// Ellipsoidal height of the plate, m (the ground's at the centre for a painted disc).
    pub height_m: f64,
    /// A disc of paint on the ground rather than a raised plate.
    pub painted: bool,
}

/// The water basin.
#[derive(Debug, Clone, PartialEq)]
pub struct Water {
    /// Minimum corner, local m.
    pub min_m: [f64; 2],
    /// Maximum corner, local m.
    pub max_m: [f64; 2],
    /// Ellipsoidal height of the still water surface, m.
    pub level_m: f64,
    /// Basin cut at the west edge and at the east edge, m.
    pub depth_m: [f64; 2],
    /// Bank width, m.
    pub bank_m: f64,
    /// The wave trains summed on the still level (empty: a flat surface).
    pub waves: Vec<Wave>,
}

/// One sinusoidal wave train: height `A sin(k (x, y)·d + φ)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wave {
    /// Amplitude A, m.
    pub amplitude_m: f64,
    /// Wave number k = 2π/λ, rad/m.
    pub wave_number_per_m: f64,
    /// Unit vector d of the travel direction in (x, y).
    pub dir: [f64; 2],
    /// Phase φ at the local origin, rad.
    pub phase_rad: f64,
}

impl Water {
    /// Largest height of the surface above the still level, m (Σ A).
    pub fn max_wave_m(&self) -> f64 {
        self.waves.iter().map(|w| w.amplitude_m).sum()
    }

    /// RMS surface slope (as the angle atan ∂h/∂x ≈ ∂h/∂x) towards grid east and grid north,
    /// rad, over an area large against the wavelengths: `√(Σ A² k² d² / 2)` per axis (the trains'
    /// cross terms average out when their wave vectors differ). With small slopes this is the σ
    /// of the sensor file's `water_surface_slope_east_deg` / `_north_deg` (grid and true north
    /// differ by the meridian convergence, a fraction of a degree).
    pub fn slope_sigma_rad(&self) -> [f64; 2] {
        let var = |axis: usize| {
            self.waves
                .iter()
                .map(|w| (w.amplitude_m * w.wave_number_per_m * w.dir[axis]).powi(2) / 2.0)
                .sum::<f64>()
        };
        [var(0).sqrt(), var(1).sqrt()]
    }

    /// RMS height of the surface about its still level, m: `√(Σ A² / 2)`.
    pub fn height_sigma_m(&self) -> f64 {
        (self
            .waves
            .iter()
            .map(|w| w.amplitude_m.powi(2))
            .sum::<f64>()
            / 2.0)
            .sqrt()
    }
}

/// The checked analytic scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// Minimum corner (local easting, northing), m.
    pub min_m: [f64; 2],
    /// Maximum corner, m.
    pub max_m: [f64; 2],
    /// Ellipsoidal height of the undisturbed ground, m.
    pub ground_height_m: f64,
    /// Relief amplitude, m.
    pub relief_m: f64,
    /// Relief wave number 2π/λ, rad/m.
    pub relief_k_per_m: f64,
    /// Paved areas.
    pub paved: Vec<Paved>,
    /// Buildings.
    pub buildings: Vec<Building>,
    /// Targets.
    pub targets: Vec<Target>,
    /// Water basin.
    pub water: Option<Water>,
    /// Survey σ of control points (horizontal, vertical), m.
    pub control_sigma_m: [f64; 2],
    /// Vegetation layer (canopy returns above the ground return).
    pub vegetation: Option<Vegetation>,
}

/// `3t² − 2t³` on t clamped to [0, 1], and its derivative.
#[inline]
fn smoothstep_slope(t: f64) -> (f64, f64) {
    let t = t.clamp(0.0, 1.0);
    (t * t * (3.0 - 2.0 * t), 6.0 * t * (1.0 - t))
}

/// The sines and cosines of the relief's three phases at a point (see `Scene::relief_phases`).
type Phases = [(f64, f64); 3];

/// [`Phases`] with the length of their chain of angle additions (see [`Anchor`]).
type Phased = (Phases, u32);

/// A ground root: the range, m, and the relief's phases there.
type NewtonRoot = (f64, Phased);

/// (sin, cos) of |ε| ≤ [`ANCHOR_REACH_RAD`] by their Taylor series to ε⁷ and ε⁸ (the next terms
/// are below 10⁻²¹ relative).
#[inline]
pub(crate) fn small_sin_cos(e: f64) -> (f64, f64) {
    // Multiplications by the reciprocals (rounded, in terms below 10⁻⁴ of the result).
    let e2 = e * e;
    (
        e * (1.0 - e2 * (1.0 / 6.0) * (1.0 - e2 * (1.0 / 20.0) * (1.0 - e2 * (1.0 / 42.0)))),
        1.0 - e2
            * 0.5
            * (1.0 - e2 * (1.0 / 12.0) * (1.0 - e2 * (1.0 / 30.0) * (1.0 - e2 * (1.0 / 56.0)))),
    )
}

/// (sin, cos) of a + b from those of a and of b.
#[inline]
pub(crate) fn add_angles((sa, ca): (f64, f64), (sb, cb): (f64, f64)) -> (f64, f64) {
    (sa * cb + ca * sb, ca * cb - sa * sb)
}

fn unit_from_azimuth(deg: f64) -> [f64; 2] {
    let (s, c) = deg.to_radians().sin_cos();
    [s, c]
}

impl Scene {
    /// Check a `[scene]` table.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] for a bad number, [`Error::OutsideScene`] for an object (or a
    /// corner of it) outside the scene rectangle.
    pub fn from_file(f: &SceneFile) -> Result<Scene> {
        for (k, v) in [
            ("scene.min_m[0]", f.min_m[0]),
            ("scene.min_m[1]", f.min_m[1]),
            ("scene.max_m[0]", f.max_m[0]),
            ("scene.max_m[1]", f.max_m[1]),
        ] {
            finite(k, v)?;
        }
        if f.max_m[0] <= f.min_m[0] || f.max_m[1] <= f.min_m[1] {
            return Err(Error::InvalidValue {
                key: "scene.max_m".into(),
                value: format!("[{}, {}]", f.max_m[0], f.max_m[1]),
                reason: format!(
                    "must be greater than scene.min_m = [{}, {}] in both coordinates",
                    f.min_m[0], f.min_m[1]
                ),
            });
        }
        let ground = finite("scene.ground_height_m", f.ground_height_m)?;
        let relief = non_negative("scene.relief_m", f.relief_m)?;
        let lambda = positive("scene.relief_wavelength_m", f.relief_wavelength_m)?;
        let sh = non_negative(
            "scene.control_sigma_horizontal_m",
            f.control_sigma_horizontal_m,
        )?;
        let sv = non_negative("scene.control_sigma_vertical_m", f.control_sigma_vertical_m)?;
        let mut scene = Scene {
            min_m: f.min_m,
            max_m: f.max_m,
            ground_height_m: ground,
            relief_m: relief,
            relief_k_per_m: 2.0 * PI / lambda,
            paved: Vec::new(),
            buildings: Vec::new(),
            targets: Vec::new(),
            water: None,
            control_sigma_m: [sh, sv],
            vegetation: f
                .vegetation
                .as_ref()
                .map(Vegetation::from_file)
                .transpose()?,
        };
        let inside = |key: &str, what: &str, p: [f64; 2]| -> Result<()> {
            let ok = p[0].is_finite()
                && p[1].is_finite()
                && p[0] >= f.min_m[0]
                && p[0] <= f.max_m[0]
                && p[1] >= f.min_m[1]
                && p[1] <= f.max_m[1];
            if ok {
                Ok(())
            } else {
                Err(Error::OutsideScene {
                    key: key.into(),
                    what: what.into(),
                    position_m: p,
                    min_m: f.min_m,
                    max_m: f.max_m,
                })
            }
        };
        let corners = |c: [f64; 2], axis: [f64; 2], half: [f64; 2]| {
            let across = [axis[1], -axis[0]];
            [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)].map(|(su, sv)| {
                [
                    c[0] + su * half[0] * axis[0] + sv * half[1] * across[0],
                    c[1] + su * half[0] * axis[1] + sv * half[1] * across[1],
                ]
            })
        };
        for (i, p) in f.paved.iter().enumerate() {
            let key = format!("scene.paved[{i}]");
            inside(&key, "paved area centre", p.center_m)?;
            let l = positive(&format!("{key}.size_m[0]"), p.size_m[0])?;
            let w = positive(&format!("{key}.size_m[1]"), p.size_m[1])?;
            let axis = unit_from_azimuth(finite(&format!("{key}.azimuth_deg"), p.azimuth_deg)?);
            for c in corners(p.center_m, axis, [l / 2.0, w / 2.0]) {
                inside(&key, "paved area corner", c)?;
            }
            let markings = match p.markings.as_str() {
                "zebra" => Markings::Zebra,
                "centre-line" => Markings::CentreLine,
                "none" => Markings::None,
                other => {
                    return Err(Error::InvalidValue {
                        key: format!("{key}.markings"),
                        value: format!("{other:?}"),
                        reason: "must be \"zebra\", \"centre-line\" or \"none\"".into(),
                    });
                }
            };
            let height_m = scene.relief_height(p.center_m[0], p.center_m[1]);
            scene.paved.push(Paved {
                center_m: p.center_m,
                axis,
                half_m: [l / 2.0, w / 2.0],
                height_m,
                markings,
            });
        }
        if let Some(w) = &f.water {
            let key = "scene.water";
            inside(key, "water basin corner", w.min_m)?;
            inside(key, "water basin corner", w.max_m)?;
            if w.max_m[0] <= w.min_m[0] || w.max_m[1] <= w.min_m[1] {
                return Err(Error::InvalidValue {
                    key: "scene.water.max_m".into(),
                    value: format!("[{}, {}]", w.max_m[0], w.max_m[1]),
                    reason: "must be greater than scene.water.min_m in both coordinates".into(),
                });
            }
            let level = finite("scene.water.level_m", w.level_m)?;
            let d0 = non_negative("scene.water.shore_depth_m", w.shore_depth_m)?;
            let d1 = non_negative("scene.water.max_depth_m", w.max_depth_m)?;
            let bank = positive("scene.water.bank_width_m", w.bank_width_m)?;
            let amp = non_negative("scene.water.wave_amplitude_m", w.wave_amplitude_m)?;
            let wl = positive("scene.water.wave_length_m", w.wave_length_m)?;
            if amp > 0.1 * wl {
                return Err(Error::InvalidValue {
                    key: "scene.water.wave_amplitude_m".into(),
                    value: amp.to_string(),
                    reason: format!("must be at most a tenth of wave_length_m = {wl}"),
                });
            }
            let mut waves = Vec::with_capacity(w.waves.len() + 1);
            if amp > 0.0 {
                waves.push(Wave {
                    amplitude_m: amp,
                    wave_number_per_m: 2.0 * PI / wl,
                    dir: unit_from_azimuth(finite(
                        "scene.water.wave_azimuth_deg",
                        w.wave_azimuth_deg,
                    )?),
                    phase_rad: 0.0,
                });
            }
            for (i, t) in w.waves.iter().enumerate() {
                let key = format!("scene.water.waves[{i}]");
                let a = non_negative(&format!("{key}.amplitude_m"), t.amplitude_m)?;
                let l = positive(&format!("{key}.length_m"), t.length_m)?;
                if a > 0.1 * l {
                    return Err(Error::InvalidValue {
                        key: format!("{key}.amplitude_m"),
                        value: a.to_string(),
                        reason: format!("must be at most a tenth of length_m = {l}"),
                    });
                }
                waves.push(Wave {
                    amplitude_m: a,
                    wave_number_per_m: 2.0 * PI / l,
                    dir: unit_from_azimuth(finite(&format!("{key}.azimuth_deg"), t.azimuth_deg)?),
                    phase_rad: finite(&format!("{key}.phase_deg"), t.phase_deg)?.to_radians(),
                });
            }
            waves.retain(|w| w.amplitude_m > 0.0);
            scene.water = Some(Water {
                min_m: w.min_m,
                max_m: w.max_m,
                level_m: ground + level,
                depth_m: [d0, d1],
                bank_m: bank,
                waves,
            });
        }
        for (i, b) in f.buildings.iter().enumerate() {
            let key = format!("scene.buildings[{i}]");
            inside(&key, "building centre", b.center_m)?;
            let l = positive(&format!("{key}.size_m[0]"), b.size_m[0])?;
            let w = positive(&format!("{key}.size_m[1]"), b.size_m[1])?;
            let axis = unit_from_azimuth(finite(&format!("{key}.azimuth_deg"), b.azimuth_deg)?);
            for c in corners(b.center_m, axis, [l / 2.0, w / 2.0]) {
                inside(&key, "building corner", c)?;
            }
            let eave = positive(&format!("{key}.eave_height_m"), b.eave_height_m)?;
            let slope = b.roof_slope_deg;
            if !(slope.is_finite() && (0.0..=75.0).contains(&slope)) {
                return Err(Error::InvalidValue {
                    key: format!("{key}.roof_slope_deg"),
                    value: slope.to_string(),
                    reason: "must be in [0, 75] degrees".into(),
                });
            }
            let base = scene.ground_height(b.center_m[0], b.center_m[1]);
            scene.buildings.push(Building {
                center_m: b.center_m,
                axis,
                half_m: [l / 2.0, w / 2.0],
                base_m: base,
                eave_m: eave,
                tan_slope: slope.to_radians().tan(),
            });
        }
        for (i, t) in f.targets.iter().enumerate() {
            let key = format!("scene.targets[{i}]");
            inside(&key, &format!("target {:?}", t.id), t.center_m)?;
            if f.targets[..i].iter().any(|o| o.id == t.id) {
                return Err(Error::InvalidValue {
                    key: format!("{key}.id"),
                    value: format!("{:?}", t.id),
                    reason: "another target has the same id".into(),
                });
            }
            let r = positive(&format!("{key}.radius_m"), t.radius_m)?;
            let above = non_negative(
                &format!("{key}.height_above_ground_m"),
                t.height_above_ground_m,
            )?;
            if t.painted && above != 0.0 {
                return Err(Error::InvalidValue {
                    key: format!("{key}.height_above_ground_m"),
                    value: format!("{above}"),
                    reason: "a painted disc lies on the ground: set 0 or drop `painted`".into(),
                });
            }
            let h = scene.ground_height(t.center_m[0], t.center_m[1]) + above;
            scene.targets.push(Target {
                id: t.id.clone(),
                center_m: t.center_m,
                radius_m: r,
                height_m: h,
                painted: t.painted,
            });
        }
        Ok(scene)
    }

    /// The sines and cosines of the relief's three phases at (x, y): `k x + 0.3`, `0.77 k y` and
    /// `0.61 k (x + y) + 1.1` (k = [`Scene::relief_k_per_m`]). The height and the slope both come
    /// from them, and a nearby point's from them by the angle-addition identities.
    #[inline]
    fn relief_phases(&self, x: f64, y: f64) -> Phases {
        let k = self.relief_k_per_m;
        [
            (k * x + 0.3).sin_cos(),
            (0.77 * k * y).sin_cos(),
            (0.61 * k * (x + y) + 1.1).sin_cos(),
        ]
    }

    /// Terrain relief without paved areas or the basin, from its phases: ground height + a
    /// smooth sum of sines, m.
    #[inline]
    fn relief_from(&self, ph: &Phases) -> f64 {
        self.ground_height_m + self.relief_m * (0.6 * ph[0].0 * ph[1].1 + 0.4 * ph[2].0)
    }

    /// Slope (∂h/∂x, ∂h/∂y) of [`Scene::relief_from`].
    #[inline]
    fn relief_slope_from(&self, ph: &Phases) -> [f64; 2] {
        let (k, a) = (self.relief_k_per_m, self.relief_m);
        let diagonal = 0.4 * 0.61 * k * ph[2].1;
        [
            a * (0.6 * k * ph[0].1 * ph[1].1 + diagonal),
            a * (-0.6 * 0.77 * k * ph[0].0 * ph[1].0 + diagonal),
        ]
    }

    /// Terrain relief without paved areas or the basin, m.
    #[inline]
    fn relief_height(&self, x: f64, y: f64) -> f64 {
        if self.relief_m == 0.0 {
            return self.ground_height_m;
        }
        self.relief_from(&self.relief_phases(x, y))
    }

    /// Ellipsoidal height of the ground (terrain, pavement, basin bottom; no buildings, targets or
    /// water) at local grid (x, y), m.
    pub fn ground_height(&self, x: f64, y: f64) -> f64 {
        self.pave_and_cut(x, y, self.relief_height(x, y), [0.0; 2], ALL_PAVED)
            .0
    }

    /// Height (m) and slope of the ground at (x, y), the relief's phases from `anchor`'s when
    /// it is near (see [`Scene::phases_near`]).
    #[inline]
    fn ground_with_slope(&self, x: f64, y: f64, sweep: &mut Sweep) -> (f64, [f64; 2], Phased) {
        let paved = sweep.paved_at(x, y);
        if self.relief_m == 0.0 {
            let (h, g) = self.pave_and_cut(x, y, self.ground_height_m, [0.0; 2], paved);
            return (h, g, ([(0.0, 1.0); 3], 0));
        }
        let phased = self.phases_near(x, y, &mut sweep.anchor);
        let ph = &phased.0;
        let (h, g) = (self.relief_from(ph), self.relief_slope_from(ph));
        let (h, g) = self.pave_and_cut(x, y, h, g, paved);
        (h, g, phased)
    }

    /// The paved areas that may reach a point within [`PAVED_NEAR_M`] (in x and in y) of `c`,
    /// with that point: an area's blend rectangle lies within `half + half + 2 blend` of its
    /// centre (all of them beyond 64 areas).
    fn paved_near(&self, c: [f64; 2]) -> ([f64; 2], u64) {
        if self.paved.len() > 64 {
            return (c, ALL_PAVED);
        }
        let mut mask = 0;
        for (i, p) in self.paved.iter().enumerate() {
            let reach = PAVED_NEAR_M + p.half_m[0] + p.half_m[1] + 2.0 * PAVED_BLEND_M;
            if (p.center_m[0] - c[0]).abs() <= reach && (p.center_m[1] - c[1]).abs() <= reach {
                mask |= 1 << i;
            }
        }
        (c, mask)
    }

    /// The relief's phases at (x, y), turned from `anchor`'s when it is within reach (with the
    /// chain length they would have as an anchor), else evaluated, and then `anchor` too.
    #[inline]
    fn phases_near(&self, x: f64, y: f64, anchor: &mut Option<Anchor>) -> (Phases, u32) {
        let k = self.relief_k_per_m;
        if let Some(a) = anchor.as_ref().filter(|a| a.chain < ANCHOR_CHAIN) {
            let (dx, dy) = (x - a.xy[0], y - a.xy[1]);
            let turn = [k * dx, 0.77 * k * dy, 0.61 * k * (dx + dy)];
            if turn[0].abs().max(turn[1].abs()).max(turn[2].abs()) <= ANCHOR_REACH_RAD {
                let ph = [
                    add_angles(a.phases[0], small_sin_cos(turn[0])),
                    add_angles(a.phases[1], small_sin_cos(turn[1])),
                    add_angles(a.phases[2], small_sin_cos(turn[2])),
                ];
                return (ph, a.chain + 1);
            }
        }
        let phases = self.relief_phases(x, y);
        *anchor = Some(Anchor {
            xy: [x, y],
            phases,
            chain: 0,
        });
        (phases, 0)
    }

    /// The ground at (x, y) from the relief's height `h` and slope `g` there: the paved areas
    /// blended in and the basin cut out, with their slopes (the slope feeds only the root
    /// finder, the height is [`Scene::ground_height`]'s). Only the paved areas of the mask
    /// `paved` (bit i: area i) are looked at: the others must not reach (x, y).
    #[inline]
    fn pave_and_cut(
        &self,
        x: f64,
        y: f64,
        mut h: f64,
        mut g: [f64; 2],
        paved: u64,
    ) -> (f64, [f64; 2]) {
        for (i, p) in self.paved.iter().enumerate() {
            if paved & (1 << i.min(63)) == 0 {
                continue;
            }
            let (u, v) = local_uv(p.center_m, p.axis, x, y);
            // Beyond the blend (the smoothstep's argument ≤ 0, as rounded): no weight.
            if u.abs() >= p.half_m[0] + PAVED_BLEND_M || v.abs() >= p.half_m[1] + PAVED_BLEND_M {
                continue;
            }
            let (su, dsu) =
                smoothstep_slope((p.half_m[0] + PAVED_BLEND_M - u.abs()) / PAVED_BLEND_M);
            let (sv, dsv) =
                smoothstep_slope((p.half_m[1] + PAVED_BLEND_M - v.abs()) / PAVED_BLEND_M);
            let w = su * sv;
            if w > 0.0 {
                // ∂w/∂u and ∂w/∂v; (u, v) turn from (x, y) by the axis.
                let wu = -u.signum() * dsu * sv / PAVED_BLEND_M;
                let wv = -v.signum() * su * dsv / PAVED_BLEND_M;
                let dw = [
                    wu * p.axis[0] + wv * p.axis[1],
                    wu * p.axis[1] - wv * p.axis[0],
                ];
                let rise = p.height_m - h;
                g = [
                    g[0] * (1.0 - w) + dw[0] * rise,
                    g[1] * (1.0 - w) + dw[1] * rise,
                ];
                h += w * rise;
            }
        }
        if let Some(w) = &self.water {
            let (cut, dc) = basin_cut(w, x, y);
            h -= cut;
            g = [g[0] - dc[0], g[1] - dc[1]];
        }
        (h, g)
    }

    /// Ellipsoidal height of the water surface at (x, y) when there is water there, m.
    pub fn water_surface_height(&self, x: f64, y: f64) -> Option<f64> {
        let w = self.water.as_ref()?;
        if x < w.min_m[0] || x > w.max_m[0] || y < w.min_m[1] || y > w.max_m[1] {
            return None;
        }
        let s = wave(w, x, y).0;
        (self.ground_height(x, y) < s).then_some(s)
    }

    /// Ellipsoidal height of the first surface seen from above at (x, y) (roof, target plate,
    /// water surface or ground), m.
    pub fn surface_height(&self, x: f64, y: f64) -> f64 {
        let mut h = self.ground_height(x, y);
        if let Some(s) = self.water_surface_height(x, y) {
            h = h.max(s);
        }
        for b in &self.buildings {
            let (u, v) = local_uv(b.center_m, b.axis, x, y);
            if u.abs() <= b.half_m[0] && v.abs() <= b.half_m[1] {
                h = h.max(b.base_m + b.eave_m + (b.half_m[1] - v.abs()) * b.tan_slope);
            }
        }
        for t in &self.targets {
            if (x - t.center_m[0]).hypot(y - t.center_m[1]) <= t.radius_m {
                h = h.max(t.height_m);
            }
        }
        h
    }

    /// Reflectivity and class of the ground at (x, y): asphalt / paint in paved areas, terrain
    /// elsewhere.
    fn ground_material(&self, x: f64, y: f64, paved: u64) -> (f64, u8) {
        for (i, p) in self.paved.iter().enumerate() {
            if paved & (1 << i.min(63)) == 0 {
                continue;
            }
            let (u, v) = local_uv(p.center_m, p.axis, x, y);
            if u.abs() <= p.half_m[0] && v.abs() <= p.half_m[1] {
                let edge = p.half_m[1] - v.abs() < 0.3 && p.half_m[1] - v.abs() > 0.15;
                let paint = edge
                    || match p.markings {
                        Markings::Zebra => u.abs() <= 2.0 && (v / 0.5).floor() as i64 % 2 == 0,
                        Markings::CentreLine => {
                            v.abs() <= 0.075 && (u / 3.0).floor() as i64 % 2 == 0
                        }
                        Markings::None => false,
                    };
                let r = if paint {
                    REFLECTIVITY_PAINT
                } else {
                    REFLECTIVITY_ASPHALT
                };
                return (r, CLASS_GROUND);
            }
        }
        (REFLECTIVITY_TERRAIN, CLASS_GROUND)
    }

    /// The first surface along `curve` (terrain, buildings, targets, water surface), with
    /// `footprint_per_m` = beam divergence (footprint diameter per metre of range) for mixed
    /// pixels at target edges. `None` if the ray never meets the ground.
    pub fn trace(&self, curve: &Curve, footprint_per_m: f64) -> Option<Hit> {
        self.trace_in(curve, footprint_per_m, &mut self.sweep())
    }

    /// [`Scene::trace`] for the next ray of `sweep` (the same hit, found faster when the rays
    /// are neighbours).
    pub fn trace_in(&self, curve: &Curve, footprint_per_m: f64, sweep: &mut Sweep) -> Option<Hit> {
        let mut best = self.trace_ground_in(curve, sweep)?;
        let mut target_mix: Option<(f64, f64)> = None; // (fraction on plate, plate reflectivity)
        // The (x, y) box of the ray between the lowest and the highest object, with the widest
        // mixed-pixel reach there: an object whose box misses it is missed (its own tests
        // below would refuse it), so most rays test no object.
        let reach = sweep.objects_m.and_then(|[low, high]| {
            let (r0, r1) = (curve.crossing(high)?, curve.crossing(low)?);
            let (p, q) = (curve.at(r0), curve.at(r1));
            // The parabola strays from its chord by at most |c| (Δρ)²/4.
            let pad = 0.5 + 0.25 * curve.c[0].abs().max(curve.c[1].abs()) * (r1 - r0).powi(2);
            let footprint = 0.5 * footprint_per_m.abs() * (r0.max(r1) + pad);
            Some((
                [p[0].min(q[0]) - pad, p[1].min(q[1]) - pad],
                [p[0].max(q[0]) + pad, p[1].max(q[1]) + pad],
                footprint,
            ))
        });
        let near = |c: [f64; 2], radius: f64| {
            reach.is_none_or(|(lo, hi, _)| {
                c[0] + radius >= lo[0]
                    && c[0] - radius <= hi[0]
                    && c[1] + radius >= lo[1]
                    && c[1] - radius <= hi[1]
            })
        };
        let footprint_reach = reach.map_or(0.0, |r| r.2);
        for b in &self.buildings {
            if !near(b.center_m, b.half_m[0] + b.half_m[1]) {
                continue;
            }
            if let Some(h) = building_hit(b, curve)
                && h.range_m < best.range_m
            {
                best = h;
            }
        }
        for t in self.targets.iter().filter(|t| !t.painted) {
            if !near(t.center_m, t.radius_m + footprint_reach) {
                continue;
            }
            let n = [0.0, 0.0, 1.0];
            let Some(r) = curve.plane(n, t.height_m) else {
                continue;
            };
            let p = curve.at(r);
            let rf = 0.5 * footprint_per_m * r;
            let Some(dist) = distance_within(p, t.center_m, t.radius_m + rf) else {
                continue;
            };
            let frac = if rf > 0.0 {
                segment_fraction((t.radius_m - dist) / rf)
            } else {
                f64::from(u8::from(dist <= t.radius_m))
            };
            if dist <= t.radius_m && r < best.range_m {
                best = Hit {
                    range_m: r,
                    position: p,
                    normal: n,
                    class: CLASS_TARGET,
                    reflectivity: REFLECTIVITY_TARGET,
                };
            }
            target_mix = Some((frac, REFLECTIVITY_TARGET));
        }
        if let Some(w) = &self.water
            && let Some(h) = self.water_hit(w, curve)
            && h.range_m < best.range_m
        {
            best = h;
        }
        // Painted discs: paint on the ground under the footprint, blended by its area fraction.
        if best.class == CLASS_GROUND {
            let rf = 0.5 * footprint_per_m * best.range_m;
            for t in self.targets.iter().filter(|t| t.painted) {
                let Some(dist) = distance_within(best.position, t.center_m, t.radius_m + rf) else {
                    continue;
                };
                let frac = if rf > 0.0 {
                    segment_fraction((t.radius_m - dist) / rf)
                } else {
                    f64::from(u8::from(dist <= t.radius_m))
                };
                best.reflectivity = frac * REFLECTIVITY_PAINT + (1.0 - frac) * best.reflectivity;
            }
        }
        // Mixed pixel: the footprint straddles a target edge; the single return's intensity
        // blends the plate and what lies beside it.
        if let Some((frac, refl)) = target_mix {
            let (inner, outer) = if best.class == CLASS_TARGET {
                (refl, REFLECTIVITY_TERRAIN)
            } else {
                (refl, best.reflectivity)
            };
            best.reflectivity = frac * inner + (1.0 - frac) * outer;
        }
        Some(best)
    }

    /// The canopy return of a beam whose first surface `hit` is the ground, if the scene has
    /// vegetation and the beam passes through a crown above it (see [`Vegetation`]).
    pub fn canopy_hit(&self, curve: &Curve, hit: &Hit) -> Option<Hit> {
        let v = self.vegetation.as_ref()?;
        if hit.class != CLASS_GROUND {
            return None;
        }
        v.canopy_hit(curve, hit, |x, y| self.ground_height(x, y))
    }

    /// The ground (terrain, pavement or basin bottom) along `curve`, ignoring everything above
    /// it, to rounding; see [`Scene::trace_ground_in`].
    pub fn trace_ground(&self, curve: &Curve) -> Option<Hit> {
        self.trace_ground_in(curve, &mut self.sweep())
    }

    /// What the rays of one sweep share (see [`Sweep`]): start one with this.
    pub fn sweep(&self) -> Sweep {
        let k = self.relief_k_per_m * GRADIENT_STEP_M;
        let tops = self
            .buildings
            .iter()
            .map(|b| (b.base_m, b.ridge_height_m()));
        let plates = self.targets.iter().filter(|t| !t.painted);
        let objects_m = tops
            .chain(plates.map(|t| (t.height_m, t.height_m)))
            .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))
            .map(|(low, high)| [low, high]);
        Sweep {
            ground_m: [None; 2],
            paved: None,
            anchor: None,
            objects_m,
            steps: [k.sin_cos(), (0.77 * k).sin_cos(), (0.61 * k).sin_cos()],
        }
    }

    /// [`Scene::trace_ground`] for the next ray of `sweep`: Newton's method on
    /// `h(ρ) − ground(x(ρ), y(ρ))` with the ground's slope from the same sines and cosines,
    /// started where the ray crosses the height extrapolated from the sweep's last ground hits
    /// (or the undisturbed ground level) and stopped when a step is within the rounding of
    /// `h − ground`; if it does not converge, the secant method from the undisturbed level.
    pub fn trace_ground_in(&self, curve: &Curve, sweep: &mut Sweep) -> Option<Hit> {
        const UP: [f64; 3] = [0.0, 0.0, 1.0];
        // A ray that starts below the undisturbed level, e.g. refracted at a lake surface,
        // starts at 0.
        let level = || curve.plane(UP, self.ground_height_m).unwrap_or(0.0);
        // Where the ray crosses the height extrapolated from the last two hits (a few µm off
        // the ground along a scan line), or the last one's.
        let guess = match sweep.ground_m {
            [Some(h1), Some(h0)] => Some(2.0 * h1 - h0),
            [h1, _] => h1,
        };
        let start = guess.and_then(|h| curve.crossing(h)).unwrap_or_else(level);
        if curve.direction(start)[2] >= 0.0 {
            return None;
        }
        // The paved areas near the start, for this ray's and the next rays' ground.
        let q = curve.at(start);
        if sweep.paved_at(q[0], q[1]) == ALL_PAVED {
            sweep.paved = Some(self.paved_near([q[0], q[1]]));
        }
        let (r, (ph, chain)) = match self.newton_ground(curve, start, sweep) {
            Some(found) => found,
            None => {
                let r = self.secant_ground(curve, level())?;
                let p = curve.at(r);
                (r, (self.relief_phases(p[0], p[1]), 0))
            }
        };
        let p = curve.at(r);
        sweep.ground_m = [Some(p[2]), sweep.ground_m[0]];
        if self.relief_m != 0.0 {
            // The hit's phases anchor the next ray's.
            sweep.anchor = Some(Anchor {
                xy: [p[0], p[1]],
                phases: ph,
                chain,
            });
        }
        let (gx, gy) = self.ground_gradient(p, &ph, sweep);
        let (reflectivity, class) = self.ground_material(p[0], p[1], sweep.paved_at(p[0], p[1]));
        Some(Hit {
            range_m: r,
            position: p,
            normal: unit([-gx, -gy, 1.0]),
            class,
            reflectivity,
        })
    }

    /// The root of `h(ρ) − ground` by Newton's method from `r`, to rounding, with the relief's
    /// phases there (from and into the sweep's anchor); `None` when it does not converge to a
    /// point ahead of the ray's origin.
    fn newton_ground(&self, curve: &Curve, mut r: f64, sweep: &mut Sweep) -> Option<NewtonRoot> {
        for _ in 0..30 {
            let p = curve.at(r);
            let d = curve.direction(r);
            let (g, slope, phases) = self.ground_with_slope(p[0], p[1], sweep);
            let df = d[2] - slope[0] * d[0] - slope[1] * d[1];
            let step = -(p[2] - g) / df;
            if !step.is_finite() {
                return None;
            }
            // A step within the rounding of h − ground (a few ulp of h over the slope): r is the
            // root, and its phases are at hand.
            if step.abs() <= 1e-12 + 16.0 * f64::EPSILON * p[2].abs() / df.abs() {
                return (r > 0.0).then_some((r, phases));
            }
            r += step;
        }
        None
    }

    /// The root of `h(ρ) − ground` by the secant method from `r0` and a Newton step that
    /// ignores the terrain slope, to 1 µm.
    fn secant_ground(&self, curve: &Curve, r0: f64) -> Option<f64> {
        let f = |r: f64| {
            let p = curve.at(r);
            p[2] - self.ground_height(p[0], p[1])
        };
        let f0 = f(r0);
        let dh = curve.direction(r0)[2];
        if dh >= 0.0 {
            return None;
        }
        let (mut ra, mut fa) = (r0, f0);
        let mut rb = r0 - f0 / dh;
        let mut fb = f(rb);
        for _ in 0..60 {
            if fb == 0.0 {
                break;
            }
            let denom = fb - fa;
            if denom == 0.0 {
                break;
            }
            let rc = rb - fb * (rb - ra) / denom;
            (ra, fa) = (rb, fb);
            rb = rc;
            fb = f(rb);
            if (rb - ra).abs() < 1e-6 {
                break;
            }
        }
        (rb.is_finite() && rb > 0.0 && fb.abs() < 1e-4).then_some(rb)
    }

    /// Forward-difference slope at the ground point `p` (only the intensity uses it, so two
    /// evaluations instead of four; the error is ~0.5 m × curvature, < 10⁻³), the relief at the
    /// two points from its phases `ph` at `p` turned by the sweep's `steps`.
    fn ground_gradient(&self, p: [f64; 3], ph: &Phases, sweep: &Sweep) -> (f64, f64) {
        let (e, steps) = (GRADIENT_STEP_M, &sweep.steps);
        let (x, y, h) = (p[0], p[1], p[2]);
        let paved = [sweep.paved_at(x + e, y), sweep.paved_at(x, y + e)];
        let (rx, ry) = if self.relief_m == 0.0 {
            (self.ground_height_m, self.ground_height_m)
        } else {
            let diagonal = add_angles(ph[2], steps[2]);
            (
                self.relief_from(&[add_angles(ph[0], steps[0]), ph[1], diagonal]),
                self.relief_from(&[ph[0], add_angles(ph[1], steps[1]), diagonal]),
            )
        };
        (
            (self.pave_and_cut(x + e, y, rx, [0.0; 2], paved[0]).0 - h) / e,
            (self.pave_and_cut(x, y + e, ry, [0.0; 2], paved[1]).0 - h) / e,
        )
    }

    fn water_hit(&self, w: &Water, curve: &Curve) -> Option<Hit> {
        let r = if w.waves.is_empty() {
            curve.plane([0.0, 0.0, 1.0], w.level_m)?
        } else {
            // Secant on h(ρ) − surface(x, y), started on the still level.
            let f = |r: f64| {
                let p = curve.at(r);
                p[2] - wave(w, p[0], p[1]).0
            };
            let mut ra = curve.plane([0.0, 0.0, 1.0], w.level_m + w.max_wave_m())?;
            let mut rb = curve.plane([0.0, 0.0, 1.0], w.level_m)?;
            let (mut fa, mut fb) = (f(ra), f(rb));
            for _ in 0..40 {
                if fb == fa {
                    break;
                }
                let rc = rb - fb * (rb - ra) / (fb - fa);
                (ra, fa) = (rb, fb);
                rb = rc;
                fb = f(rb);
                if (rb - ra).abs() < 1e-6 {
                    break;
                }
            }
            (fb.abs() < 1e-4 && rb > 0.0).then_some(rb)?
        };
        let p = curve.at(r);
        if p[0] < w.min_m[0] || p[0] > w.max_m[0] || p[1] < w.min_m[1] || p[1] > w.max_m[1] {
            return None;
        }
        let (s, gx, gy) = wave(w, p[0], p[1]);
        if self.ground_height(p[0], p[1]) >= s {
            return None;
        }
        Some(Hit {
            range_m: r,
            position: p,
            normal: unit([-gx, -gy, 1.0]),
            class: CLASS_WATER_SURFACE,
            reflectivity: REFLECTIVITY_WATER,
        })
    }
}

/// Along / across coordinates of (x, y) in a rectangle's frame (across = 90° clockwise of the
/// axis).
#[inline]
fn local_uv(c: [f64; 2], axis: [f64; 2], x: f64, y: f64) -> (f64, f64) {
    let (dx, dy) = (x - c[0], y - c[1]);
    (dx * axis[0] + dy * axis[1], dx * axis[1] - dy * axis[0])
}

/// Depth of the basin cut at (x, y), m: full depth inside the basin, a smooth bank inwards of its
/// rectangle, depth growing linearly from west to east; with its slope (∂/∂x, ∂/∂y).
#[inline]
fn basin_cut(w: &Water, x: f64, y: f64) -> (f64, [f64; 2]) {
    if x < w.min_m[0] || x > w.max_m[0] || y < w.min_m[1] || y > w.max_m[1] {
        return (0.0, [0.0; 2]);
    }
    let b = w.bank_m;
    let (sw, dsw) = smoothstep_slope((x - w.min_m[0]) / b);
    let (se, dse) = smoothstep_slope((w.max_m[0] - x) / b);
    let (ss, dss) = smoothstep_slope((y - w.min_m[1]) / b);
    let (sn, dsn) = smoothstep_slope((w.max_m[1] - y) / b);
    let s = sw * se * ss * sn;
    let width = w.max_m[0] - w.min_m[0];
    let t = (x - w.min_m[0]) / width;
    let depth = w.depth_m[0] + t * (w.depth_m[1] - w.depth_m[0]);
    let sx = (dsw * se - sw * dse) / b * ss * sn;
    let sy = sw * se * (dss * sn - ss * dsn) / b;
    (
        s * depth,
        [
            sx * depth + s * (w.depth_m[1] - w.depth_m[0]) / width,
            sy * depth,
        ],
    )
}

/// Water surface height and its gradient (∂h/∂x, ∂h/∂y) at (x, y).
#[inline]
fn wave(w: &Water, x: f64, y: f64) -> (f64, f64, f64) {
    let (mut h, mut gx, mut gy) = (w.level_m, 0.0, 0.0);
    for t in &w.waves {
        let phase = t.wave_number_per_m * (x * t.dir[0] + y * t.dir[1]) + t.phase_rad;
        let (s, c) = phase.sin_cos();
        let g = t.amplitude_m * t.wave_number_per_m * c;
        h += t.amplitude_m * s;
        gx += g * t.dir[0];
        gy += g * t.dir[1];
    }
    (h, gx, gy)
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = dot(v, v).sqrt();
    [v[0] / n, v[1] / n, v[2] / n]
}

/// The horizontal distance from `p` to `centre` when it is at most `limit`, m. hypot(a, b) ≥
/// |a|, |b| (also as rounded), so most far centres are refused without the hypot.
#[inline]
fn distance_within(p: [f64; 3], centre: [f64; 2], limit: f64) -> Option<f64> {
    let (dx, dy) = (p[0] - centre[0], p[1] - centre[1]);
    if dx.abs() > limit || dy.abs() > limit {
        return None;
    }
    let d = dx.hypot(dy);
    (d <= limit).then_some(d)
}

/// Fraction of a disc of radius 1 on one side of a chord at signed distance `t` from its centre
/// (t = 1: all, t = −1: none).
fn segment_fraction(t: f64) -> f64 {
    let t = t.clamp(-1.0, 1.0);
    0.5 + (t * (1.0 - t * t).sqrt() + t.asin()) / PI
}

/// First hit of `curve` on a building's roof or walls.
fn building_hit(b: &Building, curve: &Curve) -> Option<Hit> {
    // Quick reject: where the ray is between the floor and the ridge, is it near the building?
    let top = b.ridge_height_m();
    let r_top = curve.plane([0.0, 0.0, 1.0], top)?;
    let r_bot = curve.plane([0.0, 0.0, 1.0], b.base_m)?;
    let (p, q) = (curve.at(r_top), curve.at(r_bot));
    let radius = b.half_m[0].hypot(b.half_m[1]);
    // Cheap reject first: the centre farther than the radius (plus far more than any rounding)
    // from the segment's bounding box is farther than it from the segment.
    let gap = |k: usize| (p[k].min(q[k]) - b.center_m[k]).max(b.center_m[k] - p[k].max(q[k]));
    if gap(0).max(gap(1)) > radius + 1e-6 {
        return None;
    }
    if segment_point_distance([p[0], p[1]], [q[0], q[1]], b.center_m) > radius {
        return None;
    }
    let across = [b.axis[1], -b.axis[0]];
    let cu = b.center_m[0] * b.axis[0] + b.center_m[1] * b.axis[1];
    let cv = b.center_m[0] * across[0] + b.center_m[1] * across[1];
    let mut best: Option<Hit> = None;
    let mut consider =
        |r: Option<f64>, n: [f64; 3], valid: &dyn Fn(f64, f64, f64) -> bool, refl| {
            let Some(r) = r else { return };
            if best.is_some_and(|h| h.range_m <= r) {
                return;
            }
            let p = curve.at(r);
            let (u, v) = local_uv(b.center_m, b.axis, p[0], p[1]);
            if valid(u, v, p[2]) {
                best = Some(Hit {
                    range_m: r,
                    position: p,
                    normal: unit(n),
                    class: CLASS_BUILDING,
                    reflectivity: refl,
                });
            }
        };
    let eave_top = b.base_m + b.eave_m;
    // Roof planes: h = eave_top + (hw − s v) tanα  ⇔  h + s tanα v = eave_top + hw tanα.
    for s in [1.0, -1.0] {
        let k = s * b.tan_slope;
        let n = [k * across[0], k * across[1], 1.0];
        let d = eave_top + b.half_m[1] * b.tan_slope + k * cv;
        consider(
            curve.plane(n, d),
            n,
            &|u, v, _| u.abs() <= b.half_m[0] && s * v >= 0.0 && s * v <= b.half_m[1],
            REFLECTIVITY_ROOF,
        );
    }
    // Side walls (v = ±hw) up to the eaves; gable walls (u = ±hl) up to the roof line.
    for s in [1.0, -1.0] {
        let n = [s * across[0], s * across[1], 0.0];
        consider(
            curve.plane(n, s * cv + b.half_m[1]),
            n,
            &|u, _, h| u.abs() <= b.half_m[0] && h >= b.base_m && h <= eave_top,
            REFLECTIVITY_WALL,
        );
        let n = [s * b.axis[0], s * b.axis[1], 0.0];
        consider(
            curve.plane(n, s * cu + b.half_m[0]),
            n,
            &|_, v, h| {
                v.abs() <= b.half_m[1]
                    && h >= b.base_m
                    && h <= eave_top + (b.half_m[1] - v.abs()) * b.tan_slope
            },
            REFLECTIVITY_WALL,
        );
    }
    best
}

fn segment_point_distance(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 {
        (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a[0] + t * dx - p[0]).hypot(a[1] + t * dy - p[1])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn straight_down(x: f64, y: f64, h: f64) -> Curve {
        Curve {
            a: [x, y, h],
            b: [0.0, 0.0, -1.0],
            c: [0.0; 3],
        }
    }

    fn scene() -> Scene {
        let text = crate::scenario::builtin_toml("demo").unwrap();
        let f: crate::scenario::ScenarioFile = toml::from_str(text).unwrap();
        Scene::from_file(&f.scene).unwrap()
    }

    #[test]
    fn vertical_ray_meets_the_surface_height() {
        let s = scene();
        for (x, y) in [(10.0, 20.0), (-150.0, 75.0), (200.0, -220.0)] {
            let hit = s.trace(&straight_down(x, y, 500.0), 0.0).unwrap();
            assert!((hit.position[2] - s.surface_height(x, y)).abs() < 1e-6);
            assert!((hit.range_m - (500.0 - s.surface_height(x, y))).abs() < 1e-6);
        }
    }

    #[test]
    fn roof_and_target_are_hit_with_their_classes() {
        let s = scene();
        let b = &s.buildings[0];
        let hit = s
            .trace(&straight_down(b.center_m[0], b.center_m[1], 500.0), 0.0)
            .unwrap();
        assert_eq!(hit.class, CLASS_BUILDING);
        assert!((hit.position[2] - b.ridge_height_m()).abs() < 1e-9);
        let t = &s.targets[0];
        let hit = s
            .trace(
                &straight_down(t.center_m[0] + 0.3, t.center_m[1], 500.0),
                0.0,
            )
            .unwrap();
        assert_eq!(hit.class, CLASS_TARGET);
        assert!((hit.position[2] - t.height_m).abs() < 1e-9);
        // Just outside the plate: ground, but a wide footprint mixes the plate's brightness in.
        let off = straight_down(t.center_m[0] + t.radius_m + 0.05, t.center_m[1], 500.0);
        let plain = s.trace(&off, 0.0).unwrap();
        let mixed = s.trace(&off, 1e-3).unwrap();
        assert_eq!(plain.class, CLASS_GROUND);
        assert!(mixed.reflectivity > plain.reflectivity + 0.1);
    }

    #[test]
    fn painted_disc_is_paint_on_the_ground() {
        let text = crate::scenario::builtin_toml("demo").unwrap();
        let mut f: crate::scenario::ScenarioFile = toml::from_str(text).unwrap();
        let mut disc = f.scene.targets[0].clone();
        disc.id = "P1".into();
        disc.center_m[0] += 10.0;
        disc.height_above_ground_m = 0.5;
        disc.painted = true;
        f.scene.targets.push(disc.clone());
        // A painted disc with a height is a contradiction, named by key.
        let e = Scene::from_file(&f.scene).unwrap_err().to_string();
        assert!(e.contains("height_above_ground_m"), "{e}");
        f.scene.targets.last_mut().unwrap().height_above_ground_m = 0.0;
        let s = Scene::from_file(&f.scene).unwrap();
        let t = s.targets.last().unwrap();
        assert!(t.painted);
        let (x, y) = (t.center_m[0] + 0.3, t.center_m[1]);
        let hit = s.trace(&straight_down(x, y, 500.0), 0.0).unwrap();
        // On the ground, at the ground's height, as bright as paint.
        assert_eq!(hit.class, CLASS_GROUND);
        assert!((hit.position[2] - s.ground_height(x, y)).abs() < 1e-6);
        assert!((hit.reflectivity - REFLECTIVITY_PAINT).abs() < 1e-12);
        assert!((t.height_m - s.ground_height(t.center_m[0], t.center_m[1])).abs() < 1e-9);
        // Half a footprint across the edge: the paint's and the ground's mean.
        let edge = straight_down(t.center_m[0] + t.radius_m, t.center_m[1], 500.0);
        let mixed = s.trace(&edge, 1e-3).unwrap();
        let plain = s
            .trace(
                &straight_down(t.center_m[0] + t.radius_m + 1.0, t.center_m[1], 500.0),
                0.0,
            )
            .unwrap();
        let mid = 0.5 * (REFLECTIVITY_PAINT + plain.reflectivity);
        assert!(
            (mixed.reflectivity - mid).abs() < 0.01,
            "{} vs {mid}",
            mixed.reflectivity
        );
    }

    /// The Newton root of a sweep of neighbouring rays (each started at the last one's ground,
    /// the relief's phases by angle addition) against the scene's own `ground_height` and the
    /// secant method from the undisturbed level, over relief, paved blends and the basin's
    /// banks; its slope against the forward differences of `ground_height`.
    #[test]
    fn sweep_roots_are_the_ground() {
        let text = crate::scenario::builtin_toml("bathymetry").unwrap();
        let mut f: crate::scenario::ScenarioFile = toml::from_str(text).unwrap();
        let demo: crate::scenario::ScenarioFile =
            toml::from_str(crate::scenario::builtin_toml("demo").unwrap()).unwrap();
        f.scene.paved = demo.scene.paved;
        f.scene.relief_m = 1.5;
        let s = Scene::from_file(&f.scene).unwrap();
        let mut sweep = s.sweep();
        let (mut worst_h, mut worst_r, mut worst_n, mut rays) = (0.0_f64, 0.0_f64, 0.0_f64, 0);
        for i in 0..40_000 {
            let t = f64::from(i);
            // A triangle scan of ±20° across a track from x = −400 m to 400 m at y ≈ −40 m.
            let u = 4.0 * ((t / 400.0 + 0.25).fract() - 0.5).abs() - 1.0;
            let theta = 20f64.to_radians() * u;
            let curve = Curve {
                a: [-400.0 + 0.02 * t, -40.0, 320.0],
                b: [0.05, theta.sin(), -theta.cos()],
                c: [0.0, 0.0, -2e-8],
            };
            let Some(hit) = s.trace_ground_in(&curve, &mut sweep) else {
                continue;
            };
            rays += 1;
            let p = hit.position;
            worst_h = worst_h.max((p[2] - s.ground_height(p[0], p[1])).abs());
            let level = curve
                .plane([0.0, 0.0, 1.0], s.ground_height_m)
                .unwrap_or(0.0);
            let r = s.secant_ground(&curve, level).unwrap();
            worst_r = worst_r.max((hit.range_m - r).abs());
            let e = GRADIENT_STEP_M;
            let g = [
                (s.ground_height(p[0] + e, p[1]) - p[2]) / e,
                (s.ground_height(p[0], p[1] + e) - p[2]) / e,
            ];
            let n = unit([-g[0], -g[1], 1.0]);
            worst_n = worst_n.max(
                (0..3)
                    .map(|k| (n[k] - hit.normal[k]).abs())
                    .fold(0.0, f64::max),
            );
        }
        assert_eq!(rays, 40_000);
        assert!(worst_h < 1e-9, "height residual {worst_h} m");
        assert!(worst_r < 1e-9, "range against the secant {worst_r} m");
        assert!(worst_n < 1e-9, "normal {worst_n}");
    }

    #[test]
    fn segment_fraction_limits() {
        assert_eq!(segment_fraction(1.0), 1.0);
        assert_eq!(segment_fraction(-1.0), 0.0);
        assert!((segment_fraction(0.0) - 0.5).abs() < 1e-15);
    }
}
