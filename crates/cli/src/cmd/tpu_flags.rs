//! Flags shared by the subcommands that read point clouds: the GPS week and CRS override
//! (`tpu`, `plan tpu`, `calibrate`, `correct`), the per-point TPU options (`tpu`, `plan tpu`)
//! and the point clouds of a directory.

use anyhow::{Context, Result, bail};
use clap::Args;
use lidarqa_io::WaterClasses;
use lidarqa_io::{Crs, UtmZone};
use lidarqa_pipeline::{TpuContext, TpuOptions};
use std::path::{Path, PathBuf};

/// When and where the points are: the GPS week and the CRS of files that have none, shared by
/// every subcommand that georeferences points with a trajectory.
#[derive(Debug, Args)]
pub struct SurveyFlags {
    /// GPS week of the survey (LAS adjusted standard GPS time).
    #[arg(long, value_name = "WEEK")]
    gps_week: Option<i64>,
    /// UTM zone of the points when the files have no CRS, e.g. 33N or 17S (WGS 84); overrides
    /// the header's.
    #[arg(long, value_name = "ZONE", conflicts_with = "epsg")]
    utm_zone: Option<String>,
    /// EPSG code of the points' projected CRS when the files have none (any projected EPSG
    /// CRS: UTM, national transverse Mercator grids, LAEA, state planes in feet, ...).
    #[arg(long, value_name = "CODE")]
    epsg: Option<u32>,
}

impl SurveyFlags {
    /// The library options these flags set (the others at their defaults).
    pub(crate) fn options(&self) -> Result<TpuOptions> {
        Ok(TpuOptions {
            crs: crs_flags(self.utm_zone.as_deref(), self.epsg)?,
            gps_week: self.gps_week,
            ..TpuOptions::default()
        })
    }

    /// The sensor and trajectory (no SMRMSG) read with these flags.
    pub(crate) fn context(&self, sensor: &Path, trajectory: &Path) -> Result<TpuContext> {
        Ok(TpuContext::from_files(
            sensor,
            trajectory,
            None,
            self.options()?,
        )?)
    }
}

/// The options of a per-point TPU run, shared by `lidarqa tpu` and `lidarqa plan tpu`.
#[derive(Debug, Args)]
pub struct TpuFlags {
    #[command(flatten)]
    survey: SurveyFlags,
    /// Skip and count points outside the trajectory's time span instead of failing.
    #[arg(long)]
    skip_outside: bool,
    /// Skip and count points with NaN coordinates, an unusable GPS time or no recoverable
    /// observation (including soundings with no water surface above them or not below it)
    /// instead of failing.
    #[arg(long)]
    skip_invalid: bool,
    /// Points per chunk (memory grows with it; the result does not, for a multiple of 32: the
    /// incidence judgement is shared from seeds counted from each chunk's start).
    #[arg(long, value_name = "N", default_value_t = TpuOptions::default().chunk_points)]
    chunk_points: usize,
    /// Neighbours of the plane fit for the incidence angle (3 to 256; never more than the
    /// points searched; unused when the file has NormalX/NormalY/NormalZ).
    #[arg(long, value_name = "K", default_value_t = TpuOptions::default().neighbours)]
    neighbours: usize,
    /// Geoid separation N in metres (ellipsoidal − orthometric height), added to LAS Z (and to a
    /// projected text trajectory's Z): required when the file's CRS has an orthometric vertical
    /// datum (e.g. NAVD88 height); the TPU needs ellipsoidal heights.
    #[arg(
        long,
        value_name = "M",
        allow_negative_numbers = true,
        conflicts_with = "geoid"
    )]
    geoid_separation_m: Option<f64>,
    /// Geoid grid (GTX or GeoTIFF in degrees, e.g. GEOID18, CGG2013, EGG2015) for files whose
    /// heights are orthometric: N at each point is added to LAS Z. Not needed for a vertical
    /// CRS on EGM2008 (built in) nor with a trajectory rebuilt from the same points by
    /// `lidarqa trajectory` (it is in their height system).
    #[arg(long, value_name = "FILE")]
    geoid: Option<PathBuf>,
    /// LAS classes of returns from below the water surface, comma-separated (default 40, 43,
    /// 44, 45 — LAS 1.4 topo-bathy — and 26, RIEGL / LP360 bathymetry): a conic scanner's
    /// soundings; the summary names the classes it assumed.
    #[arg(long, value_name = "LIST", value_delimiter = ',')]
    water_classes: Option<Vec<u8>>,
    /// Also write the full covariance per point: VarianceX/Y/Z, CovarianceXY/XZ/YZ (f64 m²,
    /// projected axes easting, northing, up; PDAL filters.als_tpu's names).
    #[arg(long)]
    covariance: bool,
}

impl TpuFlags {
    /// The checked library options.
    pub(crate) fn options(&self) -> Result<TpuOptions> {
        let survey = self.survey.options()?;
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
            skip_outside: self.skip_outside,
            skip_invalid: self.skip_invalid,
            chunk_points: self.chunk_points,
            neighbours: self.neighbours,
            covariance: self.covariance,
            geoid_separation_m: self.geoid_separation_m,
            geoid: self.geoid.clone(),
            water_classes: self
                .water_classes
                .clone()
                .map(WaterClasses::given)
                .unwrap_or_default(),
            ..survey
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

/// The CRS given by `--utm-zone` or `--epsg` (clap refuses both), if any.
fn crs_flags(utm_zone: Option<&str>, epsg: Option<u32>) -> Result<Option<Crs>> {
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
