//! The one error type of lidarqa-sim.

/// What can go wrong while reading, checking or running a scenario.
///
/// Messages are lowercase with no final period and name the key (TOML path) and the value at
/// fault, so the CLI can print one line a user can act on.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The TOML text does not parse or does not match the scenario layout (an unknown key, a
    /// missing key, a wrong type). The message of the `toml` crate names the key and the line.
    #[error("scenario: {0}")]
    Parse(String),

    /// `Scenario::builtin` was given a name it does not know.
    #[error("unknown built-in scenario {name:?} (built-ins: {known})")]
    UnknownBuiltin {
        /// The name asked for.
        name: String,
        /// The built-in names, comma-separated.
        known: String,
    },

    /// A key has a value the simulator cannot use.
    #[error("{key} = {value}: {reason}")]
    InvalidValue {
        /// The TOML path of the key, e.g. `lines[1].speed_m_per_s`.
        key: String,
        /// The value as written.
        value: String,
        /// Why it is refused.
        reason: String,
    },

    /// An object (target, building, paved area, water body) lies outside the scene extent.
    #[error(
        "{key}: {what} at [{:.3}, {:.3}] m is outside the scene [{:.3}, {:.3}] x [{:.3}, {:.3}] m (local easting x northing)",
        position_m[0], position_m[1], min_m[0], max_m[0], min_m[1], max_m[1]
    )]
    OutsideScene {
        /// The TOML path of the object, e.g. `scene.targets[2]`.
        key: String,
        /// What lies outside (`target "T3"`, `building corner`, ...).
        what: String,
        /// The offending position, local easting / northing from the origin, m.
        position_m: [f64; 2],
        /// Scene minimum corner, local m.
        min_m: [f64; 2],
        /// Scene maximum corner, local m.
        max_m: [f64; 2],
    },

    /// The scenario's `[sensor]` is not a valid sensor file (lidarqa-io's one sensor check).
    #[error("{key}: {message}")]
    Sensor {
        /// The TOML path of the key at fault, e.g. `sensor.sigma.range_deg`.
        key: String,
        /// What is wrong (io's message).
        message: String,
    },

    /// A file of the survey could not be written (lidarqa-io's message names it).
    #[error(transparent)]
    Io(#[from] lidarqa_io::Error),

    /// lidarqa-model refused a sensor value.
    #[error("{key}: {source}")]
    Model {
        /// The TOML path of the key at fault.
        key: String,
        /// The model's error.
        source: lidarqa_model::Error,
    },

    /// lidarqa-io refused the projection (EPSG code).
    #[error("{key}: {source}")]
    Projection {
        /// The TOML path of the key at fault.
        key: String,
        /// The io crate's error.
        source: lidarqa_io::Error,
    },

    /// A pulse of a strip could not be traced through the scene (e.g. the beam points above the
    /// horizon because of an extreme attitude).
    #[error("strip {strip}: pulse at {gps_time_s:.6} s: {reason}")]
    Trace {
        /// Strip (flight line) id.
        strip: u16,
        /// GPS seconds of week of the pulse.
        gps_time_s: f64,
        /// What went wrong.
        reason: String,
    },
}

/// Result with the lidarqa-sim [`Error`].
pub type Result<T> = std::result::Result<T, Error>;
