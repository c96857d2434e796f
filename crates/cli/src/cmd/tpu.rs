//! `lidarqa tpu`: per-point TPU of a LAS/LAZ strip (or a directory of tiles) with its
//! trajectory (SPEC §6, §7, §9). The work is lidarqa-pipeline's `tpu_tiles`; this module parses,
//! shows progress and prints the summary.

use super::tpu_table;
use crate::format::{OutputFormat, print_json, print_text, print_warnings};
use anyhow::{Context, Result, bail};
use clap::Args;
use lidarqa_io::{AtomicFile, Crs, LasReader, UtmZone};
use lidarqa_pipeline::{TileReport, TpuContext, TpuOptions, TpuTileJob, tpu_tiles};
use std::io::Write as _;
use std::path::{Path, PathBuf};

pub const AFTER_HELP: &str = "\
Examples:
  lidarqa tpu strip.laz --trajectory sbet.out --sensor sensor.toml -o strip_tpu.laz
  lidarqa tpu strip.laz --trajectory sbet.out --smrmsg smrmsg.out --sensor sensor.toml \\
              -o strip_tpu.laz --summary summary.json --format json
  lidarqa tpu tiles/ --trajectory sbet.out --sensor sensor.toml -o tiles_tpu/ --skip-outside
  lidarqa tpu strip.laz --trajectory sbet.out --sensor sensor.toml \\
      --calibration calibration.json -o strip_tpu.laz   # the calibrated mounting and its σ

Writes every point with extra-bytes f32 sigma_north, sigma_east, sigma_up, sigma_horizontal,
sigma_vertical (1-sigma, metres, local level frame at the point; conic sensors also total_thu and
total_tvu at 95 %, and for bathymetric soundings, class 40, depth and iho_order: 1 exclusive,
2 special, 3 order 1a, 4 order 1b, 5 order 2, 0 none, -1 not a sounding). A sounding refracts at
its pulse's water-surface return (class 41, same GPS time) or else at a plane fitted to the
surface returns within 20 m; the summary gives the IHO S-44 Ed. 6 orders met by depth band.
LAS Z must be ellipsoidal heights in the trajectory's datum. The table shows σ in cm; JSON is in
metres. Skipped points are counted and not written.

An existing output of the same name (file, tiles in DIR, --summary) is replaced; an output
that is an input is refused, and so is a tile given twice under two names.";

/// Flags of `lidarqa tpu`, exactly as typed (checked by [`Plan::try_from`]).
#[derive(Debug, Args)]
pub struct TpuArgs {
    /// LAS/LAZ strip, or a directory of .las/.laz tiles.
    #[arg(value_name = "INPUT")]
    input: PathBuf,
    /// Trajectory: binary SBET, PDAL filters.sritrajectory text, cBLUE's PosPac ASCII export or
    /// text with a header (told apart by content; GPS seconds of week).
    #[arg(long, value_name = "FILE")]
    trajectory: PathBuf,
    /// Sensor file (TOML, SPEC §5); `[scanner] beam_divergence_mrad` enables the incidence term.
    #[arg(long, value_name = "FILE")]
    sensor: PathBuf,
    /// Output file (for a file input) or directory (for a directory input; created if missing).
    #[arg(short, long, value_name = "PATH")]
    output: PathBuf,
    /// SMRMSG accuracy file: its σ replace the sensor file's gnss_* and roll/pitch/heading.
    #[arg(long, value_name = "FILE")]
    smrmsg: Option<PathBuf>,
    /// calibration.json from `lidarqa calibrate`: its mounting and covariance replace the sensor
    /// file's mounting and mounting σ (parameters it held keep the sensor file's σ).
    #[arg(long, value_name = "FILE")]
    calibration: Option<PathBuf>,
    #[command(flatten)]
    flags: TpuFlags,
    /// Also write the summary as JSON to this file.
    #[arg(long, value_name = "FILE")]
    summary: Option<PathBuf>,
    /// Output format of the summary on stdout.
    #[arg(long, value_enum, default_value_t = OutputFormat::Table)]
    format: OutputFormat,
}

/// One tile: input → output.
struct Tile {
    input: PathBuf,
    output: PathBuf,
}

