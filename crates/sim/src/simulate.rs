//! The simulation kernel.
//!
//! For every pulse (SPEC §3):
//! 1. the **true** ray is cast from the true trajectory, the true mounting (nominal + injected
//!    errors) and the true scan angle / azimuth into the scene, giving the true range;
//! 2. the **measured** observations are made from it: range + offset + white noise, scan angle ·
//!    (1 + scale) + white noise (conic: azimuth + noise, travel times + noise);
//! 3. the point is **georeferenced** from the measured trajectory (true + Gauss–Markov GNSS and
//!    attitude errors), the NOMINAL mounting and the measured observations with lidarqa-model's
//!    `footprint_ned`, then NED → ECEF → geodetic → UTM (through lidarqa-io's local quadratic
//!    map `NedToGrid`, accurate to 5·10⁻⁵ m over a kilometre).
//!
//! So every injected error shows in the coordinates exactly as it would in real data.
//!
//! Determinism: each strip is cut into chunks of a fixed number of pulses; chunk `c` of strip `s`
//! draws from its own ChaCha8 stream `(seed, stream = purpose · 2⁵⁶ + s · 2³² + c)`, and chunks are
//! concatenated in order, so the output does not depend on the number of threads.

use crate::error::{Error, Result};
use crate::output::{
    InjectedErrors, LineErrorTruth, MountingParameters, Observation, PointTruth, RandomErrors,
    SimPoint, Strip, StripTruth, Survey, SurveyedTarget, TargetTruth, TrajectoryRecord, Truth,
};
use crate::ray::Curve;
use crate::scenario::{Line, ScanPattern, ScanWave, Scenario};
use crate::scene::{
    ANCHOR_CHAIN, ANCHOR_REACH_RAD, CLASS_BATHYMETRY, CLASS_WATER_SURFACE, REFLECTIVITY_BED,
    REFLECTIVITY_TARGET, REFLECTIVITY_TERRAIN, Sweep, WATER_ATTENUATION_PER_M, add_angles,
    small_sin_cos,
};
use crate::trajectory::{self, LineError, Pose, StripTrajectory, trajectory_sigmas};
use lidarqa_io::Progress;
use lidarqa_model::{
    Attitude, BeamObservation, BeamScanner, ConicObservation, ConicScanner, Georeferencer,
    LinearObservation, LinearScanner, Mounting, SPEED_OF_LIGHT_AIR_M_PER_S, Scanner, Source,
    refract, rotation_zyx, scanner_vector,
};
use nalgebra::{Matrix3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use rayon::prelude::*;
use std::f64::consts::PI;
use std::sync::{Mutex, PoisonError};

/// Shortest in-water path of a sounding, m: a seabed closer to the surface than this is not
/// separated from the surface return (a real bathymetric pulse lasts a few ns; 0.5 m of water
/// is 4.4 ns two-way), so it gives no class-40 point.
pub const MIN_WATER_RANGE_M: f64 = 0.5;

/// Options of a run that do not change the survey itself.
#[derive(Debug, Clone, Copy)]
pub struct SimOptions<'a> {
    /// Keep the per-point truth ([`Strip::truth`]): ~100 bytes more per point.
    pub keep_truth: bool,
    /// Pulses per chunk (the unit of parallel work and of RNG streams). Changing it changes the
    /// random draws; the thread count never does.
    pub chunk_pulses: usize,
    /// Told the pulses of each chunk once it is simulated (from worker threads).
    pub progress: Progress<'a>,
}

impl Default for SimOptions<'_> {
    fn default() -> Self {
        SimOptions {
            keep_truth: false,
            chunk_pulses: 1 << 15,
            progress: Progress::NONE,
        }
    }
}

/// The least downward component of a beam scanner's beam that is traced (cos 75°): a head that
/// fires all round sends the rest above the horizon or to ranges of kilometres.
const MIN_BEAM_DOWN: f64 = 0.258_819_045_102_521;

const PURPOSE_PULSES: u64 = 0;
const PURPOSE_TRAJECTORY: u64 = 1;
const PURPOSE_MOUNTING: u64 = 2;
const PURPOSE_CONTROL: u64 = 3;
const PURPOSE_LINE_ERRORS: u64 = 4;

/// The own trajectory error of line `index` (`[errors] line_*`; none with `random = false`).
fn line_error(scenario: &Scenario, index: usize) -> LineError {
    let errors = scenario.errors();
    if !errors.random || !errors.line_errors.any() {
        return LineError::default();
    }
    LineError::draw(
        &errors.line_errors,
        &mut stream(scenario.seed(), PURPOSE_LINE_ERRORS, index, 0),
    )
}

