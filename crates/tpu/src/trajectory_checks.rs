//! What a trajectory can physically be: the checks of an aircraft's heights, speeds, attitude
//! rates, duplicated times, gaps and σ, on any reader's samples.
//!
//! The parsers only check that a file is well formed. These limits are an aircraft's, with
//! margins wide enough that no real survey meets them: a value beyond one is a wrong unit (degrees
//! where radians are stored, centimetres read as metres), a corrupt record or another flight,
//! and every point posed from it would be wrong. A value that cannot be right is an
//! [`ImplausibleTrajectory`] naming the record, the value and the likely cause (the caller adds
//! the file); a doubtful one is a [`Warning`].

use crate::trajectory::PoseSigma;
use lidarqa_model::{Attitude, Ecef, Warning};
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::path::Path;

/// Lowest plausible ellipsoidal height of an aircraft, m: below the Dead Sea shore (−430 m) plus
/// the geoid's lowest undulation (−106 m) with a margin.
pub const MIN_HEIGHT_M: f64 = -1_000.0;
/// Highest plausible ellipsoidal height of a survey aircraft, m: above the service ceiling of any
/// airborne-LiDAR platform (high-altitude jets fly below 16 km).
pub const MAX_HEIGHT_M: f64 = 25_000.0;
/// Fastest plausible ground speed, m/s: about Mach 1; survey aircraft fly below 150 m/s, so a
/// faster step is positions in a wrong unit or a wrong record, not flight.
pub const MAX_SPEED_MPS: f64 = 350.0;
/// Speeds are judged over at least this time, s: sample-to-sample GNSS noise (decimetres in a
/// few milliseconds, e.g. a simulated noisy trajectory) is not motion; a wrong unit or a jumped
/// record still moves kilometres per second.
pub const SPEED_BASELINE_S: f64 = 1.0;
/// Attitude rates are judged over at least this time, s (attitude noise is far smaller).
pub const ATTITUDE_BASELINE_S: f64 = 0.1;
/// Fastest plausible attitude rate, deg/s: aerobatic roll rates reach ~200 deg/s, survey
/// aircraft turn at a few deg/s; faster is angles in a wrong unit or a corrupt record.
pub const MAX_ATTITUDE_RATE_DEG_S: f64 = 300.0;
/// A trajectory gap longer than this many nominal sample intervals inside the points' time span
/// is a warning: the pose there is interpolated over more than one missing sample.
pub const GAP_WARNING_SAMPLES: f64 = 3.0;
/// A trajectory gap longer than this inside the points' time span is an error: interpolating an
/// aircraft's attitude over more than a second is no longer a measurement (attitude changes of
/// a degree within a second are common in turbulence).
pub const GAP_ERROR_S: f64 = 1.0;
/// Two records with the same time whose positions differ by more than this, m, are an error
/// (the trajectory jumps); closer, the duplicate is a warning.
pub const DUPLICATE_POSITION_TOLERANCE_M: f64 = 0.01;
/// A trajectory position σ above this, m, is not a GNSS/INS solution: likely centimetres or
/// millimetres read as metres.
pub const MAX_POSITION_SIGMA_M: f64 = 100.0;
/// An attitude σ above this, degrees, is not an INS solution: likely a wrong unit (SMRMSG stores
/// arc-minutes).
pub const MAX_ATTITUDE_SIGMA_DEG: f64 = 5.0;
/// One trajectory sample as any reader gives it (SBET, text): what the checks need.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrajectorySample {
    /// GPS seconds of week.
    pub time_s: f64,
    /// Geodetic latitude, rad.
    pub latitude_rad: f64,
    /// Longitude, rad.
    pub longitude_rad: f64,
    /// Ellipsoidal height, m.
    pub height_m: f64,
    /// The position on WGS 84 in ECEF metres: speeds are judged from it (the reader side owns
    /// the geodesy).
    pub position_ecef_m: Ecef,
    /// Roll, pitch, heading, rad.
    pub attitude: Attitude,
}

/// A stretch of the trajectory longer than [`GAP_WARNING_SAMPLES`] nominal intervals.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gap {
    /// Time of the sample before the gap, s.
    pub start_s: f64,
    /// Time of the sample after it, s.
    pub end_s: f64,
}

/// What the trajectory check found that matters later: its gaps and its warnings.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TrajectoryFacts {
    /// Gaps, in time order (judged against the points' times per chunk).
    pub gaps: Vec<Gap>,
    /// Median sample interval, s.
    pub nominal_interval_s: f64,
    /// Doubtful findings.
    pub warnings: Vec<Warning>,
}

