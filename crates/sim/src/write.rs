//! Writing a simulated survey with lidarqa-io's writers (SPEC §7): one LAS/LAZ per strip,
//! `sbet.out` + `smrmsg.out`, `control.csv`, `truth.json` and the nominal `sensor.toml` the user
//! of the survey would have. Every file is atomic.
//!
//! [`simulate_to_dir`] keeps its own overlap of computing and writing rather than lidarqa-io's
//! writer stage: [`simulate_streaming`] computes a window of chunks in parallel while the sink
//! writes the window before (`rayon::join`), and hands the sink borrowed slices of points. A
//! writer thread would need every chunk copied into a buffer it owns, for an overlap the
//! simulation already has; and its strips are committed together only once all are written.
//!
//! A strip without the truth dimensions is written as records encoded here (point format 6,
//! [`record`]) rather than through a `LasPoint` and `las::Point` per point: that conversion cost
//! as much as the strip's geometry. A test holds the records to `LasWriter::write_point`'s byte
//! for byte.

use crate::error::{Error, Result};
use crate::{PointSink, PointTruth, Scenario, SimOptions, SimPoint, Survey, simulate_streaming};
use lidarqa_io::{
    AtomicFile, LasTimeBase, LasWriteOptions, LasWriter, RawVlr, SbetPose, SmrmsgSigma, sbet_raw,
    utm_wkt, write_records_to_path,
};
use std::io::Write as _;
use std::path::{Path, PathBuf};

/// The names of the files [`write_survey`] writes into its directory, strips first.
pub fn survey_file_names(survey: &Survey, laz: bool) -> Vec<String> {
    file_names(survey.strips.iter().map(|s| s.id), laz)
}

fn file_names(strip_ids: impl Iterator<Item = u16>, laz: bool) -> Vec<String> {
    let ext = if laz { "laz" } else { "las" };
    let mut names: Vec<String> = strip_ids.map(|id| format!("strip_{id:03}.{ext}")).collect();
    names.extend(
        [
            "sbet.out",
            "smrmsg.out",
            "control.csv",
            "truth.json",
            "sensor.toml",
        ]
        .map(String::from),
    );
    names
}

/// Writes `survey` (simulated from `scenario`) into `dir`: the files of [`survey_file_names`],
/// LAZ when `laz`, else LAS. No output may be one of `inputs` (SPEC §7: checked for every file
/// before the first is written).
///
/// # Errors
/// [`Error::Io`] naming the file that cannot be written or that is an input.
pub fn write_survey(
    dir: &Path,
    scenario: &Scenario,
    survey: &Survey,
    laz: bool,
    inputs: &[&Path],
) -> Result<Vec<PathBuf>> {
    let paths = checked_paths(dir, survey_file_names(survey, laz), inputs)?;
    let marker = mark_incomplete(dir)?;
    for (strip, path) in survey.strips.iter().zip(&paths) {
        let mut file = StripFile::create(path, scenario, strip.id, !strip.truth.is_empty())?;
        file.write(&strip.points, &strip.truth)?;
        file.finish_uncommitted()?.commit()?;
    }
    write_rest(dir, scenario, survey)?;
    unmark(&marker)?;
    Ok(paths)
}

/// Simulates `scenario` ([`simulate_streaming`]) and writes it into `dir` as it is computed,
/// the same files as [`write_survey`] (checked against `inputs` before the first is written),
/// with memory bounded by the chunks in flight instead of the survey. The strips appear only
/// when all are complete, so a failed run replaces nothing. Returns the survey, whose strips
/// hold no points (see [`simulate_streaming`]), and the paths written.
///
/// # Errors
/// As [`simulate_streaming`] and [`write_survey`].
pub fn simulate_to_dir(
    dir: &Path,
    scenario: &Scenario,
    options: &SimOptions,
    laz: bool,
    inputs: &[&Path],
) -> Result<(Survey, Vec<PathBuf>)> {
    let names = file_names(scenario.lines().iter().map(|l| l.id), laz);
    let paths = checked_paths(dir, names, inputs)?;
    let mut sink = StreamSink {
        scenario,
        paths: &paths,
        truth: options.keep_truth,
        open: None,
        done: Vec::new(),
    };
    let survey = simulate_streaming(scenario, options, &mut sink)?;
    // From the first rename to the last the directory mixes this run's files and an earlier
    // run's: the marker says so until the last file is in place.
    let marker = mark_incomplete(dir)?;
    for file in sink.done {
        file.commit()?;
    }
    write_rest(dir, scenario, &survey)?;
    unmark(&marker)?;
    Ok((survey, paths))
}