/// The RNG of one purpose / strip / chunk: ChaCha8 (portable, seekable), keyed by the seed.
fn stream(seed: u64, purpose: u64, strip: usize, chunk: usize) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(
        (purpose << 56) | ((strip as u64 & 0xff_ffff) << 32) | (chunk as u64 & 0xffff_ffff),
    );
    rng
}

#[inline]
fn normal(rng: &mut ChaCha8Rng) -> f64 {
    rng.sample(StandardNormal)
}

/// `σ · N(0, 1)`, drawing nothing when σ = 0 (so switched-off errors are exactly zero).
#[inline]
fn draw(rng: &mut ChaCha8Rng, sigma: f64) -> f64 {
    if sigma > 0.0 {
        sigma * normal(rng)
    } else {
        0.0
    }
}

/// Simulate the whole survey.
///
/// # Errors
/// [`Error::Trace`] if a pulse cannot be traced (a beam above the horizon).
///
/// # Example
/// ```
/// use lidarqa_sim::{Scenario, SimOptions, simulate};
/// let mut file = Scenario::builtin("demo").unwrap().file().clone();
/// file.lines.truncate(1);
/// file.lines[0].end_m = [file.lines[0].start_m[0] + 20.0, file.lines[0].start_m[1]];
/// let survey = simulate(&Scenario::from_file(file).unwrap(), &SimOptions::default()).unwrap();
/// assert!(survey.point_count() > 1000);
/// ```
pub fn simulate(scenario: &Scenario, options: &SimOptions) -> Result<Survey> {
    let mut collect = Collect::default();
    let mut survey = simulate_streaming(scenario, options, &mut collect)?;
    for (strip, (points, truth)) in survey.strips.iter_mut().zip(collect.strips) {
        strip.points = points;
        strip.truth = truth;
    }
    Ok(survey)
}

/// Where [`simulate_streaming`] delivers the points, strip by strip in scenario order and, within
/// a strip, in pulse order.
pub trait PointSink {
    /// The next points of the strip with index `strip` (its place in the scenario's lines), with
    /// their truth (empty unless [`SimOptions::keep_truth`]).
    ///
    /// # Errors
    /// Whatever stops the run (an output that cannot be written).
    fn points(&mut self, strip: usize, points: &[SimPoint], truth: &[PointTruth]) -> Result<()>;

    /// Strip `strip` is complete: called once for every strip, in order, also for a strip
    /// without points.
    ///
    /// # Errors
    /// As [`PointSink::points`].
    fn end_strip(&mut self, strip: usize) -> Result<()>;
}

/// The in-memory sink of [`simulate`]: every strip's points and truth.
#[derive(Default)]
struct Collect {
    strips: Vec<(Vec<SimPoint>, Vec<PointTruth>)>,
}

impl PointSink for Collect {
    fn points(&mut self, strip: usize, points: &[SimPoint], truth: &[PointTruth]) -> Result<()> {
        if self.strips.len() <= strip {
            self.strips.resize_with(strip + 1, Default::default);
        }
        self.strips[strip].0.extend_from_slice(points);
        self.strips[strip].1.extend_from_slice(truth);
        Ok(())
    }

    fn end_strip(&mut self, strip: usize) -> Result<()> {
        if self.strips.len() <= strip {
            self.strips.resize_with(strip + 1, Default::default);
        }
        Ok(())
    }
}

