//! The named error sources of SPEC §4 and their units.

use std::fmt;

/// Physical kind of a source's value; decides the SI unit and the unit suffix of config keys.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Unit {
    /// Lengths: SI metres, config `_m`.
    Metre,
    /// Angles: SI radians, config `_deg` (degrees at the edges).
    Radian,
    /// Times: SI seconds, config `_ns` (nanoseconds at the edges).
    Second,
    /// Dimensionless ratios (a refraction index): SI symbol `1`, config key without a suffix.
    One,
}

impl Unit {
    /// The SI unit symbol used in JSON (`"m"`, `"rad"`, `"s"`).
    pub fn si_symbol(self) -> &'static str {
        match self {
            Unit::Metre => "m",
            Unit::Radian => "rad",
            Unit::Second => "s",
            Unit::One => "1",
        }
    }

    /// The suffix a config key or flag carries for this unit (`_m`, `_deg`, `_ns`; none for a
    /// ratio).
    pub fn config_suffix(self) -> &'static str {
        match self {
            Unit::Metre => "_m",
            Unit::Radian => "_deg",
            Unit::Second => "_ns",
            Unit::One => "",
        }
    }

    /// Factor from the config unit (m, degrees, nanoseconds) to SI (m, rad, s).
    pub fn config_to_si(self) -> f64 {
        match self {
            Unit::Metre => 1.0,
            Unit::Radian => std::f64::consts::PI / 180.0,
            Unit::Second => 1e-9,
            Unit::One => 1.0,
        }
    }
}

