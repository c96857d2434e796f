//! `lidarqa calibrate`: boresight + lever-arm self-calibration from overlapping strips (SPEC §7,
//! seed 001), writing `calibration.json` (SPEC §8) and `calibration_iterations.json` beside it.
//!
//! Also holds the strip loading shared with `lidarqa correct`: LAS/LAZ → (UTM inverse, ellipsoid)
//! ECEF → local NED frame at the survey centre, GPS time → trajectory pose, raw observation
//! recovered once with the sensor file's mounting (lidarqa-tpu). The sensor and SBET are read by
//! lidarqa-pipeline's `TpuContext`, as `lidarqa tpu` does.

use super::tpu::crs_flags;
use crate::format::{OutputFormat, print_json, print_text};
use anyhow::{Context, Result, bail};
use clap::Args;
use lidarqa_calib::{
    AutoTieOptions, Calibration, CalibrationOptions, ControlPoint, LocalFrame, MAX_RADIUS_M,
    MAX_RANSAC_ITERATIONS, Param, PlaneOptions, RawPoint, Strip, Tie, TieKind, TiePick,
    TrajectorySigma, auto_ties, calibrate_plane, calibrate_vtpm,
};

/// Most Levenberg–Marquardt iterations: a calibration converges in tens.
const MAX_LM_ITERATIONS: usize = 10_000;
use lidarqa_io::{
    AtomicFile, ControlPoints, Crs, Geodetic, LasInfo, LasReader, LasTimeConverter, PointChunk,
    TiePicks,
};
use lidarqa_model::{Mounting, Source};
use lidarqa_pipeline::{TpuContext, TpuOptions};
use lidarqa_tpu::Recoverer;
use nalgebra::Vector3;
use std::collections::HashMap;
use std::io::Write as _;
use std::path::{Path, PathBuf};