/// Simulates the survey and hands the points to `sink` as they are computed, so that memory is
/// bounded by a few chunks (see [`SimOptions::chunk_pulses`]), not by the survey: the chunks of
/// a strip are computed in parallel windows, each while the sink takes the one before
/// (`rayon::join`, in the current thread pool). The points are those of [`simulate`], in the same
/// order; the returned survey's strips hold no points or truth (they went to the sink), the
/// rest (trajectories, control, [`Survey::truth`] with each strip's point count) is complete.
///
/// # Errors
/// As [`simulate`], and the sink's errors.
pub fn simulate_streaming(
    scenario: &Scenario,
    options: &SimOptions,
    sink: &mut (dyn PointSink + Send),
) -> Result<Survey> {
    let seed = scenario.seed();
    let sensor = scenario.sensor();
    let errors = scenario.errors();
    // The true mounting: nominal + injected + (optionally) one draw from the mounting σ.
    let drawn = if errors.random_mounting {
        let mut rng = stream(seed, PURPOSE_MOUNTING, 0, 0);
        let mut d = |s: Source| sensor.sigma.get(s) * normal(&mut rng);
        Mounting {
            boresight_roll_rad: d(Source::BoresightRoll),
            boresight_pitch_rad: d(Source::BoresightPitch),
            boresight_yaw_rad: d(Source::BoresightYaw),
            lever_arm_m: Vector3::new(d(Source::LeverX), d(Source::LeverY), d(Source::LeverZ)),
        }
    } else {
        Mounting::default()
    };
    let nominal = sensor.mounting;
    let inj = errors.injected_mounting;
    let true_mounting = Mounting {
        boresight_roll_rad: nominal.boresight_roll_rad
            + inj.boresight_roll_rad
            + drawn.boresight_roll_rad,
        boresight_pitch_rad: nominal.boresight_pitch_rad
            + inj.boresight_pitch_rad
            + drawn.boresight_pitch_rad,
        boresight_yaw_rad: nominal.boresight_yaw_rad
            + inj.boresight_yaw_rad
            + drawn.boresight_yaw_rad,
        lever_arm_m: nominal.lever_arm_m + inj.lever_arm_m + drawn.lever_arm_m,
    };

    let window = 4 * rayon::current_num_threads().max(1);
    let mut counts = Vec::with_capacity(scenario.lines().len());
    let mut strips = Vec::with_capacity(scenario.lines().len());
    for (index, line) in scenario.lines().iter().enumerate() {
        let (strip, count) =
            simulate_strip(scenario, options, &true_mounting, index, line, window, sink)?;
        strips.push(strip);
        counts.push(count);
    }

    let origin = scenario.origin_m();
    let scene = scenario.scene();
    let mut rng = stream(seed, PURPOSE_CONTROL, 0, 0);
    let [sh, sv] = scene.control_sigma_m;
    // The survey's own noise is one of the random errors: off with them, so that a run with
    // `random = false` is noise-free end to end (the calibration's numerical floor is tested so).
    let survey = if scenario.errors().random { 1.0 } else { 0.0 };
    let control = scene
        .targets
        .iter()
        .map(|t| SurveyedTarget {
            id: t.id.clone(),
            easting_m: origin[0] + t.center_m[0] + survey * sh * normal(&mut rng),
            northing_m: origin[1] + t.center_m[1] + survey * sh * normal(&mut rng),
            height_m: t.height_m + survey * sv * normal(&mut rng),
            sigma_horizontal_m: sh,
            sigma_vertical_m: sv,
            radius_m: t.radius_m,
        })
        .collect();
    let sigma_keys = Source::ALL
        .iter()
        .filter(|s| sensor.sigma.get(**s) > 0.0)
        .map(|s| {
            (
                s.config_key(),
                sensor.sigma.get(*s) / s.unit().config_to_si(),
            )
        })
        .collect();
    let truth = Truth {
        scenario: scenario.name().to_string(),
        seed,
        epsg: scenario.epsg(),
        gps_week: scenario.gps_week(),
        origin_m: origin,
        mounting: MountingParameters::from(&true_mounting),
        nominal_mounting: MountingParameters::from(&nominal),
        injected: InjectedErrors {
            mounting: MountingParameters::from(&inj),
            random_mounting: MountingParameters::from(&drawn),
            range_offset_m: errors.range_offset_m,
            scan_angle_scale_ppm: errors.scan_angle_scale * 1e6,
        },
        random: RandomErrors {
            enabled: errors.random,
            gnss_correlation_time_s: errors.gnss_correlation_time_s,
            attitude_correlation_time_s: errors.attitude_correlation_time_s,
            sigma: sigma_keys,
        },
        targets: scene
            .targets
            .iter()
            .map(|t| TargetTruth {
                id: t.id.clone(),
                easting_m: origin[0] + t.center_m[0],
                northing_m: origin[1] + t.center_m[1],
                height_m: t.height_m,
                radius_m: t.radius_m,
            })
            .collect(),
        strips: strips
            .iter()
            .zip(scenario.lines())
            .enumerate()
            .map(|(k, (s, l))| StripTruth {
                id: s.id,
                pulses: s.pulses,
                points: counts[k],
                time_span_s: [
                    s.trajectory.first().map_or(0.0, |r| r.time_s),
                    s.trajectory.last().map_or(0.0, |r| r.time_s),
                ],
                height_m: l.height_m,
                trajectory_error: (errors.random && errors.line_errors.any()).then(|| {
                    let e = line_error(scenario, k);
                    LineErrorTruth {
                        start_time_s: l.start_time_s,
                        end_time_s: l.start_time_s + l.duration_s(),
                        offset_m: e.gnss_offset_m.into(),
                        drift_m: e.gnss_drift_m.into(),
                        attitude_deg: e.attitude_rad.map(f64::to_degrees).into(),
                    }
                }),
            })
            .collect(),
        scene: scenario.file().scene.clone(),
    };
    let trajectory_sigma_si = if errors.random {
        trajectory_sigmas(&sensor.sigma)
    } else {
        [0.0; 6]
    };
    Ok(Survey {
        strips,
        control,
        truth,
        true_mounting,
        trajectory_sigma_si,
    })
}