/// The options of a per-point TPU run, shared by `lidarqa tpu` and `lidarqa plan tpu`.
#[derive(Debug, Args)]
pub struct TpuFlags {
    /// GPS week of the survey (for adjusted standard GPS time).
    #[arg(long, value_name = "N")]
    gps_week: Option<i64>,
    /// UTM zone of the points when the files have no CRS, e.g. 33N or 17S (WGS 84).
    #[arg(long, value_name = "ZONE", conflicts_with = "epsg")]
    utm_zone: Option<String>,
    /// EPSG code of the points' projected CRS when the files have none (any projected EPSG
    /// CRS: UTM, national transverse Mercator grids, LAEA, state planes in feet, ...).
    #[arg(long, value_name = "CODE")]
    epsg: Option<u32>,
    /// Skip and count points outside the trajectory's time span instead of failing.
    #[arg(long)]
    skip_outside: bool,
    /// Skip and count points with NaN coordinates, an unusable GPS time or no recoverable
    /// observation (including soundings with no water surface above them or not below it)
    /// instead of failing.
    #[arg(long)]
    skip_invalid: bool,
    /// Points per chunk (memory grows with it; the result does not).
    #[arg(long, value_name = "N", default_value_t = TpuOptions::default().chunk_points)]
    chunk_points: usize,
    /// Neighbours of the plane fit for the incidence angle (3 to 256; never more than the
    /// points searched; unused when the file has NormalX/NormalY/NormalZ).
    #[arg(long, value_name = "K", default_value_t = TpuOptions::default().neighbours)]
    neighbours: usize,
    /// Geoid separation N in metres (ellipsoidal − orthometric height), added to LAS Z (and to a
    /// projected text trajectory's Z): required when the file's CRS has an orthometric vertical
    /// datum (e.g. NAVD88 height); the TPU needs ellipsoidal heights.
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    geoid_separation_m: Option<f64>,
    /// Also write the full covariance per point: VarianceX/Y/Z, CovarianceXY/XZ/YZ (f64 m²,
    /// projected axes easting, northing, up; PDAL filters.als_tpu's names).
    #[arg(long)]
    covariance: bool,
}

impl TpuFlags {
    /// The checked library options.
    pub(crate) fn options(&self) -> Result<TpuOptions> {
        let crs = crs_flags(self.utm_zone.as_deref(), self.epsg)?;
        if self.chunk_points == 0 {
            bail!("--chunk-points must be > 0");
        }
        if self
            .geoid_separation_m
            .is_some_and(|n| !(n.is_finite() && n.abs() < 200.0))
        {
            bail!(
                "--geoid-separation-m {:?} is not a geoid separation (|N| < 200 m)",
                self.geoid_separation_m.unwrap_or_default()
            );
        }
        let (lo, hi) = (lidarqa_tpu::MIN_NEIGHBOURS, lidarqa_tpu::MAX_NEIGHBOURS);
        if !(lo..=hi).contains(&self.neighbours) {
            bail!(
                "--neighbours {} must be {lo} to {hi} (a plane fit over one footprint's surroundings)",
                self.neighbours
            );
        }
        Ok(TpuOptions {
            crs,
            gps_week: self.gps_week,
            skip_outside: self.skip_outside,
            skip_invalid: self.skip_invalid,
            chunk_points: self.chunk_points,
            neighbours: self.neighbours,
            covariance: self.covariance,
            geoid_separation_m: self.geoid_separation_m,
            ..TpuOptions::default()
        })
    }
}

/// The `.las` / `.laz` files of `dir`, sorted; an error names the directory when it has none.
pub(crate) fn point_clouds_in(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut inputs: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("{}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file() && is_point_cloud(p))
        .collect();
    inputs.sort();
    if inputs.is_empty() {
        bail!("{}: no .las or .laz files in the directory", dir.display());
    }
    Ok(inputs)
}

/// A checked run.
struct Plan {
    tiles: Vec<Tile>,
    options: TpuOptions,
    trajectory: PathBuf,
    smrmsg: Option<PathBuf>,
    sensor: PathBuf,
    calibration: Option<PathBuf>,
    summary: Option<PathBuf>,
    format: OutputFormat,
}

/// The CRS given by `--utm-zone` or `--epsg` (clap refuses both), if any.
pub(crate) fn crs_flags(utm_zone: Option<&str>, epsg: Option<u32>) -> Result<Option<Crs>> {
    Ok(match (utm_zone, epsg) {
        (Some(z), _) => Some(Crs::from(z.parse::<UtmZone>().context("--utm-zone")?)),
        (None, Some(code)) => Some(Crs::from_epsg(code).with_context(|| format!("--epsg {code}"))?),
        (None, None) => None,
    })
}

pub(crate) fn is_point_cloud(p: &Path) -> bool {
    p.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("las") || e.eq_ignore_ascii_case("laz"))
}

