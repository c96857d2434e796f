//! The scene's TOML layout (`[scene]` of a scenario): schema only; [`crate::Scene::from_file`]
//! checks it. Kept apart from the scenario's checks so that the scene and the scenario modules
//! do not import each other.

use serde::{Deserialize, Serialize};

/// `[scene]`: the analytic scene, in local grid coordinates and ellipsoidal heights.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// Minimum corner (local easting, northing), m.
    pub min_m: [f64; 2],
    /// Maximum corner (local easting, northing), m.
    pub max_m: [f64; 2],
    /// Ellipsoidal height of the undisturbed ground, m.
    pub ground_height_m: f64,
    /// Amplitude of the gentle terrain relief, m.
    #[serde(default)]
    pub relief_m: f64,
    /// Wavelength of the relief, m.
    #[serde(default = "default_relief_wavelength")]
    pub relief_wavelength_m: f64,
    /// 1-sigma of the surveyed control-point coordinates, horizontal, m (Zhang et al. 2018: 5 mm).
    #[serde(default = "default_control_h")]
    pub control_sigma_horizontal_m: f64,
    /// 1-sigma of the surveyed control-point coordinates, vertical, m (Zhang et al. 2018: 2 cm).
    #[serde(default = "default_control_v")]
    pub control_sigma_vertical_m: f64,
    /// Flat paved areas with painted markings.
    #[serde(default)]
    pub paved: Vec<PavedFile>,
    /// Buildings with gable roofs.
    #[serde(default)]
    pub buildings: Vec<BuildingFile>,
    /// Circular high-reflectivity targets.
    #[serde(default)]
    pub targets: Vec<TargetFile>,
    /// An optional water body with a sloping bottom.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub water: Option<WaterFile>,
    /// An optional vegetation layer (multi-return pulses); absent: no canopy.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vegetation: Option<crate::vegetation::VegetationFile>,
}

fn default_relief_wavelength() -> f64 {
    400.0
}
fn default_control_h() -> f64 {
    0.005
}
fn default_control_v() -> f64 {
    0.02
}

/// `[[scene.paved]]`: a flat rectangle (its height is the terrain's at its centre) blended into
/// the terrain over `blend_m`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PavedFile {
    /// Centre, local easting / northing, m.
    pub center_m: [f64; 2],
    /// `[length, width]`, m; the length runs along `azimuth_deg`.
    pub size_m: [f64; 2],
    /// Grid bearing of the length axis, degrees clockwise from grid north.
    #[serde(default)]
    pub azimuth_deg: f64,
    /// `"zebra"` (a 4 m crossing of 0.5 m stripes across the middle, plus edge lines),
    /// `"centre-line"` (3 m dashes, 0.15 m wide, plus edge lines) or `"none"`.
    #[serde(default = "default_markings")]
    pub markings: String,
}

fn default_markings() -> String {
    "zebra".into()
}

/// `[[scene.buildings]]`: a rectangular building with a symmetric gable roof.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BuildingFile {
    /// Centre, local easting / northing, m.
    pub center_m: [f64; 2],
    /// `[length, width]`, m; the ridge runs along the length.
    pub size_m: [f64; 2],
    /// Grid bearing of the ridge, degrees clockwise from grid north.
    #[serde(default)]
    pub azimuth_deg: f64,
    /// Eave height above the ground at the centre, m.
    pub eave_height_m: f64,
    /// Roof slope, degrees.
    pub roof_slope_deg: f64,
}

/// `[[scene.targets]]`: a horizontal circular plate of high reflectivity (Zhang et al. 2018: radius
/// 0.8 m, 0.5 m above the ground).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TargetFile {
    /// Target id (control-point id).
    pub id: String,
    /// Centre, local easting / northing, m.
    pub center_m: [f64; 2],
    /// Radius, m.
    #[serde(default = "default_target_radius")]
    pub radius_m: f64,
    /// Height of the plate above the ground at its centre, m.
    #[serde(default = "default_target_height")]
    pub height_above_ground_m: f64,
    /// A flat disc of white paint on the ground instead of a raised plate (then
    /// `height_above_ground_m` must be 0).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub painted: bool,
}

fn default_target_radius() -> f64 {
    0.8
}
fn default_target_height() -> f64 {
    0.5
}

/// `[scene.water]`: a basin cut into the terrain inside a rectangle, filled to `level_m`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WaterFile {
    /// Minimum corner of the basin, local m.
    pub min_m: [f64; 2],
    /// Maximum corner of the basin, local m.
    pub max_m: [f64; 2],
    /// Water level relative to the ground height, m (negative: below the surrounding ground).
    pub level_m: f64,
    /// Depth of the basin cut below the ground at its west edge, m.
    pub shore_depth_m: f64,
    /// Depth of the basin cut at its east edge, m (the bottom slopes linearly between).
    pub max_depth_m: f64,
    /// Width of the smooth bank around the basin, m.
    #[serde(default = "default_bank")]
    pub bank_width_m: f64,
    /// Amplitude of the surface waves, m (0 = flat).
    #[serde(default)]
    pub wave_amplitude_m: f64,
    /// Wavelength of the surface waves, m.
    #[serde(default = "default_wave_length")]
    pub wave_length_m: f64,
    /// Grid bearing the waves travel towards, degrees.
    #[serde(default)]
    pub wave_azimuth_deg: f64,
    /// More wave trains, summed with the one above: a sea of several directions and lengths
    /// (its slope σ per axis is [`Water::slope_sigma_rad`](crate::Water::slope_sigma_rad)).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub waves: Vec<WaveFile>,
}

/// `[[scene.water.waves]]`: one sinusoidal wave train `A sin(k (x, y)·d + φ)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WaveFile {
    /// Amplitude A, m.
    pub amplitude_m: f64,
    /// Wavelength 2π/k, m.
    pub length_m: f64,
    /// Grid bearing the train travels towards, degrees.
    pub azimuth_deg: f64,
    /// Phase φ at the local origin, degrees.
    #[serde(default)]
    pub phase_deg: f64,
}

fn default_bank() -> f64 {
    20.0
}
fn default_wave_length() -> f64 {
    8.0
}