fn record(p: &Pose) -> TrajectoryRecord {
    TrajectoryRecord {
        time_s: p.time_s,
        latitude_rad: p.position.latitude_rad,
        longitude_rad: p.position.longitude_rad,
        height_m: p.position.height_m,
        velocity_north_m_per_s: p.velocity_ned_m_per_s[0],
        velocity_east_m_per_s: p.velocity_ned_m_per_s[1],
        velocity_down_m_per_s: p.velocity_ned_m_per_s[2],
        roll_rad: p.roll_rad,
        pitch_rad: p.pitch_rad,
        heading_rad: (p.heading_rad + PI).rem_euclid(2.0 * PI) - PI,
    }
}

/// Per-strip constants of the kernel.
struct Kernel<'a> {
    scenario: &'a Scenario,
    traj: &'a StripTrajectory,
    strip_id: u16,
    origin: [f64; 2],
    true_mounting: Mounting,
    r_m_true: Matrix3<f64>,
    nominal: Mounting,
    conic: Option<ConicScanner>,
    /// The beam scanner (rotating mirror, spinning multi-beam, Risley, elliptical).
    beam: Option<&'a BeamScanner>,
    /// A beam scanner's white per-pulse σ: first encoder, second encoder, channel elevation
    /// (rad); the range's is `sigma[0]` grown by the ppm part.
    beam_sigma: [f64; 3],
    /// White per-pulse σ: range (m) or time air (s), scan angle or azimuth (rad), time water (s).
    sigma: [f64; 3],
    keep_truth: bool,
}

/// Simulates one strip into `sink`, window by window; also returns its point count.
#[allow(clippy::too_many_arguments)]
fn simulate_strip(
    scenario: &Scenario,
    options: &SimOptions,
    true_mounting: &Mounting,
    index: usize,
    line: &Line,
    window: usize,
    sink: &mut (dyn PointSink + Send),
) -> Result<(Strip, u64)> {
    let sensor = scenario.sensor();
    let mut rng = stream(scenario.seed(), PURPOSE_TRAJECTORY, index, 0);
    let traj = trajectory::build(
        scenario.zone(),
        scenario.origin_m(),
        line,
        scenario.motion(),
        scenario.errors(),
        &sensor.sigma,
        &line_error(scenario, index),
        &mut rng,
    );
    let random = scenario.errors().random;
    let sig = |s: Source| if random { sensor.sigma.get(s) } else { 0.0 };
    let beam = match &sensor.scanner {
        Scanner::Beam(b) => Some(b),
        _ => None,
    };
    let beam_sigma = [
        sig(Source::ScanAngle),
        sig(Source::ScanAngle2),
        sig(Source::ChannelElevation),
    ];
    let (conic, sigma) = match &sensor.scanner {
        // A beam scanner's range and first encoder are the linear scanner's sources.
        Scanner::Linear | Scanner::Beam(_) => {
            (None, [sig(Source::Range), sig(Source::ScanAngle), 0.0])
        }
        Scanner::Conic(c) => (
            Some(*c),
            [
                sig(Source::TimeAir),
                sig(Source::ScanAzimuth),
                sig(Source::TimeWater),
            ],
        ),
    };
    let kernel = Kernel {
        scenario,
        traj: &traj,
        strip_id: line.id,
        origin: scenario.origin_m(),
        true_mounting: *true_mounting,
        r_m_true: rotation_zyx(
            true_mounting.boresight_roll_rad,
            true_mounting.boresight_pitch_rad,
            true_mounting.boresight_yaw_rad,
        ),
        nominal: sensor.mounting,
        conic,
        beam,
        beam_sigma,
        sigma,
        keep_truth: options.keep_truth,
    };
    let pulses = (line.duration_s() * scenario.pulse_rate_hz()).floor() as u64;
    let chunk = options.chunk_pulses.max(1) as u64;
    let n_chunks = pulses.div_ceil(chunk);
    // The point buffers the sink has taken, for the next chunks: fresh ones each time cost as
    // much in page faults as a tenth of the geometry.
    let spare: Mutex<Vec<Vec<SimPoint>>> = Mutex::default();
    let spare_list = || spare.lock().unwrap_or_else(PoisonError::into_inner);
    let compute = |first: u64| -> Result<Vec<(Vec<SimPoint>, Vec<PointTruth>)>> {
        let last = (first + window as u64).min(n_chunks);
        (first..last)
            .into_par_iter()
            .map(|c| {
                let mut rng = stream(scenario.seed(), PURPOSE_PULSES, index, c as usize);
                let (start, end) = (c * chunk, ((c + 1) * chunk).min(pulses));
                let cap = (end - start) as usize;
                let mut points = spare_list().pop().unwrap_or_default();
                points.clear();
                points.reserve(cap + cap / 8);
                let mut truth = Vec::with_capacity(if options.keep_truth { cap } else { 0 });
                // The chunk's pulses in order: each ray's ground search starts at the last
                // one's (the air's and the water's apart).
                let mut sweeps = [scenario.scene().sweep(); 2];
                let mut attitude = None;
                for i in start..end {
                    let state = (&mut sweeps, &mut attitude);
                    kernel.pulse(i, &mut rng, state, &mut points, &mut truth)?;
                }
                options.progress.report(end - start);
                Ok((points, truth))
            })
            .collect()
    };
    let mut count = 0u64;
    let mut give = |chunks: Vec<(Vec<SimPoint>, Vec<PointTruth>)>| -> Result<()> {
        for (points, truth) in chunks {
            count += points.len() as u64;
            sink.points(index, &points, &truth)?;
            spare_list().push(points);
        }
        Ok(())
    };
    // Window k + 1 is computed while the sink takes window k.
    let mut ready = compute(0)?;
    let mut first = window as u64;
    while first < n_chunks {
        let (next, given) = rayon::join(|| compute(first), || give(ready));
        given?;
        ready = next?;
        first += window as u64;
    }
    give(ready)?;
    sink.end_strip(index)?;
    let strip = Strip {
        id: line.id,
        points: Vec::new(),
        truth: Vec::new(),
        trajectory: traj.measured.iter().map(record).collect(),
        true_trajectory: traj.truth.iter().map(record).collect(),
        pulses,
    };
    Ok((strip, count))
}