impl TryFrom<TpuArgs> for Plan {
    type Error = anyhow::Error;

    fn try_from(a: TpuArgs) -> Result<Plan> {
        let options = a.flags.options()?;
        let tiles = if a.input.is_dir() {
            let inputs = point_clouds_in(&a.input)?;
            // Two links to one tile would count its points twice.
            lidarqa_io::check_distinct_inputs(&inputs)?;
            if a.output.exists() && !a.output.is_dir() {
                bail!(
                    "{}: the input is a directory, so the output must be one too",
                    a.output.display()
                );
            }
            if a.output.canonicalize().ok() == a.input.canonicalize().ok() {
                bail!(
                    "{}: refusing to write into the input directory {}",
                    a.output.display(),
                    a.input.display()
                );
            }
            std::fs::create_dir_all(&a.output)
                .with_context(|| format!("{}", a.output.display()))?;
            inputs
                .into_iter()
                .map(|input| Tile {
                    output: a.output.join(input.file_name().unwrap_or_default()),
                    input,
                })
                .collect()
        } else {
            if a.output.is_dir() {
                bail!(
                    "{}: the input is a file, so the output must be a file, not a directory",
                    a.output.display()
                );
            }
            vec![Tile {
                input: a.input.clone(),
                output: a.output.clone(),
            }]
        };
        for t in &tiles {
            let mut inputs = vec![
                t.input.as_path(),
                a.trajectory.as_path(),
                a.sensor.as_path(),
            ];
            inputs.extend(a.smrmsg.as_deref());
            inputs.extend(a.calibration.as_deref());
            lidarqa_io::check_not_an_input(&t.output, &inputs)?;
        }
        Ok(Plan {
            tiles,
            options,
            trajectory: a.trajectory,
            smrmsg: a.smrmsg,
            sensor: a.sensor,
            calibration: a.calibration,
            summary: a.summary,
            format: a.format,
        })
    }
}

/// Run `lidarqa tpu`.
pub fn run(args: TpuArgs) -> Result<()> {
    let plan = Plan::try_from(args)?;
    let ctx = TpuContext::from_files(
        &plan.sensor,
        &plan.trajectory,
        plan.smrmsg.as_deref(),
        plan.options.clone(),
    )?;
    let ctx = match &plan.calibration {
        Some(path) => ctx.with_calibration(path)?,
        None => ctx,
    };
    // Headers only, for the progress bar's length.
    let total: u64 = plan
        .tiles
        .iter()
        .map(|t| LasReader::from_path(&t.input).map(|r| r.info().point_count))
        .sum::<lidarqa_io::Result<u64>>()?;
    let bar = crate::progress::bar("tpu", total, "points");
    let progress = |n: u64| bar.inc(n);
    let jobs: Vec<TpuTileJob> = plan
        .tiles
        .iter()
        .map(|t| TpuTileJob {
            input: &t.input,
            output: &t.output,
            context: &ctx,
        })
        .collect();
    let reports = tpu_tiles(&jobs, &progress)?;
    bar.finish_and_clear();
    let (_, report) = TileReport::merge(&reports).context("no tiles")?;
    print_warnings(&report.summary.warnings);
    if let Some(path) = &plan.summary {
        let mut inputs: Vec<&Path> = plan.tiles.iter().map(|t| t.input.as_path()).collect();
        inputs.push(&plan.trajectory);
        inputs.push(&plan.sensor);
        inputs.extend(plan.smrmsg.as_deref());
        inputs.extend(plan.calibration.as_deref());
        let mut f = AtomicFile::create(path, &inputs)?;
        serde_json::to_writer_pretty(&mut f, &report)
            .with_context(|| format!("{}", path.display()))?;
        writeln!(f).with_context(|| format!("{}", path.display()))?;
        f.commit()?;
    }
    match plan.format {
        OutputFormat::Json => print_json(&report),
        OutputFormat::Table => print_text(&format!(
            "trajectory {} read as {}\n{}",
            plan.trajectory.display(),
            ctx.trajectory_format().describe(),
            tpu_table::table(&report)
        )),
    }
}
