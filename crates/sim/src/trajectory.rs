//! True and measured trajectories of one strip.
//!
//! The true platform flies the grid line at constant speed and height; its attitude is a
//! sinusoidal oscillation plus a seeded random walk about the track (heading = grid bearing +
//! grid convergence, so it is a true heading). The measured trajectory adds first-order
//! Gauss–Markov errors `x_{k+1} = φ x_k + σ √(1 − φ²) w_k`, `φ = e^(−Δt/τ)`, started from the
//! stationary distribution, so every sample has marginal σ and neighbouring samples are
//! correlated over τ (not white noise per pulse).
//!
//! With `[errors] line_*`, each line also carries its own constant GNSS offset, linear GNSS drift
//! (zero at the line's middle) and constant attitude offset, drawn once per line
//! ([`LineError::draw`]): the per-line trajectory errors a strip adjustment estimates.
//!
//! Both are sampled at the trajectory rate and linearly interpolated at pulse times (latitude,
//! longitude, height and unwrapped angles), exactly as a user interpolates an SBET.

use crate::scenario::{ErrorModel, Line, LineErrorSigma, Motion};
use lidarqa_io::{Geodetic, NedToGrid, UtmZone};
use lidarqa_model::{Sigmas, Source, ecef_from_ned};
use nalgebra::{Matrix3, Vector3};
use rand::Rng;
use rand_distr::StandardNormal;
use std::f64::consts::PI;

/// One trajectory sample, SI: geodetic position, attitude (B → N) and NED velocity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Pose {
    /// GPS seconds of week, s.
    pub time_s: f64,
    /// Geodetic (WGS 84 / the zone's ellipsoid) position of the GNSS/INS reference point.
    pub position: Geodetic,
    /// Roll, rad.
    pub roll_rad: f64,
    /// Pitch, rad.
    pub pitch_rad: f64,
    /// True heading, rad, unwrapped (continuous along the strip; may leave [−π, π)).
    pub heading_rad: f64,
    /// Velocity north, east, down, m/s.
    pub velocity_ned_m_per_s: [f64; 3],
}

/// The data of one sample in its map's frame: NED offset of the reference point from the map
/// origin, and the rotation NED(sample) → NED(map origin).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Frame {
    pub offset: Vector3<f64>,
    pub rotation: Matrix3<f64>,
}

/// Interval [k, k+1] of a trajectory expressed in the map of sample k.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Segment {
    pub map: u32,
    pub truth: [Frame; 2],
    pub measured: [Frame; 2],
}

/// True and measured trajectory of one strip, with the local maps.
#[derive(Debug, Clone)]
pub(crate) struct StripTrajectory {
    pub t0_s: f64,
    pub rate_hz: f64,
    pub truth: Vec<Pose>,
    pub measured: Vec<Pose>,
    pub segments: Vec<Segment>,
    pub maps: Vec<NedToGrid>,
}

/// One line's own trajectory error, SI, drawn once per line: added to the measured trajectory.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct LineError {
    /// GNSS position offset (north, east, up) at the line's middle, m.
    pub gnss_offset_m: [f64; 3],
    /// GNSS drift (north, east, up): the change from the line's middle to its end, m.
    pub gnss_drift_m: [f64; 3],
    /// Attitude offset (roll, pitch, heading), rad.
    pub attitude_rad: [f64; 3],
}

impl LineError {
    /// Each component `σ · N(0, 1)`, in the order offset, drift, attitude.
    pub fn draw(sigma: &LineErrorSigma, rng: &mut impl Rng) -> Self {
        let mut three = |s: &[f64; 3]| s.map(|s| s * rng.sample::<f64, _>(StandardNormal));
        LineError {
            gnss_offset_m: three(&sigma.gnss_offset_m),
            gnss_drift_m: three(&sigma.gnss_drift_m),
            attitude_rad: three(&sigma.attitude_rad),
        }
    }

    /// The error added at `t` seconds after the line's start of a line of `duration_s`: GNSS
    /// north, east, up (m), roll, pitch, heading (rad).
    fn at(&self, t: f64, duration_s: f64) -> [f64; 6] {
        let half = 0.5 * duration_s;
        let tau = (t - half) / half;
        std::array::from_fn(|i| {
            if i < 3 {
                self.gnss_offset_m[i] + tau * self.gnss_drift_m[i]
            } else {
                self.attitude_rad[i - 3]
            }
        })
    }
}

/// Samples between two local-map origins (the map is accurate far beyond the ~1 s of flight).
const SAMPLES_PER_MAP: usize = 200;

/// Gauss–Markov σ of the trajectory errors, in the order gnss north, east, up, roll, pitch,
/// heading.
pub(crate) fn trajectory_sigmas(sigma: &Sigmas) -> [f64; 6] {
    [
        sigma.get(Source::GnssNorth),
        sigma.get(Source::GnssEast),
        sigma.get(Source::GnssUp),
        sigma.get(Source::Roll),
        sigma.get(Source::Pitch),
        sigma.get(Source::Heading),
    ]
}