/// The file that says a survey directory is being written (or was, by a run that was killed or
/// failed): from the first output renamed into place to the last, the directory holds some files
/// of this run and some of an earlier one, and only this file tells. Removed when every file is
/// in place.
pub const INCOMPLETE_MARKER: &str = "lidarqa-incomplete.txt";

/// Writes [`INCOMPLETE_MARKER`] into `dir` before the first output is renamed into place.
fn mark_incomplete(dir: &Path) -> Result<PathBuf> {
    let marker = dir.join(INCOMPLETE_MARKER);
    write_text(
        &marker,
        &format!(
            "lidarqa simulate (process {}) was writing this directory and did not finish: its \
             strips, trajectory, control, truth and sensor file may mix this run's and an \
             earlier run's. Run the simulation again; this file is removed when every file is \
             in place.\n",
            std::process::id()
        ),
    )?;
    Ok(marker)
}

/// Removes the marker of [`mark_incomplete`] once every file is in place.
fn unmark(marker: &Path) -> Result<()> {
    std::fs::remove_file(marker).map_err(|source| {
        Error::Io(lidarqa_io::Error::Io {
            path: marker.to_path_buf(),
            source,
        })
    })
}

/// The paths of `names` in `dir`, none of them one of `inputs` (SPEC §7: checked for every
/// file before the first is written).
fn checked_paths(dir: &Path, names: Vec<String>, inputs: &[&Path]) -> Result<Vec<PathBuf>> {
    let paths: Vec<PathBuf> = names.into_iter().map(|n| dir.join(n)).collect();
    for p in &paths {
        lidarqa_io::check_not_an_input(p, inputs)?;
    }
    Ok(paths)
}

/// The [`PointSink`] of [`simulate_to_dir`]: one strip file open at a time, the complete ones
/// kept uncommitted until the survey is done.
struct StreamSink<'a> {
    scenario: &'a Scenario,
    paths: &'a [PathBuf],
    truth: bool,
    open: Option<(usize, StripFile)>,
    done: Vec<AtomicFile>,
}

impl StreamSink<'_> {
    fn file(&mut self, strip: usize) -> Result<&mut StripFile> {
        if self.open.as_ref().is_none_or(|(k, _)| *k != strip) {
            let id = self.scenario.lines()[strip].id;
            let file = StripFile::create(&self.paths[strip], self.scenario, id, self.truth)?;
            self.open = Some((strip, file));
        }
        Ok(&mut self.open.as_mut().expect("opened above").1)
    }
}

impl PointSink for StreamSink<'_> {
    fn points(&mut self, strip: usize, points: &[SimPoint], truth: &[PointTruth]) -> Result<()> {
        self.file(strip)?.write(points, truth)
    }

    fn end_strip(&mut self, strip: usize) -> Result<()> {
        self.file(strip)?;
        if let Some((_, file)) = self.open.take() {
            self.done.push(file.finish_uncommitted()?);
        }
        Ok(())
    }
}