#[inline]
fn lerp_attitude(a: &Pose, b: &Pose, f: f64) -> Attitude {
    Attitude {
        roll_rad: a.roll_rad + f * (b.roll_rad - a.roll_rad),
        pitch_rad: a.pitch_rad + f * (b.pitch_rad - a.pitch_rad),
        heading_rad: a.heading_rad + f * (b.heading_rad - a.heading_rad),
    }
}

#[inline]
fn lerp_frame(fr: &[trajectory::Frame; 2], f: f64) -> (Vector3<f64>, Matrix3<f64>) {
    (
        fr[0].offset + (fr[1].offset - fr[0].offset) * f,
        fr[0].rotation + (fr[1].rotation - fr[0].rotation) * f,
    )
}

impl Kernel<'_> {
    fn intensity(
        &self,
        reflectivity: f64,
        cos_incidence: f64,
        range_m: f64,
        rng: &mut ChaCha8Rng,
    ) -> u16 {
        let errors = self.scenario.errors();
        let noise = errors.intensity_noise;
        let n = if noise > 0.0 {
            1.0 + noise * normal(rng)
        } else {
            1.0
        };
        // Additive noise, a fraction of the target–ground contrast at this range and incidence.
        let contrast =
            errors.intensity_contrast_noise * (REFLECTIVITY_TARGET - REFLECTIVITY_TERRAIN);
        let add = if contrast > 0.0 {
            contrast * normal(rng)
        } else {
            0.0
        };
        // Range normalised to 150 m: no saturation of the u16 scale above ~110 m even for the
        // target plates (reflectivity ~0.9), and still a 1/ρ² fall-off.
        let r = 150.0 / range_m;
        let i = 0.8 * (reflectivity * n + add) * cos_incidence.abs().max(0.02) * r * r;
        (i.clamp(0.0, 1.0) * 65535.0).round().max(1.0) as u16
    }

    fn pulse(
        &self,
        i: u64,
        rng: &mut ChaCha8Rng,
        (sweeps, attitude): (&mut [Sweep; 2], &mut Option<AttitudeAnchor>),
        points: &mut Vec<SimPoint>,
        truth: &mut Vec<PointTruth>,
    ) -> Result<()> {
        let sc = self.scenario;
        let tau = i as f64 / sc.pulse_rate_hz();
        let t = self.traj.t0_s + tau;
        let x = tau * self.traj.rate_hz;
        let k = (x.floor() as usize).min(self.traj.segments.len() - 1);
        let f = x - k as f64;
        let seg = &self.traj.segments[k];
        let map = &self.traj.maps[seg.map as usize];
        let att_true = lerp_attitude(&self.traj.truth[k], &self.traj.truth[k + 1], f);
        let (p_true, c_true) = lerp_frame(&seg.truth, f);
        let m_true = c_true * AttitudeAnchor::rotation(attitude, &att_true);
        let origin = p_true + m_true * self.true_mounting.lever_arm_m;
        let att_meas = lerp_attitude(&self.traj.measured[k], &self.traj.measured[k + 1], f);
        let (p_meas, c_meas) = lerp_frame(&seg.measured, f);
        let phase = tau
            * match sc.pattern() {
                ScanPattern::Linear { frequency_hz, .. } => frequency_hz,
                ScanPattern::Conic { rotation_hz } => rotation_hz,
                ScanPattern::Beam { rotation_hz, .. } => rotation_hz,
            };
        let fail = |reason: &str| Error::Trace {
            strip: self.strip_id,
            gps_time_s: t,
            reason: reason.into(),
        };
        let divergence = sc.beam_divergence_rad();
        let errors = sc.errors();
        let [s0, s1, s2] = self.sigma;

        let to_point = |v: &Vector3<f64>| map.eval(v);
        let mut emit = |local: Vector3<f64>,
                        hit_pos: [f64; 3],
                        intensity: u16,
                        scan_angle_deg: f64,
                        ret: (u8, u8),
                        class: u8,
                        true_obs: Observation,
                        obs: Observation| {
            points.push(SimPoint {
                easting_m: self.origin[0] + local.x,
                northing_m: self.origin[1] + local.y,
                height_m: local.z,
                gps_time_s: t,
                intensity,
                scan_angle_deg: scan_angle_deg as f32,
                return_number: ret.0,
                number_of_returns: ret.1,
                classification: class,
                point_source_id: self.strip_id,
            });
            if self.keep_truth {
                truth.push(PointTruth {
                    easting_m: self.origin[0] + hit_pos[0],
                    northing_m: self.origin[1] + hit_pos[1],
                    height_m: hit_pos[2],
                    true_observation: true_obs,
                    observation: obs,
                });
            }
        };

        match (&self.conic, sc.pattern()) {
            (
                None,
                ScanPattern::Linear {
                    field_of_view_rad,
                    wave,
                    ..
                },
            ) => {
                let u = match wave {
                    // Triangle wave in [−1, 1], 0 at τ = 0.
                    ScanWave::Triangle => 4.0 * ((phase + 0.25).fract() - 0.5).abs() - 1.0,
                    ScanWave::Sine => (2.0 * PI * phase).sin(),
                    // Sawtooth in [−1, 1), 0 at τ = 0, rising: one scan line per cycle.
                    ScanWave::Sawtooth => 2.0 * (phase + 0.5).fract() - 1.0,
                };
                let theta = field_of_view_rad * u;
                let dir = m_true * (self.r_m_true * scanner_vector(1.0, theta));
                let curve = Curve::along(map, &origin, &dir);
                let hit = sc
                    .scene()
                    .trace_in(&curve, divergence, &mut sweeps[0])
                    .ok_or_else(|| fail("the beam does not reach the ground"))?;
                let true_obs = LinearObservation {
                    range_m: hit.range_m,
                    scan_angle_rad: theta,
                };
                let obs = LinearObservation {
                    range_m: hit.range_m + errors.range_offset_m + draw(rng, s0),
                    scan_angle_rad: theta * (1.0 + errors.scan_angle_scale) + draw(rng, s1),
                };
                let georef = |o: &LinearObservation| {
                    let p = LinearScanner.parameters(&att_meas, &self.nominal, o);
                    to_point(&(p_meas + c_meas * LinearScanner.footprint_ned(&p)))
                };
                let cos_inc = cos_incidence(&curve.direction(hit.range_m), &hit.normal);
                let intensity = self.intensity(hit.reflectivity, cos_inc, hit.range_m, rng);
                // A crown above the ground return: the first of two returns of this pulse (its
                // draws come after the ground's, so a scene without vegetation is unchanged).
                let canopy = sc.scene().canopy_hit(&curve, &hit);
                let n_ret = 1 + u8::from(canopy.is_some());
                if let Some(c) = canopy {
                    let true_c = LinearObservation {
                        range_m: c.range_m,
                        scan_angle_rad: theta,
                    };
                    let obs_c = LinearObservation {
                        range_m: c.range_m + errors.range_offset_m + draw(rng, s0),
                        scan_angle_rad: obs.scan_angle_rad,
                    };
                    let intensity = self.intensity(c.reflectivity, 1.0, c.range_m, rng);
                    emit(
                        georef(&obs_c),
                        c.position,
                        intensity,
                        obs.scan_angle_rad.to_degrees(),
                        (1, 2),
                        c.class,
                        Observation::Linear(true_c),
                        Observation::Linear(obs_c),
                    );
                }
                emit(
                    georef(&obs),
                    hit.position,
                    intensity,
                    obs.scan_angle_rad.to_degrees(),
                    (n_ret, n_ret),
                    hit.class,
                    Observation::Linear(true_obs),
                    Observation::Linear(obs),
                );
            }
            (Some(conic), ScanPattern::Conic { .. }) => {
                let az = 2.0 * PI * phase.fract();
                let q = ConicObservation {
                    azimuth_rad: az,
                    time_air_s: 0.0,
                    time_water_s: 0.0,
                };
                let params = conic.parameters(&att_true, &self.true_mounting, &q);
                let (l3, _) = conic.beam_directions(&params);
                let dir = m_true * (self.r_m_true * l3);
                let curve = Curve::along(map, &origin, &dir);
                let hit = sc
                    .scene()
                    .trace_in(&curve, divergence, &mut sweeps[0])
                    .ok_or_else(|| fail("the beam does not reach the ground"))?;
                let c = SPEED_OF_LIGHT_AIR_M_PER_S;
                let scan_deg = l3.y.atan2(l3.z).to_degrees();
                let air_noise = draw(rng, s0);
                let az_noise = draw(rng, s1);
                let time_air = 2.0 * hit.range_m / c;
                let measure = |time_water_true: f64, water_noise: f64| {
                    let true_obs = ConicObservation {
                        azimuth_rad: az,
                        time_air_s: time_air,
                        time_water_s: time_water_true,
                    };
                    let obs = ConicObservation {
                        azimuth_rad: az + az_noise,
                        time_air_s: 2.0 * (hit.range_m + errors.range_offset_m) / c + air_noise,
                        time_water_s: time_water_true + water_noise,
                    };
                    let p = conic.parameters(&att_meas, &self.nominal, &obs);
                    (true_obs, obs, p_meas + c_meas * conic.footprint_ned(&p))
                };
                let cos_inc = cos_incidence(&curve.direction(hit.range_m), &hit.normal);
                let intensity = self.intensity(hit.reflectivity, cos_inc, hit.range_m, rng);
                if hit.class != CLASS_WATER_SURFACE {
                    let (to, o, v) = measure(0.0, 0.0);
                    emit(
                        to_point(&v),
                        hit.position,
                        intensity,
                        scan_deg,
                        (1, 1),
                        hit.class,
                        Observation::Conic(to),
                        Observation::Conic(o),
                    );
                    return Ok(());
                }
                // Refraction at the real surface: its normal in the map's NED frame is the
                // gradient of h − wave(x, y) with respect to the NED offset.
                let v_s = origin + dir * hit.range_m;
                let jac = map.jacobian(&v_s);
                let n = hit.normal;
                let grad = jac.row(2) * n[2] + jac.row(0) * n[0] + jac.row(1) * n[1];
                let down = -grad.transpose().normalize();
                let l_w = refract(&dir, &down, conic.n_air() / conic.n_water());
                let water_curve = Curve::along(map, &v_s, &l_w);
                // A bottom closer than MIN_WATER_RANGE_M below the surface is not separated from
                // the surface return (as with a real pulse of a few ns): no sounding.
                let bottom = sc
                    .scene()
                    .trace_ground_in(&water_curve, &mut sweeps[1])
                    .filter(|b| b.range_m >= MIN_WATER_RANGE_M);
                let (to, o, v) = measure(0.0, 0.0);
                let n_ret = if bottom.is_some() { 2 } else { 1 };
                emit(
                    to_point(&v),
                    hit.position,
                    intensity,
                    scan_deg,
                    (1, n_ret),
                    CLASS_WATER_SURFACE,
                    Observation::Conic(to),
                    Observation::Conic(o),
                );
                if let Some(b) = bottom {
                    let tw = 2.0 * conic.n_water() * b.range_m / c;
                    let water_noise = draw(rng, s2);
                    let (to, o, v) = measure(tw, water_noise);
                    let refl =
                        REFLECTIVITY_BED * (-2.0 * WATER_ATTENUATION_PER_M * b.range_m).exp();
                    let cos_b = cos_incidence(&water_curve.direction(b.range_m), &b.normal);
                    let intensity = self.intensity(refl, cos_b, hit.range_m + b.range_m, rng);
                    emit(
                        to_point(&v),
                        b.position,
                        intensity,
                        scan_deg,
                        (2, 2),
                        CLASS_BATHYMETRY,
                        Observation::Conic(to),
                        Observation::Conic(o),
                    );
                }
            }
            (
                None,
                ScanPattern::Beam {
                    rotation_2_hz,
                    half_field_of_view_rad,
                    ..
                },
            ) => {
                let Some(b) = self.beam else {
                    return Err(fail("scanner type and scan pattern disagree"));
                };
                // The encoders' true angles at this pulse.
                let a = 2.0 * PI * (phase.fract() - 0.5);
                if half_field_of_view_rad.is_some_and(|h| a.abs() > h) {
                    return Ok(());
                }
                let a2 = 2.0 * PI * (tau * rotation_2_hz).fract();
                let elevation = if b.channel_elevations_rad.is_empty() {
                    0.0
                } else {
                    b.channel_elevations_rad[(i % b.channel_elevations_rad.len() as u64) as usize]
                };
                let nominal = b.scanner_direction::<f64>(a, a2, elevation);
                // The return comes from a random place in the footprint: σ = γ/4 across the
                // beam in each direction (the beam model's footprint term).
                let spread = if errors.random {
                    b.beam_divergence_rad / 4.0
                } else {
                    0.0
                };
                let actual = if spread > 0.0 {
                    let u1 = nominal.cross(&Vector3::z());
                    let u1 = if u1.norm() > 1e-6 {
                        u1.normalize()
                    } else {
                        Vector3::x()
                    };
                    let u2 = nominal.cross(&u1);
                    (nominal + u1 * draw(rng, spread) + u2 * draw(rng, spread)).normalize()
                } else {
                    nominal
                };
                let dir = m_true * (self.r_m_true * actual);
                let curve = Curve::along(map, &origin, &dir);
                // A head fires all round: beams above the horizon, or within 15° of it (ranges
                // of kilometres), return nothing.
                if curve.direction(0.0)[2] > -MIN_BEAM_DOWN {
                    return Ok(());
                }
                let Some(hit) = sc.scene().trace_in(&curve, divergence, &mut sweeps[0]) else {
                    return Ok(());
                };
                let true_obs = BeamObservation {
                    range_m: hit.range_m,
                    angle_rad: a,
                    angle_2_rad: a2,
                    channel_elevation_rad: elevation,
                };
                let [sa, sa2, se] = self.beam_sigma;
                let range_sigma = if s0 > 0.0 {
                    b.range_sigma(s0, hit.range_m)
                } else {
                    0.0
                };
                let obs = BeamObservation {
                    range_m: hit.range_m + errors.range_offset_m + draw(rng, range_sigma),
                    angle_rad: a * (1.0 + errors.scan_angle_scale) + draw(rng, sa),
                    angle_2_rad: a2 + draw(rng, sa2),
                    channel_elevation_rad: elevation + draw(rng, se),
                };
                let p = b.parameters(&att_meas, &self.nominal, &obs);
                let v = p_meas + c_meas * b.footprint_ned(&p);
                let cos_inc = cos_incidence(&curve.direction(hit.range_m), &hit.normal);
                let intensity = self.intensity(hit.reflectivity, cos_inc, hit.range_m, rng);
                emit(
                    to_point(&v),
                    hit.position,
                    intensity,
                    a.to_degrees(),
                    (1, 1),
                    hit.class,
                    Observation::Beam(true_obs),
                    Observation::Beam(obs),
                );
            }
            _ => return Err(fail("scanner type and scan pattern disagree")),
        }
        Ok(())
    }
}