#[allow(clippy::too_many_arguments)]
pub(crate) fn build(
    zone: &UtmZone,
    origin_en: [f64; 2],
    line: &Line,
    motion: &Motion,
    errors: &ErrorModel,
    sigma: &Sigmas,
    line_error: &LineError,
    rng: &mut impl Rng,
) -> StripTrajectory {
    let rate = motion.trajectory_rate_hz;
    let dt = 1.0 / rate;
    let n = (line.duration_s() * rate).ceil() as usize + 2;
    let len = line.length_m();
    let dir = [
        (line.end_m[0] - line.start_m[0]) / len,
        (line.end_m[1] - line.start_m[1]) / len,
    ];
    let bearing = dir[0].atan2(dir[1]);
    let phase: [f64; 3] = std::array::from_fn(|_| rng.random::<f64>() * 2.0 * PI);
    let mut walk = [0.0f64; 3];
    let rw_step = motion.random_walk_rad_per_sqrt_s * dt.sqrt();
    let sig = if errors.random {
        trajectory_sigmas(sigma)
    } else {
        [0.0; 6]
    };
    let taus = [
        errors.gnss_correlation_time_s,
        errors.gnss_correlation_time_s,
        errors.gnss_correlation_time_s,
        errors.attitude_correlation_time_s,
        errors.attitude_correlation_time_s,
        errors.attitude_correlation_time_s,
    ];
    let phi = taus.map(|tau| (-dt / tau).exp());
    let mut err: [f64; 6] = std::array::from_fn(|i| sig[i] * rng.sample::<f64, _>(StandardNormal));
    let ell = zone.datum().ellipsoid();
    let mut truth = Vec::with_capacity(n);
    let mut measured = Vec::with_capacity(n);
    for k in 0..n {
        let t = k as f64 * dt;
        let s = line.speed_m_per_s * t;
        let (x, y) = (line.start_m[0] + dir[0] * s, line.start_m[1] + dir[1] * s);
        let pos = geodetic_of_local(zone, origin_en, x, y, line.height_m);
        let conv = zone.grid_convergence(pos.latitude_rad, pos.longitude_rad);
        let track = bearing + conv;
        let osc = |i: usize| {
            motion.amplitude_rad[i] * (2.0 * PI * t / motion.period_s[i] + phase[i]).sin()
        };
        let pose = Pose {
            time_s: line.start_time_s + t,
            position: pos,
            roll_rad: osc(0) + walk[0],
            pitch_rad: motion.mean_pitch_rad + osc(1) + walk[1],
            heading_rad: track + osc(2) + walk[2],
            velocity_ned_m_per_s: [
                line.speed_m_per_s * track.cos(),
                line.speed_m_per_s * track.sin(),
                0.0,
            ],
        };
        let own = line_error.at(t, line.duration_s());
        let e: [f64; 6] = std::array::from_fn(|i| err[i] + own[i]);
        let lat = pos.latitude_rad;
        let m_radius = ell.meridian_radius_m(lat) + pos.height_m;
        let n_radius = (ell.prime_vertical_radius_m(lat) + pos.height_m) * lat.cos();
        measured.push(Pose {
            position: Geodetic {
                latitude_rad: lat + e[0] / m_radius,
                longitude_rad: pos.longitude_rad + e[1] / n_radius,
                height_m: pos.height_m + e[2],
            },
            roll_rad: pose.roll_rad + e[3],
            pitch_rad: pose.pitch_rad + e[4],
            heading_rad: pose.heading_rad + e[5],
            ..pose
        });
        truth.push(pose);
        for (w, _) in walk.iter_mut().zip(0..3) {
            *w += rw_step * rng.sample::<f64, _>(StandardNormal);
        }
        for i in 0..6 {
            let w: f64 = rng.sample(StandardNormal);
            err[i] = phi[i] * err[i] + sig[i] * (1.0 - phi[i] * phi[i]).sqrt() * w;
        }
    }
    let maps: Vec<NedToGrid> = (0..n.div_ceil(SAMPLES_PER_MAP))
        .map(|m| NedToGrid::new(zone, origin_en, &truth[m * SAMPLES_PER_MAP].position))
        .collect();
    let frame = |map: &NedToGrid, g: &Geodetic| {
        let tangent = map.frame();
        Frame {
            offset: tangent.to_ned(&ell.geodetic_to_ecef(g)).vector(),
            rotation: tangent.ned_from_ecef() * ecef_from_ned(g.latitude_rad, g.longitude_rad),
        }
    };
    let segments = (0..n - 1)
        .map(|k| {
            let m = k / SAMPLES_PER_MAP;
            let map = &maps[m];
            Segment {
                map: m as u32,
                truth: [
                    frame(map, &truth[k].position),
                    frame(map, &truth[k + 1].position),
                ],
                measured: [
                    frame(map, &measured[k].position),
                    frame(map, &measured[k + 1].position),
                ],
            }
        })
        .collect();
    StripTrajectory {
        t0_s: line.start_time_s,
        rate_hz: rate,
        truth,
        measured,
        segments,
        maps,
    }
}

/// Geodetic position of a local grid point (x, y from the origin) at ellipsoidal height h.
fn geodetic_of_local(zone: &UtmZone, origin_en: [f64; 2], x: f64, y: f64, h: f64) -> Geodetic {
    let (lat, lon) = zone.inverse(origin_en[0] + x, origin_en[1] + y);
    Geodetic {
        latitude_rad: lat,
        longitude_rad: lon,
        height_m: h,
    }
}