/// Everything but the strips: trajectory, control, truth and the nominal sensor file.
fn write_rest(dir: &Path, scenario: &Scenario, survey: &Survey) -> Result<()> {
    write_trajectory(dir, survey)?;
    write_control(&dir.join("control.csv"), survey)?;
    let truth_path = dir.join("truth.json");
    let truth = serde_json::to_string_pretty(&survey.truth).map_err(|e| {
        Error::Io(lidarqa_io::Error::Io {
            path: truth_path.clone(),
            source: e.into(),
        })
    })?;
    write_text(&truth_path, &(truth + "\n"))?;
    write_text(
        &dir.join("sensor.toml"),
        &lidarqa_io::sensor_to_toml(scenario.sensor()),
    )
}

fn write_text(path: &Path, text: &str) -> Result<()> {
    let mut file = AtomicFile::create(path, &[] as &[&Path])?;
    file.write_all(text.as_bytes()).map_err(|source| {
        Error::Io(lidarqa_io::Error::Io {
            path: path.to_path_buf(),
            source,
        })
    })?;
    file.commit()?;
    Ok(())
}

/// One strip's LAS/LAZ being written.
struct StripFile {
    writer: LasWriter,
    path: PathBuf,
    scale: [f64; 3],
    offset: [f64; 3],
    gps_week: u32,
    /// Records of points without truth not yet given to the writer (a batch at most).
    records: Vec<u8>,
}

impl StripFile {
    /// Starts the file of strip `id`, with the `--truth` extra bytes when `truth`.
    fn create(path: &Path, scenario: &Scenario, id: u16, truth: bool) -> Result<StripFile> {
        let [e0, n0] = scenario.origin_m();
        let mut wkt = utm_wkt(scenario.zone(), scenario.epsg()).into_bytes();
        wkt.push(0);
        let options = LasWriteOptions {
            version_minor: 4,
            point_format: 6,
            scale: [0.001; 3],
            offset: [e0.round(), n0.round(), 0.0],
            time_base: LasTimeBase::AdjustedStandard,
            crs_vlrs: vec![RawVlr {
                user_id: "LASF_Projection".into(),
                record_id: 2112,
                description: "OGC WKT".into(),
                data: wkt,
            }],
            extra_dims: if truth {
                TRUTH_DIMS
                    .iter()
                    .map(|(n, d)| (n.to_string(), d.to_string()))
                    .collect()
            } else {
                Vec::new()
            },
            file_source_id: id,
            carried_extra: Default::default(),
            extra_dims_f64: Vec::new(),
        };
        Ok(StripFile {
            writer: LasWriter::create(path, &options, &[] as &[&Path])?,
            path: path.to_path_buf(),
            scale: options.scale,
            offset: options.offset,
            gps_week: scenario.gps_week(),
            records: Vec::new(),
        })
    }

    /// Appends points (with their truth when the file has the truth dimensions).
    fn write(&mut self, points: &[SimPoint], truth: &[PointTruth]) -> Result<()> {
        if truth.is_empty() {
            return self.write_records(points);
        }
        let (scale, offset) = (self.scale, self.offset);
        // The error of the coordinates as stored: the LAS record rounds them to its scale.
        let stored = |v: f64, k: usize| ((v - offset[k]) / scale[k]).round() * scale[k] + offset[k];
        for (p, t) in points.iter().zip(truth) {
            let point = p.to_las(self.gps_week);
            let error = [
                (stored(point.x, 0) - t.easting_m) as f32,
                (stored(point.y, 1) - t.northing_m) as f32,
                (stored(point.z, 2) - t.height_m) as f32,
            ];
            self.writer.write_point(&point, &error)?;
        }
        Ok(())
    }

    /// Appends points as records, handed to the writer in its batches.
    fn write_records(&mut self, points: &[SimPoint]) -> Result<()> {
        let batch = lidarqa_io::WRITE_BATCH_POINTS * RECORD_LEN;
        for p in points {
            let index = self.writer.len() + (self.records.len() / RECORD_LEN) as u64;
            let r = record(p, self.gps_week, self.scale, self.offset).ok_or_else(|| {
                Error::Io(lidarqa_io::Error::PointMismatch {
                    path: self.path.clone(),
                    index,
                    message: format!(
                        "coordinates ({}, {}, {}) beyond the i32 range of the scale and offset",
                        p.easting_m, p.northing_m, p.height_m
                    ),
                })
            })?;
            self.records.extend_from_slice(&r);
            if self.records.len() >= batch {
                self.writer.write_records(std::mem::replace(
                    &mut self.records,
                    Vec::with_capacity(batch),
                ))?;
            }
        }
        Ok(())
    }