/// A trajectory that cannot be physically right: what, the value and the likely cause.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{message}")]
pub struct ImplausibleTrajectory {
    /// The message a user sees after the file's name.
    pub message: String,
}

fn implausible(message: String) -> ImplausibleTrajectory {
    ImplausibleTrajectory { message }
}

/// A value for a message: plain, or in exponent form when huge (1e30, not 31 digits).
fn short(v: f64) -> String {
    if v.abs() >= 1e9 {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// The angle `a − b` wrapped to (−π, π].
fn wrapped(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(TAU);
    if d > PI { d - TAU } else { d }
}

/// Checks a trajectory: latitude and longitude in radians and in range, heights of an aircraft,
/// speeds and attitude rates an aircraft can have, duplicated times; returns its gaps.
///
/// # Errors
/// [`ImplausibleTrajectory`] naming the record and the value, with the likely cause.
pub fn check_trajectory(
    path: &Path,
    samples: &[TrajectorySample],
) -> Result<TrajectoryFacts, ImplausibleTrajectory> {
    let mut facts = TrajectoryFacts::default();
    for (i, s) in samples.iter().enumerate() {
        if s.latitude_rad.abs() > FRAC_PI_2 {
            let hint = if s.latitude_rad.abs() <= 90.0 {
                "latitudes look like degrees, SBET stores radians"
            } else {
                "not a latitude in radians or degrees: a corrupt record or a wrong format"
            };
            return Err(implausible(format!(
                "record {i}: latitude {} is beyond ±π/2 rad: {hint}",
                s.latitude_rad
            )));
        }
        if s.longitude_rad.abs() > TAU {
            let hint = if s.longitude_rad.abs() <= 360.0 {
                "longitudes look like degrees, SBET stores radians"
            } else {
                "not a longitude in radians or degrees: a corrupt record or a wrong format"
            };
            return Err(implausible(format!(
                "record {i}: longitude {} is beyond ±2π rad: {hint}",
                s.longitude_rad
            )));
        }
        if !(MIN_HEIGHT_M..=MAX_HEIGHT_M).contains(&s.height_m) {
            return Err(implausible(format!(
                "record {i}: height {} m is not an aircraft's (expected {MIN_HEIGHT_M} to \
                     {MAX_HEIGHT_M} m): a corrupt record or a wrong unit",
                short(s.height_m)
            )));
        }
    }
    let ecef = |s: &TrajectorySample| s.position_ecef_m;
    let mut intervals = Vec::with_capacity(samples.len());
    for (i, w) in samples.windows(2).enumerate() {
        let (a, b) = (&w[0], &w[1]);
        let dt = b.time_s - a.time_s;
        let dist = (ecef(b) - ecef(a)).norm();
        if dt == 0.0 {
            if dist > DUPLICATE_POSITION_TOLERANCE_M {
                return Err(implausible(format!(
                    "records {i} and {} share time {} s but lie {dist:.3} m apart: a \
                         duplicated time in the trajectory",
                    i + 1,
                    a.time_s
                )));
            }
            facts.warnings.push(Warning::new(
                "trajectory_duplicate_time",
                format!(
                    "{}: records {i} and {} share time {} s (the same pose twice)",
                    path.display(),
                    i + 1,
                    a.time_s
                ),
            ));
            continue;
        }
        // Time order is the reader's / Trajectory's check; nothing to judge here.
        if dt > 0.0 {
            intervals.push(dt);
        }
    }
    let times: Vec<f64> = samples.iter().map(|s| s.time_s).collect();
    for (i, j) in baseline_pairs(&times, SPEED_BASELINE_S) {
        let (a, b) = (&samples[i], &samples[j]);
        let (dist, dt) = ((ecef(b) - ecef(a)).norm(), b.time_s - a.time_s);
        let speed = dist / dt;
        if speed > MAX_SPEED_MPS {
            return Err(implausible(format!(
                "records {i}–{j}: the aircraft would move {dist:.1} m in {dt:.3} s \
                     ({speed:.0} m/s, more than {MAX_SPEED_MPS} m/s): positions in a wrong \
                     unit (latitudes in degrees?) or a corrupt record"
            )));
        }
    }
    for (i, j) in baseline_pairs(&times, ATTITUDE_BASELINE_S) {
        let (a, b) = (&samples[i], &samples[j]);
        let dt = b.time_s - a.time_s;
        for (name, x, y) in [
            ("roll", a.attitude.roll_rad, b.attitude.roll_rad),
            ("pitch", a.attitude.pitch_rad, b.attitude.pitch_rad),
            ("heading", a.attitude.heading_rad, b.attitude.heading_rad),
        ] {
            let rate = wrapped(y, x).abs().to_degrees() / dt;
            if rate > MAX_ATTITUDE_RATE_DEG_S {
                return Err(implausible(format!(
                    "records {i}–{j}: {name} changes at {rate:.0} deg/s (more than \
                         {MAX_ATTITUDE_RATE_DEG_S} deg/s): angles in a wrong unit (degrees \
                         where radians are stored?) or a corrupt record"
                )));
            }
        }
    }
    if !intervals.is_empty() {
        let mut sorted = intervals.clone();
        sorted.sort_by(f64::total_cmp);
        facts.nominal_interval_s = sorted[sorted.len() / 2];
        let limit = GAP_WARNING_SAMPLES * facts.nominal_interval_s;
        facts.gaps = samples
            .windows(2)
            .filter(|w| w[1].time_s - w[0].time_s > limit)
            .map(|w| Gap {
                start_s: w[0].time_s,
                end_s: w[1].time_s,
            })
            .collect();
    }
    Ok(facts)
}

/// Pairs of samples at least `baseline_s` apart, so that a speed or a rate is judged over the
/// intended time and sample-to-sample noise of a high-rate trajectory is not taken for motion.
/// Each sample is paired with the first sample at least `baseline_s` after it and the last at
/// least `baseline_s` before it, so that one bad record is always in a pair. A sample with
/// neither (within `baseline_s` of both ends: a trajectory shorter than twice the baseline) is
/// paired with the farther end, at least half the span away; never with its neighbour.
fn baseline_pairs(times: &[f64], baseline_s: f64) -> Vec<(usize, usize)> {
    let n = times.len();
    let mut out = Vec::with_capacity(2 * n);
    if n < 2 {
        return out;
    }
    // j: first index with times[j] − times[i] ≥ baseline (n when none);
    // k: last index with times[i] − times[k] ≥ baseline (None when none).
    let (mut j, mut k): (usize, Option<usize>) = (0, None);
    for i in 0..n {
        j = j.max(i + 1);
        while j < n && times[j] - times[i] < baseline_s {
            j += 1;
        }
        while k.map_or(0, |k| k + 1) < i && times[i] - times[k.map_or(0, |k| k + 1)] >= baseline_s {
            k = Some(k.map_or(0, |k| k + 1));
        }
        let mut paired = false;
        if j < n {
            out.push((i, j));
            paired = true;
        }
        if let Some(k) = k {
            out.push((k, i));
            paired = true;
        }
        if !paired {
            let pair = if times[i] - times[0] >= times[n - 1] - times[i] {
                (0, i)
            } else {
                (i, n - 1)
            };
            if pair.1 > pair.0 && times[pair.1] > times[pair.0] {
                out.push(pair);
            }
        }
    }
    out
}

/// Checks the trajectory's σ (SMRMSG or any other source): position and attitude σ in units a
/// GNSS/INS solution can have. Returns warnings only: a σ in a wrong unit gives a wrong σ, not a
/// wrong point.
pub fn check_trajectory_sigmas(path: &Path, sigmas: &[PoseSigma]) -> Vec<Warning> {
    let mut out = Vec::new();
    let max_pos = sigmas
        .iter()
        .map(|s| s.north_m.max(s.east_m).max(s.down_m))
        .fold(0.0, f64::max);
    if max_pos > MAX_POSITION_SIGMA_M {
        out.push(Warning::new(
            "trajectory_sigma_unit",
            format!(
                "{}: a position σ of {max_pos} m (more than {MAX_POSITION_SIGMA_M} m) is not a \
                 GNSS/INS solution: σ in centimetres or millimetres read as metres?",
                path.display()
            ),
        ));
    }
    let max_att = sigmas
        .iter()
        .map(|s| s.roll_rad.max(s.pitch_rad).max(s.heading_rad))
        .fold(0.0, f64::max)
        .to_degrees();
    if max_att > MAX_ATTITUDE_SIGMA_DEG {
        out.push(Warning::new(
            "trajectory_sigma_unit",
            format!(
                "{}: an attitude σ of {max_att:.2}° (more than {MAX_ATTITUDE_SIGMA_DEG}°) is not \
                 an INS solution: a wrong unit (SMRMSG stores arc-minutes)?",
                path.display()
            ),
        ));
    }
    out
}

/// Judges the gaps that points fall in (`times_s`: the points' times, sorted): a gap longer
/// than [`GAP_ERROR_S`] is an error, a shorter one a warning. Gaps between strips (turns, where
/// no point lies) are not judged.
///
/// # Errors
/// [`ImplausibleTrajectory`] naming the trajectory and the gap (the caller names `points`).
pub fn check_gaps(
    points: &Path,
    trajectory: &Path,
    gaps: &[Gap],
    times_s: &[f64],
) -> Result<Vec<Warning>, ImplausibleTrajectory> {
    let mut out = Vec::new();
    for g in gaps {
        let k = times_s.partition_point(|t| *t <= g.start_s);
        let Some(&t) = times_s.get(k).filter(|t| **t < g.end_s) else {
            continue;
        };
        let len = g.end_s - g.start_s;
        if len > GAP_ERROR_S {
            return Err(implausible(format!(
                "the trajectory {} has a {len:.3} s gap ({} to {} s) with points inside it \
                     (the first at {t:.3} s): poses cannot be interpolated over more than \
                     {GAP_ERROR_S} s; use a trajectory without the gap",
                trajectory.display(),
                g.start_s,
                g.end_s
            )));
        }
        out.push(Warning::new(
            "trajectory_gap",
            format!(
                "{}: the trajectory {} has a {len:.3} s gap ({} to {} s) with points inside it \
                 (the first at {t:.3} s): poses there are interpolated over missing samples",
                points.display(),
                trajectory.display(),
                g.start_s,
                g.end_s
            ),
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn samples(n: usize, dt: f64) -> Vec<TrajectorySample> {
        // 60 m/s north at 1000 m, level, heading north.
        (0..n)
            .map(|i| {
                let t = 1000.0 + i as f64 * dt;
                TrajectorySample {
                    time_s: t,
                    latitude_rad: 0.7 + 60.0 * (t - 1000.0) / 6_371_000.0,
                    longitude_rad: 0.2,
                    height_m: 1000.0,
                    position_ecef_m: Ecef::default(),
                    attitude: Attitude::default(),
                }
            })
            .collect()
    }

    /// WGS 84 geodetic → ECEF (the readers' geodesy, restated for the tests).
    fn ecef(s: &TrajectorySample) -> Ecef {
        let (a, f) = (6_378_137.0, 1.0 / 298.257_223_563);
        let e2 = f * (2.0 - f);
        let (sp, cp) = s.latitude_rad.sin_cos();
        let (sl, cl) = s.longitude_rad.sin_cos();
        let n = a / (1.0 - e2 * sp * sp).sqrt();
        Ecef::new(
            (n + s.height_m) * cp * cl,
            (n + s.height_m) * cp * sl,
            (n * (1.0 - e2) + s.height_m) * sp,
        )
    }

    /// [`check_trajectory`] with each sample's ECEF position from its latitude, longitude and
    /// height as they are after the test's edits.
    fn check(
        path: &Path,
        s: &[TrajectorySample],
    ) -> Result<TrajectoryFacts, ImplausibleTrajectory> {
        let s: Vec<TrajectorySample> = s
            .iter()
            .map(|s| TrajectorySample {
                position_ecef_m: ecef(s),
                ..*s
            })
            .collect();
        check_trajectory(path, &s)
    }

    fn message(r: Result<TrajectoryFacts, ImplausibleTrajectory>) -> String {
        match r {
            Err(e) => e.to_string(),
            other => panic!("expected ImplausibleTrajectory, got {other:?}"),
        }
    }

    #[test]
    fn a_plausible_trajectory_passes_without_warnings() {
        let f = check(Path::new("t.out"), &samples(200, 0.005)).unwrap();
        assert!(f.warnings.is_empty() && f.gaps.is_empty());
        assert!((f.nominal_interval_s - 0.005).abs() < 1e-12);
    }

    #[test]
    fn latitudes_in_degrees_are_named() {
        let mut s = samples(10, 0.005);
        for p in &mut s {
            p.latitude_rad = p.latitude_rad.to_degrees();
            p.longitude_rad = p.longitude_rad.to_degrees();
        }
        let m = message(check(Path::new("t.out"), &s));
        assert!(m.starts_with("record 0: latitude 40.1"), "{m}");
        assert!(
            m.contains("latitudes look like degrees, SBET stores radians"),
            "{m}"
        );
    }

    #[test]
    fn altitude_speed_attitude_rate_and_duplicates() {
        let p = Path::new("t.out");
        let mut s = samples(10, 0.005);
        s[4].height_m = 1e30;
        let m = message(check(p, &s));
        assert!(
            m.contains("record 4: height 1e30 m is not an aircraft's"),
            "{m}"
        );
        let mut s = samples(10, 0.005);
        s[5].longitude_rad += 1e-4; // 490 m in 25 ms
        let m = message(check(p, &s));
        assert!(m.contains("m/s, more than 350 m/s"), "{m}");
        // Decimetre noise on every record of a 200 Hz trajectory is not speed.
        let mut s = samples(1000, 0.005);
        for (i, p) in s.iter_mut().enumerate() {
            p.height_m += if i % 2 == 0 { 0.1 } else { -0.1 };
        }
        assert!(check(p, &s).is_ok());
        let mut s = samples(10, 0.005);
        s[5].attitude.roll_rad = 0.5; // 28.6° in 25 ms
        let m = message(check(p, &s));
        assert!(m.contains("records 0–5: roll changes at 1146 deg/s"), "{m}");
        let mut s = samples(10, 0.005);
        s[6] = s[5];
        let f = check(p, &s).unwrap();
        assert_eq!(f.warnings[0].code, "trajectory_duplicate_time");
        s[6].latitude_rad += 1e-6;
        s[6].time_s = s[5].time_s;
        assert!(message(check(p, &s)).contains("share time"));
    }

    #[test]
    fn noisy_high_rate_trajectories_pass_and_a_bad_first_or_last_record_does_not() {
        // 10 kHz, 3 s, ±0.2 m of independent noise per record on every axis (the simulator's
        // white-noise trajectory): sample to sample that is 4000 m/s, over a second 0.4 m/s.
        let p = Path::new("t.out");
        let noisy = |n: usize| {
            let mut s = samples(n, 1e-4);
            let mut state = 12345u64;
            let mut next = || {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
            };
            for r in &mut s {
                r.height_m += 0.2 * next();
                r.latitude_rad += 0.2 * next() / 6_371_000.0;
                r.longitude_rad += 0.2 * next() / 6_371_000.0;
            }
            s
        };
        assert!(check(p, &noisy(30_000)).is_ok());
        // Shorter than the baseline (0.05 s) and between one and two baselines (1.5 s).
        assert!(check(p, &noisy(500)).is_ok());
        assert!(check(p, &noisy(15_000)).is_ok());
        // The pairs span at least the baseline (or half the span): never neighbours.
        let times: Vec<f64> = (0..30_000).map(|i| i as f64 * 1e-4).collect();
        for (a, b) in baseline_pairs(&times, 1.0) {
            assert!(times[b] - times[a] >= 1.0 - 1e-9, "{a}–{b}");
        }
        // A record 500 m off at either end, or in the middle, is still found.
        for bad in [0, 14_999, 29_999] {
            let mut s = noisy(30_000);
            s[bad].height_m += 500.0;
            let m = message(check(p, &s));
            assert!(m.contains("m/s, more than 350 m/s"), "{bad}: {m}");
            assert!(m.contains(&format!("{bad}")), "{bad}: {m}");
        }
    }

    #[test]
    fn gaps_inside_the_points_span_are_errors_or_warnings_by_length() {
        let mut s = samples(2000, 0.005);
        // A 5 s gap after sample 1000 and a 4-sample gap after 1500.
        for p in &mut s[1001..] {
            p.time_s += 5.0;
        }
        for p in &mut s[1501..] {
            p.time_s += 0.015;
        }
        for p in &mut s {
            p.latitude_rad = 0.7 + 1e-9 * (p.time_s - 1000.0);
        }
        let f = check(Path::new("t.out"), &s).unwrap();
        assert_eq!(f.gaps.len(), 2);
        let (pts, traj) = (Path::new("s.laz"), Path::new("t.out"));
        // Points before the gaps: nothing.
        assert!(
            check_gaps(pts, traj, &f.gaps, &[1000.0, 1004.0])
                .unwrap()
                .is_empty()
        );
        // Points on both sides of the gaps, none inside: nothing (a tile spanning two strips).
        let around = [1004.0, 1010.1, 1012.4, 1012.6];
        assert!(check_gaps(pts, traj, &f.gaps, &around).unwrap().is_empty());
        let e = check_gaps(pts, traj, &f.gaps, &[1004.0, 1006.0, 1012.0]).unwrap_err();
        assert!(e.to_string().contains("5.005 s gap"), "{e}");
        let w = check_gaps(pts, traj, &f.gaps, &[1011.0, 1012.51, 1013.0]).unwrap();
        assert_eq!(w.len(), 1);
        assert!(w[0].message.contains("0.020 s gap"), "{}", w[0].message);
    }
}