pub const AFTER_HELP: &str = "\
Examples:
  lidarqa calibrate s1.laz s2.laz s3.laz s4.laz --trajectory sbet.out --sensor sensor.toml \\
      --ties ties.csv --control control.csv -o calibration.json
  lidarqa calibrate strips/*.laz --trajectory sbet.out --sensor sensor.toml --auto-ties -o cal.json
  lidarqa calibrate strips/*.laz --trajectory sbet.out --sensor sensor.toml --ties ties.csv \\
      --method plane -o calibration_plane.json

Tie picks CSV: tie,strip,x,y (projected metres; strip = LAS point source id or file stem).
Control CSV: id,x,y,z (projected metres, ellipsoidal height). A control id equal to a tie id
observes all three coordinates; otherwise only its height. Without control the vertical lever
arm is not observable and is held at the sensor file's value (\"observable\": false).
Writes calibration_iterations.json (the convergence record) beside the output.

An existing -o file and calibration_iterations.json beside it are replaced; a strip given
twice, or an output that is an input, is refused.";

/// Flags of `lidarqa calibrate`.
#[derive(Debug, Args)]
pub struct CalibrateArgs {
    /// Strips (LAS/LAZ with GPS time), one flight line each.
    #[arg(required = true, value_name = "STRIP")]
    strips: Vec<PathBuf>,
    /// Trajectory (SBET).
    #[arg(long, value_name = "FILE")]
    trajectory: PathBuf,
    /// Sensor file (TOML, SPEC §5); its [mounting] is the prior the strips were made with.
    #[arg(long, value_name = "FILE")]
    sensor: PathBuf,
    /// Hand-picked ties (CSV tie,strip,x,y).
    #[arg(
        long,
        value_name = "FILE",
        conflicts_with = "auto_ties",
        required_unless_present = "auto_ties"
    )]
    ties: Option<PathBuf>,
    /// Find ties automatically: road markings (intensity contrast on flat ground) and roof faces.
    #[arg(long)]
    auto_ties: bool,
    /// Control points (CSV id,x,y,z).
    #[arg(long, value_name = "FILE")]
    control: Option<PathBuf>,
    /// vtpm (seed 001, lever arm + boresight) or plane (point-to-plane baseline, boresight only).
    #[arg(long, default_value = "vtpm", value_parser = ["vtpm", "plane"])]
    method: String,
    /// Output calibration.json.
    #[arg(short, long, value_name = "FILE")]
    output: PathBuf,
    /// GPS week of the survey (LAS adjusted standard GPS time).
    #[arg(long, value_name = "WEEK")]
    gps_week: Option<i64>,
    /// VTPM search radius around a pick, metres [default: the radius that holds ~20 points of
    /// the sparsest strip, at least seed 001's 1 m].
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    radius_m: Option<f64>,
    /// RANSAC plane threshold, metres.
    #[arg(
        long,
        value_name = "M",
        default_value_t = 0.05,
        allow_negative_numbers = true
    )]
    ransac_threshold_m: f64,
    /// RANSAC iterations.
    #[arg(long, value_name = "N", default_value_t = 200)]
    ransac_iterations: usize,
    /// What carries a tie in a strip: `triangle` is seed 001's rule (the three coplanar points
    /// around the pick); `patch` uses every coplanar point of the window (height from their
    /// least-squares plane, moved rigidly with all of them), which averages the points' noise
    #[arg(long, value_name = "CARRIER", default_value = "patch", value_parser = ["patch", "triangle"])]
    tie_carrier: String,
    /// Levenberg–Marquardt iteration limit.
    #[arg(long, value_name = "N", default_value_t = 50)]
    max_iterations: usize,
    /// Plain least squares, as seed 001: do not weigh the ties by each strip's trajectory error
    /// (the sensor file's GNSS and attitude σ), and report σ from the tie scatter alone
    #[arg(long)]
    no_trajectory_weighting: bool,
    /// Correlation time of the trajectory's GNSS position errors (Gauss–Markov), s: the
    /// weighting then lets a strip's error drift over the strip instead of holding it constant
    /// (the navigation processing report, or the simulator's `errors.gnss_correlation_time_s`)
    #[arg(
        long,
        value_name = "SECONDS",
        conflicts_with = "no_trajectory_weighting"
    )]
    gnss_correlation_s: Option<f64>,
    /// Correlation time of the trajectory's attitude errors (Gauss–Markov), s; as
    /// `--gnss-correlation-s` (post-processed attitude is often correlated over tens of seconds,
    /// about a strip's length, which is when it matters)
    #[arg(
        long,
        value_name = "SECONDS",
        conflicts_with = "no_trajectory_weighting"
    )]
    attitude_correlation_s: Option<f64>,
    /// UTM zone of the points when the files have no CRS, e.g. 33N or 17S (WGS 84); overrides
    /// the header's.
    #[arg(long, value_name = "ZONE", conflicts_with = "epsg")]
    utm_zone: Option<String>,
    /// EPSG code of the points' projected CRS when the files have none (any projected EPSG CRS).
    #[arg(long, value_name = "CODE")]
    epsg: Option<u32>,
    /// Output format of the summary on stdout.
    #[arg(long, value_enum, default_value_t = OutputFormat::Table)]
    format: OutputFormat,
}

/// A loaded strip: the calib strip, the file's points (for writing) and what converts back.
pub(crate) struct LoadedStrip {
    pub(crate) stem: String,
    pub(crate) strip: Strip,
}

/// Survey centre of the files (from their headers) as a local frame, on `zone`'s ellipsoid.
pub(crate) fn frame_for(infos: &[LasInfo], zone: &Crs) -> LocalFrame {
    let n = infos.len().max(1) as f64;
    let c = |k: usize| {
        infos
            .iter()
            .map(|i| 0.5 * (i.min[k] + i.max[k]))
            .sum::<f64>()
            / n
    };
    let (lat, lon) = zone.inverse(c(0), c(1));
    let e = zone.ellipsoid();
    let ecef = e.geodetic_to_ecef(&Geodetic {
        latitude_rad: lat,
        longitude_rad: lon,
        height_m: c(2),
    });
    LocalFrame::new(ecef, lat, lon)
}

/// The strip's header and CRS: `crs` (from `--utm-zone` / `--epsg`) when given, else the
/// header's.
pub(crate) fn read_info(path: &Path, crs: Option<Crs>) -> Result<(LasInfo, Crs)> {
    let info = LasReader::from_path(path)?.info().clone();
    if !info.has_gps_time {
        bail!(
            "{}: no GPS time (point format {}); recovering raw observations needs each point's time",
            path.display(),
            info.point_format
        );
    }
    let zone = match crs {
        Some(z) => z,
        None => info
            .projected_crs()
            .context("pass --utm-zone or --epsg for points without a usable CRS")?,
    };
    if zone.unit() != lidarqa_io::LinearUnit::Metre {
        bail!(
            "{}: the CRS {} is in {}s; calibrate works on metre CRSs only",
            path.display(),
            zone.name(),
            zone.unit().name()
        );
    }
    Ok((info, zone))
}

/// Reads the points of one strip (its header and zone from [`read_info`]) and recovers every
/// point's raw observation (module docs).
pub(crate) fn load_strip(
    path: &Path,
    (info, zone): (&LasInfo, &Crs),
    ctx: &TpuContext,
    frame: &LocalFrame,
    gps_week: Option<i64>,
) -> Result<LoadedStrip> {
    let trajectory = ctx.trajectory_in(zone)?;
    let converter = LasTimeConverter::new(path, info.time_base, gps_week, info.creation_date)?;
    let projection = zone;
    let ellipsoid = zone.ellipsoid();
    let recoverer = Recoverer::new(&ctx.sensor().mounting);
    let mut reader = LasReader::from_path(path)?;
    let mut chunk = PointChunk::new();
    // A LAZ header's count cannot be checked against the file size (issue #12): reserve at
    // most 4 Mi points up front and let the vectors grow with what is really read.
    let reserve = usize::try_from(info.point_count.min(1 << 22)).unwrap_or(0);
    let mut points = Vec::with_capacity(reserve);
    // The strip's point source id while every point has the same one.
    let mut psid: Option<u16> = None;
    let mut same_psid = true;
    let mut index = 0u64;
    while reader.fill(&mut chunk, 200_000)? > 0 {
        for p in &chunk.points {
            let t = p
                .gps_time_s
                .with_context(|| format!("{}: point {index} has no GPS time", path.display()))?;
            let sow = converter.to_seconds_of_week(t)?;
            let pose = trajectory
                .at(sow)
                .with_context(|| format!("{}: point {index}", path.display()))?;
            let (lat, lon) = projection.inverse(p.x, p.y);
            let ecef = ellipsoid.geodetic_to_ecef(&Geodetic {
                latitude_rad: lat,
                longitude_rad: lon,
                height_m: p.z,
            });
            let raw = RawPoint::recover(frame, &pose, &recoverer, &ecef, p.intensity)
                .with_context(|| format!("{}: point {index}", path.display()))?;
            points.push(raw);
            same_psid &= *psid.get_or_insert(p.point_source_id) == p.point_source_id;
            index += 1;
        }
    }
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    // The strip id: the LAS point source id when every point has the same non-zero one.
    let id = match psid {
        Some(id) if id != 0 && same_psid => id.to_string(),
        _ => stem.clone(),
    };
    Ok(LoadedStrip {
        stem,
        strip: Strip { id, points },
    })
}

/// Local NED → projected `[easting, northing, ellipsoidal height]` in `zone`.
pub(crate) fn local_to_projected(frame: &LocalFrame, zone: &Crs, v: &Vector3<f64>) -> [f64; 3] {
    let g = zone.ellipsoid().ecef_to_geodetic(&frame.to_ecef(v));
    let p = zone.forward(g.latitude_rad, g.longitude_rad);
    [p.easting_m, p.northing_m, g.height_m]
}

/// Projected position → local NED.
pub(crate) fn projected_to_local(
    frame: &LocalFrame,
    zone: &Crs,
    x: f64,
    y: f64,
    h: f64,
) -> Vector3<f64> {
    let (lat, lon) = zone.inverse(x, y);
    let ecef = zone.ellipsoid().geodetic_to_ecef(&Geodetic {
        latitude_rad: lat,
        longitude_rad: lon,
        height_m: h,
    });
    frame.to_local(&ecef)
}

fn frame_height(frame: &LocalFrame, zone: &Crs) -> f64 {
    local_to_projected(frame, zone, &Vector3::zeros())[2]
}

/// Tie picks in the local frame; a pick's height is taken from the nearest point of its strip
/// (the horizontal local position depends on it by ~1.6 cm per 100 m per km from the centre).
fn ties_from_csv(
    picks: &TiePicks,
    loaded: &[LoadedStrip],
    frame: &LocalFrame,
    zone: &Crs,
) -> Result<Vec<Tie>> {
    let mut by_id: HashMap<&str, usize> = HashMap::new();
    for (k, l) in loaded.iter().enumerate() {
        by_id.insert(l.strip.id.as_str(), k);
        by_id.insert(l.stem.as_str(), k);
    }
    let h0 = frame_height(frame, zone);
    let mut order: Vec<String> = Vec::new();
    let mut ties: HashMap<String, Vec<TiePick>> = HashMap::new();
    for p in &picks.picks {
        let &k = by_id.get(p.strip.as_str()).with_context(|| {
            format!(
                "{}: line {}: strip {} is not among the input strips",
                picks.path.display(),
                p.line,
                p.strip
            )
        })?;
        let guess = projected_to_local(frame, zone, p.x, p.y, h0);
        let up = nearest_up(&loaded[k].strip, guess.x, guess.y).unwrap_or(0.0);
        let local = projected_to_local(frame, zone, p.x, p.y, h0 + up);
        if !ties.contains_key(&p.tie) {
            order.push(p.tie.clone());
        }
        ties.entry(p.tie.clone()).or_default().push(TiePick {
            strip: loaded[k].strip.id.clone(),
            north_m: local.x,
            east_m: local.y,
        });
    }
    Ok(order
        .into_iter()
        .map(|id| Tie {
            picks: ties.remove(&id).unwrap_or_default(),
            id,
            kind: TieKind::Feature,
        })
        .collect())
}

/// A calibration error about a tie or control point, told in the CSV's own terms: file, line,
/// and the projected x, y the user wrote, not the local frame the adjustment works in.
fn in_csv_terms(
    e: lidarqa_calib::Error,
    picks: Option<&TiePicks>,
    control: Option<(&ControlPoints, &Path)>,
    strips: &[(String, String)],
) -> anyhow::Error {
    use lidarqa_calib::Error as E;
    let same_strip = |csv: &str, id: &str| {
        strips
            .iter()
            .any(|(i, stem)| i == id && (csv == i || csv == stem))
    };
    let pick = |tie: &str, strip: Option<&str>| {
        picks.and_then(|p| {
            p.picks
                .iter()
                .find(|k| k.tie == tie && strip.is_none_or(|s| same_strip(&k.strip, s)))
                .map(|k| {
                    format!(
                        "{}: line {}: tie {} in strip {} at x {}, y {}",
                        p.path.display(),
                        k.line,
                        k.tie,
                        k.strip,
                        k.x,
                        k.y
                    )
                })
        })
    };
    let told = match &e {
        E::TieOutsideStrip {
            tie,
            strip,
            radius_m,
            ..
        } => pick(tie, Some(strip))
            .map(|w| format!("{w}: no point of the strip within {radius_m:.2} m of the pick")),
        E::NoCoplanarTriangle { tie, strip, reason } => pick(tie, Some(strip))
            .map(|w| format!("{w}: no coplanar triangle around the pick ({reason})")),
        E::InvalidTie { tie, message } => pick(tie, None).map(|w| format!("{w}: {message}")),
        // Too few ties remain because picks were dropped: name the first in the CSV's terms.
        E::TooFewTies {
            ties,
            observations,
            unknowns,
            dropped,
        } if !dropped.is_empty() => {
            let d = &dropped[0];
            pick(&d.tie, Some(&d.strip)).map(|w| {
                format!(
                    "{w}: {}; with this and {} other dropped picks, {ties} ties give \
                     {observations} independent observations, {unknowns} unknowns need at least \
                     {unknowns}",
                    d.reason,
                    dropped.len() - 1
                )
            })
        }
        E::OutsideEveryStrip { what, id, .. } if *what == "tie" => {
            pick(id, None).map(|w| format!("{w}: outside every strip"))
        }
        E::OutsideEveryStrip { id, .. } => control.and_then(|(table, path)| {
            table.records.iter().find(|c| &c.id == id).map(|c| {
                format!(
                    "{}: line {}: control point {id} at x {}, y {} is outside every strip",
                    path.display(),
                    c.line,
                    c.x,
                    c.y
                )
            })
        }),
        _ => None,
    };
    match told {
        Some(t) => anyhow::anyhow!(t),
        None => e.into(),
    }
}

fn nearest_up(strip: &Strip, x: f64, y: f64) -> Option<f64> {
    strip
        .points
        .iter()
        .min_by(|a, b| {
            let da = (a.position_m.x - x).powi(2) + (a.position_m.y - y).powi(2);
            let db = (b.position_m.x - x).powi(2) + (b.position_m.y - y).powi(2);
            da.total_cmp(&db)
        })
        .map(|p| -p.position_m.z)
}

/// Loads every strip into one frame (the files must share a CRS).
pub(crate) fn load_all(
    paths: &[PathBuf],
    ctx: &TpuContext,
    gps_week: Option<i64>,
    crs: Option<Crs>,
) -> Result<(LocalFrame, Crs, Vec<LoadedStrip>)> {
    lidarqa_io::check_distinct_inputs(paths)?;
    let mut infos = Vec::new();
    let mut zone: Option<Crs> = None;
    for p in paths {
        let (info, z) = read_info(p, crs.clone())?;
        if let Some(z0) = &zone
            && *z0 != z
        {
            bail!(
                "{}: CRS EPSG {:?} differs from the first strip's",
                p.display(),
                z.epsg()
            );
        }
        zone = Some(z);
        infos.push(info);
    }
    let zone = zone.context("no strips")?;
    let frame = frame_for(&infos, &zone);
    let loaded = paths
        .iter()
        .zip(&infos)
        .map(|(p, info)| load_strip(p, (info, &zone), ctx, &frame, gps_week))
        .collect::<Result<Vec<_>>>()?;
    Ok((frame, zone, loaded))
}

fn write_json(path: &Path, value: &serde_json::Value, inputs: &[PathBuf]) -> Result<()> {
    let mut f = AtomicFile::create(path, inputs)?;
    serde_json::to_writer_pretty(&mut f, value)?;
    writeln!(f)?;
    f.commit()?;
    Ok(())
}

/// Points a VTPM window should hold in the sparsest strip when `--radius-m` is not given: enough
/// for a RANSAC plane and a Delaunay triangle around the pick with points to spare.
const VTPM_NEIGHBOURS: usize = 20;

struct Plan {
    args: CalibrateArgs,
    options: CalibrationOptions,
    iterations_path: PathBuf,
}

impl TryFrom<CalibrateArgs> for Plan {
    type Error = anyhow::Error;
    fn try_from(args: CalibrateArgs) -> Result<Plan> {
        let mut options = CalibrationOptions::default();
        if let Some(r) = args.radius_m {
            options.vtpm.radius_m = r;
        }
        options.vtpm.ransac_threshold_m = args.ransac_threshold_m;
        options.vtpm.ransac_iterations = args.ransac_iterations;
        options.vtpm.patch = args.tie_carrier == "patch";
        options.lm.max_iterations = args.max_iterations;
        if let Some(r) = args.radius_m
            && !(r.is_finite() && r > 0.0 && r <= MAX_RADIUS_M)
        {
            bail!(
                "--radius-m must be a number > 0 and at most {MAX_RADIUS_M} m (a tie is a local surface), got {r}"
            );
        }
        if !(args.ransac_threshold_m.is_finite() && args.ransac_threshold_m > 0.0) {
            bail!(
                "--ransac-threshold-m must be a number > 0, got {}",
                args.ransac_threshold_m
            );
        }
        for (flag, tau) in [
            ("--gnss-correlation-s", args.gnss_correlation_s),
            ("--attitude-correlation-s", args.attitude_correlation_s),
        ] {
            if let Some(t) = tau.filter(|t| !(t.is_finite() && *t > 0.0)) {
                bail!("{flag} must be a number of seconds > 0, got {t}");
            }
        }
        if !(1..=MAX_RANSAC_ITERATIONS).contains(&args.ransac_iterations) {
            bail!(
                "--ransac-iterations must be 1 to {MAX_RANSAC_ITERATIONS}, got {}",
                args.ransac_iterations
            );
        }
        if !(1..=MAX_LM_ITERATIONS).contains(&args.max_iterations) {
            bail!(
                "--max-iterations must be 1 to {MAX_LM_ITERATIONS}, got {}",
                args.max_iterations
            );
        }
        let dir = match args.output.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let iterations_path = dir.join("calibration_iterations.json");
        if iterations_path == args.output {
            bail!(
                "the output must not be named calibration_iterations.json (that file is written beside it)"
            );
        }
        Ok(Plan {
            args,
            options,
            iterations_path,
        })
    }
}

pub fn run(args: CalibrateArgs) -> Result<()> {
    let mut plan = Plan::try_from(args)?;
    if let Some(dir) = plan.args.output.parent()
        && !dir.as_os_str().is_empty()
    {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("{}: cannot create", dir.display()))?;
    }
    let a = &plan.args;
    let ctx = TpuContext::from_files(
        &a.sensor,
        &a.trajectory,
        None,
        TpuOptions {
            gps_week: a.gps_week,
            ..TpuOptions::default()
        },
    )?;
    crate::format::print_warnings(ctx.warnings());
    let prior: Mounting = ctx.sensor().mounting;
    plan.options.prior_sigma = lidarqa_io::read_sensor_with_extras(&a.sensor)?
        .1
        .mounting_sigma;
    if !a.no_trajectory_weighting {
        let sigma = &ctx.sensor().sigma;
        let t = TrajectorySigma {
            position_m: [Source::GnssNorth, Source::GnssEast, Source::GnssUp].map(|s| sigma.get(s)),
            attitude_rad: [Source::Roll, Source::Pitch, Source::Heading].map(|s| sigma.get(s)),
            position_correlation_s: a.gnss_correlation_s,
            attitude_correlation_s: a.attitude_correlation_s,
        };
        let any = t.position_m.iter().chain(&t.attitude_rad).any(|v| *v > 0.0);
        plan.options.trajectory_sigma = any.then_some(t);
    }
    let crs = crs_flags(a.utm_zone.as_deref(), a.epsg)?;
    let (frame, zone, loaded) = load_all(&a.strips, &ctx, a.gps_week, crs)?;
    let tie_picks = a.ties.as_ref().map(TiePicks::from_path).transpose()?;
    let picked = match &tie_picks {
        Some(p) => Some(ties_from_csv(p, &loaded, &frame, &zone)?),
        None => None,
    };
    // Strip id → the names a CSV may use for it (id and file stem).
    let loaded_ids: Vec<(String, String)> = loaded
        .iter()
        .map(|l| (l.strip.id.clone(), l.stem.clone()))
        .collect();
    let strips: Vec<Strip> = loaded.into_iter().map(|l| l.strip).collect();
    if a.radius_m.is_none() {
        let sparsest = strips
            .iter()
            .filter_map(|s| s.radius_for_neighbours_m(VTPM_NEIGHBOURS))
            .fold(0.0f64, f64::max);
        plan.options.vtpm.radius_m = sparsest.max(plan.options.vtpm.radius_m);
    }
    let ties = match picked {
        Some(t) => t,
        None => auto_ties(
            &strips,
            &prior,
            &AutoTieOptions {
                vtpm: plan.options.vtpm,
                ..AutoTieOptions::default()
            },
        )?,
    };
    let control_table = a
        .control
        .as_ref()
        .map(ControlPoints::from_path)
        .transpose()?;
    let control: Vec<ControlPoint> = match &control_table {
        Some(table) => {
            let mut out = Vec::with_capacity(table.records.len());
            for (i, c) in table.records.iter().enumerate() {
                out.push(ControlPoint {
                    id: c.id.clone(),
                    position_m: projected_to_local(&frame, &zone, c.x, c.y, c.z),
                    target_radius_m: table.extra_f64(i, "radius_m")?,
                    sigma_vertical_m: c.sigma_v_m,
                });
            }
            out
        }
        None => Vec::new(),
    };
    let cal: Calibration = match a.method.as_str() {
        "plane" => {
            let centres: Vec<[f64; 2]> = ties
                .iter()
                .map(|t| {
                    let n = t.picks.len() as f64;
                    [
                        t.picks.iter().map(|p| p.north_m).sum::<f64>() / n,
                        t.picks.iter().map(|p| p.east_m).sum::<f64>() / n,
                    ]
                })
                .collect();
            calibrate_plane(
                &strips,
                &centres,
                &prior,
                &plan.options,
                &PlaneOptions::default(),
            )?
        }
        _ => calibrate_vtpm(&strips, &ties, &control, &prior, &plan.options).map_err(|e| {
            in_csv_terms(
                e,
                tie_picks.as_ref(),
                control_table.as_ref().zip(a.control.as_deref()),
                &loaded_ids,
            )
        })?,
    };
    let mut inputs: Vec<PathBuf> = a.strips.clone();
    inputs.extend([a.trajectory.clone(), a.sensor.clone()]);
    inputs.extend(a.ties.clone());
    inputs.extend(a.control.clone());
    // SPEC §7: the trajectory's warnings and the calibration's own (dropped picks) go to
    // stderr and into the JSON.
    crate::format::print_warnings(&cal.warnings);
    let mut doc = cal.to_json();
    let mut warnings = ctx.warnings().to_vec();
    warnings.extend(cal.warnings.iter().cloned());
    if let Some(m) = doc.as_object_mut() {
        m.insert("warnings".into(), serde_json::to_value(&warnings)?);
    }
    write_json(&a.output, &doc, &inputs)?;
    if cal.method == lidarqa_calib::Method::Vtpm {
        let doc = cal.iterations_json(|v| local_to_projected(&frame, &zone, v));
        write_json(&plan.iterations_path, &doc, &inputs)?;
    }
    match a.format {
        OutputFormat::Json => print_json(&doc),
        OutputFormat::Table => print_text(&table(&cal)),
    }
}

fn table(cal: &Calibration) -> String {
    let x = lidarqa_calib::mounting_to_vector(&cal.mounting);
    let mut s = format!(
        "method {}  iterations {}  ({})  sigma0 {:.4} m\n{:<22} {:>12} {:>12} {:>12}  observable\n",
        cal.method.name(),
        cal.iterations,
        cal.termination.name(),
        cal.sigma0_m,
        "parameter",
        "value",
        "sigma",
        "prior sigma"
    );
    for p in Param::ALL {
        let i = p.index();
        let sig = cal.sigma[i].map_or("-".to_string(), |v| format!("{:.5}", p.to_display(v)));
        let prior_sig =
            cal.prior_sigma[i].map_or("-".to_string(), |v| format!("{:.5}", p.to_display(v)));
        s += &format!(
            "{:<22} {:>12.5} {:>12} {:>12}  {}\n",
            p.key(),
            p.to_display(x[i]),
            sig,
            prior_sig,
            if cal.observable[i] {
                "yes".to_string()
            } else {
                format!("no: {}", cal.held_because[i])
            }
        );
    }
    if let Some(t) = &cal.trajectory_sigma {
        s += &format!(
            "sigma includes each strip's trajectory error (GNSS {:.3}/{:.3}/{:.3} m, roll/pitch/heading {:.4}/{:.4}/{:.4} deg, {}; the ties are weighted by it)\n",
            t.position_m[0],
            t.position_m[1],
            t.position_m[2],
            t.attitude_rad[0].to_degrees(),
            t.attitude_rad[1].to_degrees(),
            t.attitude_rad[2].to_degrees(),
            correlation_phrase(t),
        );
    }
    for d in &cal.dropped_picks {
        s += &format!(
            "dropped pick: tie {} in strip {}: {}\n",
            d.tie, d.strip, d.reason
        );
    }
    let ((h0, v0), (h1, v1)) = cal.tie_rms_m();
    s += &format!(
        "tie residual RMS: horizontal {:.3} -> {:.3} m, vertical {:.3} -> {:.3} m ({} ties)\n",
        h0,
        h1,
        v0,
        v1,
        cal.ties.len()
    );
    s
}

/// How the trajectory errors are taken to vary over a strip, for the summary.
fn correlation_phrase(t: &TrajectorySigma) -> String {
    let one = |what: &str, tau: Option<f64>| match tau {
        Some(v) => format!("{what} correlated over {v} s"),
        None => format!("{what} constant over each strip"),
    };
    format!(
        "{}, {}",
        one("GNSS", t.position_correlation_s),
        one("attitude", t.attitude_correlation_s)
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;
    use lidarqa_io::{LasTimeBase, LasWriteOptions, LasWriter};

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: CalibrateArgs,
    }

    /// A one-point LAS without a CRS, in point format 0 (no GPS time) or 1.
    fn one_point_las(path: &Path, point_format: u8) {
        let opts = LasWriteOptions {
            version_minor: 2,
            point_format,
            scale: [0.001; 3],
            offset: [0.0; 3],
            time_base: LasTimeBase::GpsWeekSeconds,
            crs_vlrs: Vec::new(),
            extra_dims: Vec::new(),
            file_source_id: 0,
            extra_dims_f64: Vec::new(),
        };
        let mut w = LasWriter::create(path, &opts, &[] as &[&Path]).unwrap();
        w.write_point(
            &lidarqa_io::LasPoint {
                x: 1.0,
                y: 2.0,
                z: 3.0,
                gps_time_s: (point_format == 1).then_some(1000.0),
                ..lidarqa_io::LasPoint::default()
            },
            &[],
        )
        .unwrap();
        w.finish().unwrap();
    }

    #[test]
    fn a_strip_without_a_crs_needs_the_flag_which_overrides() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("no_crs.las");
        one_point_las(&path, 1);
        let e = format!("{:#}", read_info(&path, None).unwrap_err());
        assert!(
            e.contains("no_crs.las") && e.contains("pass --utm-zone or --epsg"),
            "{e}"
        );
        let zone = crs_flags(Some("33N"), None).unwrap();
        let (_, z) = read_info(&path, zone.clone()).unwrap();
        assert_eq!(Some(z.clone()), zone);
        assert_eq!(z.epsg(), Some(32633));
    }

    #[test]
    fn las_without_gps_time_is_refused_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("no_time.las");
        one_point_las(&path, 0);
        let e = read_info(&path, None).unwrap_err().to_string();
        assert!(
            e.ends_with(
                "no GPS time (point format 0); recovering raw observations needs each point's time"
            ),
            "{e}"
        );
        assert!(e.contains("no_time.las"), "{e}");
    }

    /// The required arguments, with neither `--ties` nor `--auto-ties`.
    const BASE: [&str; 8] = [
        "x",
        "a.laz",
        "--trajectory",
        "t",
        "--sensor",
        "s",
        "-o",
        "c.json",
    ];

    fn parse(extra: &[&str]) -> Result<Cli, clap::Error> {
        Cli::try_parse_from(BASE.iter().chain(extra))
    }

    #[test]
    fn ties_and_auto_ties_are_exclusive_and_one_is_required() {
        assert!(Cli::try_parse_from(BASE).is_err());
        assert!(parse(&["--ties", "t.csv", "--auto-ties"]).is_err());
        let c = parse(&["--auto-ties", "--radius-m", "1.5", "--method", "plane"]).unwrap();
        let plan = Plan::try_from(c.args).unwrap();
        assert_eq!(plan.options.vtpm.radius_m, 1.5);
        assert_eq!(
            plan.iterations_path,
            PathBuf::from("./calibration_iterations.json")
        );
    }

    #[test]
    fn bad_radius_is_refused() {
        for r in ["-1", "1e6"] {
            let c = parse(&["--auto-ties", "--radius-m", r]).unwrap();
            let e = Plan::try_from(c.args).err().unwrap().to_string();
            assert_eq!(
                e,
                format!(
                    "--radius-m must be a number > 0 and at most 50 m (a tie is a local surface), got {}",
                    r.parse::<f64>().unwrap()
                )
            );
        }
    }

    #[test]
    fn correlation_times_are_checked_and_exclude_the_plain_adjustment() {
        let with = |extra: &[&'static str]| {
            let mut v = vec!["--auto-ties"];
            v.extend(extra);
            parse(&v)
        };
        let c = with(&[
            "--attitude-correlation-s",
            "30",
            "--gnss-correlation-s",
            "200",
        ])
        .unwrap();
        assert_eq!(c.args.attitude_correlation_s, Some(30.0));
        assert_eq!(c.args.gnss_correlation_s, Some(200.0));
        assert!(Plan::try_from(c.args).is_ok());
        let c = with(&["--attitude-correlation-s", "0"]).unwrap();
        let e = Plan::try_from(c.args).err().unwrap().to_string();
        assert_eq!(
            e,
            "--attitude-correlation-s must be a number of seconds > 0, got 0"
        );
        assert!(with(&["--gnss-correlation-s", "60", "--no-trajectory-weighting"]).is_err());
    }
}