    /// Writes what is buffered and completes the file, not yet in place.
    fn finish_uncommitted(mut self) -> Result<AtomicFile> {
        if !self.records.is_empty() {
            self.writer
                .write_records(std::mem::take(&mut self.records))?;
        }
        Ok(self.writer.finish_uncommitted()?.0)
    }
}

/// Bytes of a point format 6 record.
const RECORD_LEN: usize = 30;

/// The point format 6 record of `p` (LAS 1.4 R15 table 13), as `LasWriter::write_point` writes
/// `p.to_las(gps_week)`: coordinates rounded to the nearest step of `scale` from `offset`, the
/// scan angle to the nearest 0.006°; `None` for a coordinate beyond the i32 range. The
/// simulator's return numbers (1–2), classes and scan angles (within ±180°) always fit.
fn record(p: &SimPoint, gps_week: u32, scale: [f64; 3], offset: [f64; 3]) -> Option<[u8; 30]> {
    let mut r = [0u8; RECORD_LEN];
    for (k, v) in [p.easting_m, p.northing_m, p.height_m]
        .into_iter()
        .enumerate()
    {
        let n = ((v - offset[k]) / scale[k]).round();
        if !(n >= f64::from(i32::MIN) && n <= f64::from(i32::MAX)) {
            return None;
        }
        r[4 * k..4 * k + 4].copy_from_slice(&(n as i32).to_le_bytes());
    }
    r[12..14].copy_from_slice(&p.intensity.to_le_bytes());
    r[14] = (p.number_of_returns << 4) | p.return_number;
    // r[15]: no flags, scanner channel 0, scan direction bit clear (as `LasPoint`'s default).
    r[16] = p.classification;
    // r[17]: user data 0.
    let scan = (p.scan_angle_deg / 0.006).round() as i16;
    r[18..20].copy_from_slice(&scan.to_le_bytes());
    r[20..22].copy_from_slice(&p.point_source_id.to_le_bytes());
    let t = lidarqa_io::week_to_adjusted_standard(i64::from(gps_week), p.gps_time_s);
    r[22..30].copy_from_slice(&t.to_le_bytes());
    Some(r)
}

/// The `--truth` extra-bytes dimensions: name and description (each ≤ 32 bytes).
const TRUTH_DIMS: [(&str, &str); 3] = [
    ("error_x", "lidar - true, projected x (m)"),
    ("error_y", "lidar - true, projected y (m)"),
    ("error_z", "lidar - true, height (m)"),
];