macro_rules! sources {
    ($( $(#[$doc:meta])* $variant:ident = $name:literal, $unit:ident; )*) => {
        /// One error source. Its snake_case [`Source::name`] is used in TOML `[sigma]` keys (with a
        /// unit suffix), in JSON and in reports (SPEC §4).
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub enum Source {
            $( $(#[$doc])* $variant, )*
        }

        impl Source {
            /// Every source, in a fixed order.
            pub const ALL: &'static [Source] = &[$(Source::$variant),*];

            /// The snake_case name of SPEC §4.
            pub fn name(self) -> &'static str {
                match self { $(Source::$variant => $name,)* }
            }

            /// The physical kind of the source's value.
            pub fn unit(self) -> Unit {
                match self { $(Source::$variant => Unit::$unit,)* }
            }
        }
    };
}

sources! {
    /// GNSS/INS reference point position error, north (m). Zhang et al. (2018) X0,
    /// Li et al. (2016) ΔxG.
    GnssNorth = "gnss_north", Metre;
    /// GNSS/INS reference point position error, east (m). Zhang et al. (2018) Y0,
    /// Li et al. (2016) ΔyG.
    GnssEast = "gnss_east", Metre;
    /// GNSS/INS reference point position error, up (m). Zhang et al. (2018) Z0,
    /// Li et al. (2016) ΔzG.
    GnssUp = "gnss_up", Metre;
    /// Platform roll (rad). Zhang et al. (2018) R, Li et al. (2016) ω.
    Roll = "roll", Radian;
    /// Platform pitch (rad). Zhang et al. (2018) P, Li et al. (2016) ψ.
    Pitch = "pitch", Radian;
    /// Platform heading (rad). Zhang et al. (2018) H, Li et al. (2016) κ.
    Heading = "heading", Radian;
    /// Boresight roll, about scanner X (rad). Zhang et al. (2018) Δα, Li et al. (2016) θrol.
    BoresightRoll = "boresight_roll", Radian;
    /// Boresight pitch, about scanner Y (rad). Zhang et al. (2018) Δβ, Li et al. (2016) θpit.
    BoresightPitch = "boresight_pitch", Radian;
    /// Boresight yaw, about scanner Z (rad). Zhang et al. (2018) Δγ, Li et al. (2016) θhea.
    BoresightYaw = "boresight_yaw", Radian;
    /// Lever arm, body X (m). Zhang et al. (2018) Δx, Li et al. (2016) Δxil.
    LeverX = "lever_x", Metre;
    /// Lever arm, body Y (m). Zhang et al. (2018) Δy, Li et al. (2016) Δyil.
    LeverY = "lever_y", Metre;
    /// Lever arm, body Z (m). Zhang et al. (2018) Δz, Li et al. (2016) Δzil.
    LeverZ = "lever_z", Metre;
    /// Laser range (m). Zhang et al. (2018) ρ.
    Range = "range", Metre;
    /// Instantaneous scan angle (rad), positive to the right wing. Zhang et al. (2018) θ.
    ScanAngle = "scan_angle", Radian;
    /// Prism top-surface slope (rad). Li et al. (2016) θf.
    PrismSlope = "prism_slope", Radian;
    /// Prism-to-scanner mounting angle about X (rad). Li et al. (2016) θfsx.
    PrismX = "prism_x", Radian;
    /// Prism-to-scanner mounting angle about Y (rad). Li et al. (2016) θfsy.
    PrismY = "prism_y", Radian;
    /// Prism-to-scanner mounting angle about Z (rad). Li et al. (2016) θfsz.
    PrismZ = "prism_z", Radian;
    /// Scan azimuth of the rotating prism (rad). Li et al. (2016) θaz.
    ScanAzimuth = "scan_azimuth", Radian;
    /// Emitter zenith angle in the scanner frame (rad). Li et al. (2016) φls.
    EmitterZenith = "emitter_zenith", Radian;
    /// Emitter azimuth angle in the scanner frame (rad). Li et al. (2016) θls.
    EmitterAzimuth = "emitter_azimuth", Radian;
    /// Two-way travel time in air (s). Li et al. (2016) Δt1.
    TimeAir = "time_air", Second;
    /// Two-way travel time in water (s). Li et al. (2016) Δt2.
    TimeWater = "time_water", Second;
    /// Height of the water surface at the refraction point above where the air travel time puts
    /// it, along the surface normal (m), with the total travel time held: the refraction point
    /// moves along the air beam and the water leg takes up the difference. Waves about a
    /// modelled surface, or a surface-detection bias. Bathymetric soundings only.
    WaterSurfaceHeight = "water_surface_height", Metre;
    /// Tilt of the water surface at the refraction point towards north (rad): the surface rises
    /// towards north by tan of it (wave slope). Bathymetric soundings only.
    WaterSurfaceSlopeNorth = "water_surface_slope_north", Radian;
    /// Tilt of the water surface at the refraction point towards east (rad).
    WaterSurfaceSlopeEast = "water_surface_slope_east", Radian;
    /// Refraction index of the water (dimensionless): Snell's law at the surface and the speed
    /// of light in water, `ρ2 = c Δt2 / (2 nw)`. Bathymetric soundings only.
    NWater = "n_water", One;
    /// The second encoder angle of a beam scanner (rad): the second prism of a Risley pair.
    ScanAngle2 = "scan_angle_2", Radian;
    /// Elevation of a spinning multi-beam head's channel above the head's rotation plane (rad).
    ChannelElevation = "channel_elevation", Radian;
}

impl Source {
    /// Number of sources.
    pub const COUNT: usize = Source::ALL.len();

    /// Look a source up by its snake_case name.
    pub fn from_name(name: &str) -> Option<Source> {
        Source::ALL.iter().copied().find(|s| s.name() == name)
    }

    /// The config key of this source: name plus unit suffix, e.g. `boresight_roll_deg`.
    pub fn config_key(self) -> String {
        format!("{}{}", self.name(), self.unit().config_suffix())
    }

    /// Parse a config key (`range_m`, `heading_deg`, `time_water_ns`); `None` when the name is
    /// unknown or the suffix is not this source's unit.
    pub fn from_config_key(key: &str) -> Option<Source> {
        Source::ALL.iter().copied().find(|s| s.config_key() == key)
    }

    /// Index in [`Source::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }
}

impl fmt::Display for Source {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_keys_round_trip() {
        assert_eq!(Source::COUNT, 29);
        for (i, s) in Source::ALL.iter().enumerate() {
            assert_eq!(s.index(), i);
            assert_eq!(Source::from_name(s.name()), Some(*s));
            assert_eq!(Source::from_config_key(&s.config_key()), Some(*s));
        }
        assert_eq!(Source::BoresightRoll.config_key(), "boresight_roll_deg");
        assert_eq!(Source::TimeWater.config_key(), "time_water_ns");
        assert_eq!(Source::from_config_key("range_deg"), None);
        assert_eq!(Source::NWater.config_key(), "n_water");
        assert_eq!(
            Source::WaterSurfaceSlopeNorth.config_key(),
            "water_surface_slope_north_deg"
        );
        assert_eq!(
            Source::WaterSurfaceHeight.config_key(),
            "water_surface_height_m"
        );
    }
}