/// The sines and cosines of the true attitude at a recent pulse: the next pulses' (a few µrad
/// on) follow from them by angle addition instead of three `sin_cos` (as the scene's relief
/// phases do), evaluated again after `ANCHOR_CHAIN` additions.
#[derive(Debug, Clone, Copy)]
struct AttitudeAnchor {
    angles_rad: [f64; 3],
    sin_cos: [(f64, f64); 3],
    chain: u32,
}

impl AttitudeAnchor {
    /// `Rz(heading) · Ry(pitch) · Rx(roll)` of `att` (`lidarqa_model::rotation_zyx`, to
    /// rounding), its sines and cosines from `anchor`'s, which it then becomes.
    #[inline]
    fn rotation(anchor: &mut Option<AttitudeAnchor>, att: &Attitude) -> Matrix3<f64> {
        let angles_rad = [att.roll_rad, att.pitch_rad, att.heading_rad];
        let mut sin_cos = [(0.0, 1.0); 3];
        let mut chain = 0;
        match anchor {
            Some(a) if a.chain < ANCHOR_CHAIN => {
                let d = [
                    angles_rad[0] - a.angles_rad[0],
                    angles_rad[1] - a.angles_rad[1],
                    angles_rad[2] - a.angles_rad[2],
                ];
                if d[0].abs().max(d[1].abs()).max(d[2].abs()) <= ANCHOR_REACH_RAD {
                    for i in 0..3 {
                        sin_cos[i] = add_angles(a.sin_cos[i], small_sin_cos(d[i]));
                    }
                    chain = a.chain + 1;
                } else {
                    sin_cos = angles_rad.map(f64::sin_cos);
                }
            }
            _ => sin_cos = angles_rad.map(f64::sin_cos),
        }
        *anchor = Some(AttitudeAnchor {
            angles_rad,
            sin_cos,
            chain,
        });
        let [(sr, cr), (sp, cp), (sy, cy)] = sin_cos;
        Matrix3::new(
            cy * cp,
            cy * sp * sr - sy * cr,
            cy * sp * cr + sy * sr,
            sy * cp,
            sy * sp * sr + cy * cr,
            sy * sp * cr - cy * sr,
            -sp,
            cp * sr,
            cp * cr,
        )
    }
}

#[inline]
fn cos_incidence(dir: &[f64; 3], normal: &[f64; 3]) -> f64 {
    let n = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
    ((dir[0] * normal[0] + dir[1] * normal[1] + dir[2] * normal[2]) / n).abs()
}