fn write_trajectory(dir: &Path, survey: &Survey) -> Result<()> {
    let sbet: Vec<sbet_raw::SbetRecord> = survey
        .trajectory()
        .iter()
        .map(|r| {
            sbet_raw::SbetRecord::from(SbetPose {
                time_s: r.time_s,
                latitude_rad: r.latitude_rad,
                longitude_rad: r.longitude_rad,
                height_m: r.height_m,
                // Wander angle 0: the wander frame is north-east-down.
                velocity_wander_mps: [
                    r.velocity_north_m_per_s,
                    r.velocity_east_m_per_s,
                    r.velocity_down_m_per_s,
                ],
                roll_rad: r.roll_rad,
                pitch_rad: r.pitch_rad,
                platform_heading_rad: r.heading_rad,
                wander_angle_rad: 0.0,
                specific_force_body_mps2: [0.0; 3],
                angular_rate_body_radps: [0.0; 3],
            })
        })
        .collect();
    write_records_to_path(dir.join("sbet.out"), &sbet, &[] as &[&Path])?;
    let smrmsg: Vec<sbet_raw::SmrmsgRecord> = survey
        .trajectory_sigma()
        .iter()
        .map(|s| {
            sbet_raw::SmrmsgRecord::from(SmrmsgSigma {
                time_s: s.time_s,
                sigma_north_m: s.position_ned_m[0],
                sigma_east_m: s.position_ned_m[1],
                sigma_down_m: s.position_ned_m[2],
                sigma_velocity_north_mps: s.velocity_ned_m_per_s[0],
                sigma_velocity_east_mps: s.velocity_ned_m_per_s[1],
                sigma_velocity_down_mps: s.velocity_ned_m_per_s[2],
                sigma_roll_rad: s.attitude_rad[0],
                sigma_pitch_rad: s.attitude_rad[1],
                sigma_heading_rad: s.attitude_rad[2],
            })
        })
        .collect();
    write_records_to_path(dir.join("smrmsg.out"), &smrmsg, &[] as &[&Path])?;
    Ok(())
}

/// `control.csv`: `id,x,y,z,sigma_h,sigma_v,radius_m` (SPEC §7 plus the target radius, which
/// `lidarqa targets` reads per target).
fn write_control(path: &Path, survey: &Survey) -> Result<()> {
    let mut text = String::from("id,x,y,z,sigma_h,sigma_v,radius_m\n");
    for c in &survey.control {
        text.push_str(&format!(
            "{},{:.4},{:.4},{:.4},{},{},{}\n",
            c.id,
            c.easting_m,
            c.northing_m,
            c.height_m,
            c.sigma_horizontal_m,
            c.sigma_vertical_m,
            c.radius_m
        ));
    }
    write_text(path, &text)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `record` against the writer's own `las::Point` path, byte for byte: coordinates and scan
    /// angles on and beside their rounding boundaries, both signs, every class the simulator
    /// writes.
    #[test]
    fn records_are_those_of_write_point() {
        let dir = tempfile::tempdir().unwrap();
        let scenario = Scenario::builtin("demo").unwrap();
        let path = dir.path().join("a.las");
        let mut file = StripFile::create(&path, &scenario, 7, false).unwrap();
        let [e0, n0] = scenario.origin_m();
        let mut points = Vec::new();
        for i in 0..4000 {
            let f = f64::from(i);
            let step = 0.006 * (f - 2000.0) / 7.0;
            points.push(SimPoint {
                easting_m: e0 + (f - 2000.0) * 0.0005 + 1e-9 * (f % 3.0 - 1.0),
                northing_m: n0 - 1234.5675 + f * 0.25005,
                height_m: 180.0 + (f - 2000.0) * 0.0015,
                gps_time_s: 300_000.0 + f * 5e-6,
                intensity: (i * 17 % 65536) as u16,
                scan_angle_deg: [step as f32, (0.003 * (f - 2000.0)) as f32][i as usize % 2],
                return_number: 1 + (i % 2) as u8,
                number_of_returns: 2,
                classification: [2, 6, 40, 41, 64, 5][i as usize % 6],
                point_source_id: 7,
            });
        }
        let records: Vec<u8> = points
            .iter()
            .flat_map(|p| record(p, 2200, file.scale, file.offset).unwrap())
            .collect();
        for p in &points {
            file.writer.write_point(&p.to_las(2200), &[]).unwrap();
        }
        let (scale, offset) = (file.scale, file.offset);
        file.finish_uncommitted().unwrap().commit().unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let start = u32::from_le_bytes(bytes[96..100].try_into().unwrap()) as usize;
        assert_eq!(bytes.len() - start, records.len());
        assert!(bytes[start..] == records[..], "records differ");
        // And a coordinate beyond the i32 range is refused.
        let mut far = points[0];
        far.easting_m = e0 + 3e6;
        assert!(record(&far, 2200, scale, offset).is_none());
    }
}
