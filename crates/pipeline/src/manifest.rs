//! Tile manifests: plan a survey once, run each tile anywhere (a SLURM array task, a Kubernetes
//! Indexed Job pod, a Dask task), merge the tile reports (SPEC §9).
//!
//! A [`Manifest`] lists one [`Entry`] per tile with its input (path, size, BLAKE3), its output,
//! its tile-report path and its seed, plus what every tile shares (trajectory, SMRMSG, sensor,
//! each with its digest) and the [`ManifestOptions`]. Paths under the manifest's directory are
//! stored relative to it, so a manifest and its data can be moved or mounted elsewhere together.
//!
//! **Completion.** [`run_entry`] writes the tile's LAS/LAZ atomically (temporary file + rename),
//! then its tile report (JSON, atomically): the report is the completion marker. An entry is
//! complete when its report parses, was written for this very entry (its `key` is a hash of the
//! entry, the shared inputs' digests, the options and the lidarqa version), and the output on
//! disk still has the size and BLAKE3 the report recorded. A run skips a complete entry, and
//! redoes anything else: a missing or partial output, an output changed since, a report from an
//! earlier plan (a changed input or option gives a new key). A killed run leaves at most a
//! hidden `.NAME.*.tmp` file, never a file under the final name without its report.
//!
//! **Changed inputs.** A run refuses (one-line error naming the file) when an input no longer
//! has the digest the manifest recorded: plan again, and the entries whose inputs changed get a
//! new key and are redone while the others are skipped.
//!
//! **Collect.** [`collect`] reads every entry's report, in manifest order, and merges them with
//! [`TileReport::merge`], the merge `lidarqa tpu` uses over a directory: the survey summary is
//! the same, bit for bit.

use crate::context::{TpuContext, TpuOptions};
use crate::digest::{FileDigest, seed_for_tile};
use crate::error::{Error, Result};
use crate::stored::StoredSummary;
use crate::summary::{TileReport, TpuSummary};
use crate::tile::{TpuTileJob, tpu_tile};
use lidarqa_io::{AtomicFile, Crs};
use lidarqa_products::TpuSummaryDocument;
use serde::{Deserialize, Serialize};
use std::io::Write as _;
use std::path::{Path, PathBuf};

/// `format` of a manifest.
pub const MANIFEST_FORMAT: &str = "lidarqa-manifest/1";
/// `format` of a tile report.
pub const TILE_REPORT_FORMAT: &str = "lidarqa-tile-report/1";
/// Suffix of a tile report beside its output (`tile.laz` → `tile.laz.report.json`).
pub const REPORT_SUFFIX: &str = ".report.json";

/// What a manifest's entries compute.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Task {
    /// Per-point TPU ([`tpu_tile`]).
    Tpu,
}

/// An input file as planned: its path and digest.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InputFile {
    /// Relative to the manifest's directory, or absolute.
    pub path: PathBuf,
    /// Length, bytes.
    pub size: u64,
    /// BLAKE3, hex.
    pub blake3: String,
}

impl InputFile {
    fn digest(&self) -> FileDigest {
        FileDigest {
            size: self.size,
            blake3: self.blake3.clone(),
        }
    }
}

/// The [`TpuOptions`] of a manifest, as stored (the CRS as an EPSG code).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ManifestOptions {
    /// EPSG code of the points' UTM CRS when the files have none (or to override theirs).
    pub epsg: Option<u32>,
    /// GPS week of the survey.
    pub gps_week: Option<i64>,
    /// Skip points outside the trajectory.
    pub skip_outside: bool,
    /// Skip invalid points.
    pub skip_invalid: bool,
    /// Points per chunk.
    pub chunk_points: usize,
    /// Neighbours of the incidence plane fit.
    pub neighbours: usize,
    /// Look-back / look-ahead margin across chunk borders, points.
    pub margin_points: usize,
    /// Write the full covariance too.
    #[serde(default)]
    pub covariance: bool,
    /// Geoid separation, m.
    #[serde(default)]
    pub geoid_separation_m: Option<f64>,
    /// Geoid grid file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub geoid: Option<PathBuf>,
    /// Water classes given by the user (`None`: the default).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub water_classes: Option<Vec<u8>>,
}

impl ManifestOptions {
    /// From run options.
    ///
    /// # Errors
    /// [`Error::InvalidOption`] for a CRS without an EPSG code.
    pub fn from_options(o: &TpuOptions) -> Result<ManifestOptions> {
        let epsg = match &o.crs {
            None => None,
            Some(z) => Some(z.epsg().ok_or_else(|| {
                Error::InvalidOption(format!("the CRS {} has no EPSG code", z.name()))
            })?),
        };
        Ok(ManifestOptions {
            epsg,
            gps_week: o.gps_week,
            skip_outside: o.skip_outside,
            skip_invalid: o.skip_invalid,
            chunk_points: o.chunk_points,
            neighbours: o.neighbours,
            margin_points: o.margin_points,
            covariance: o.covariance,
            geoid_separation_m: o.geoid_separation_m,
            geoid: o.geoid.clone(),
            water_classes: o.water_classes.given_list(),
        })
    }

    /// Back to run options.
    ///
    /// # Errors
    /// [`Error::Io`] (lidarqa-io's message) for an EPSG code lidarqa cannot project with.
    pub fn to_options(&self) -> Result<TpuOptions> {
        Ok(TpuOptions {
            crs: self.epsg.map(Crs::from_epsg).transpose()?,
            gps_week: self.gps_week,
            skip_outside: self.skip_outside,
            skip_invalid: self.skip_invalid,
            chunk_points: self.chunk_points,
            neighbours: self.neighbours,
            margin_points: self.margin_points,
            covariance: self.covariance,
            geoid_separation_m: self.geoid_separation_m,
            geoid: self.geoid.clone(),
            water_classes: self
                .water_classes
                .clone()
                .map(lidarqa_io::WaterClasses::given)
                .unwrap_or_default(),
        })
    }
}

/// One tile of a manifest.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Entry {
    /// Position in `entries` (the array task index).
    pub index: usize,
    /// Tile id: the input's file stem.
    pub id: String,
    /// Seed of the tile's random draws, from its id ([`seed_for_tile`]; TPU draws none).
    pub seed: u64,
    /// The input tile.
    pub input: InputFile,
    /// The output tile (relative to the manifest's directory, or absolute).
    pub output: PathBuf,
    /// The tile report, the completion marker, written after the output.
    pub report: PathBuf,
}

/// A survey's tiles and what they share; see the module docs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// [`MANIFEST_FORMAT`].
    pub format: String,
    /// What the entries compute.
    pub task: Task,
    /// SBET.
    pub trajectory: InputFile,
    /// SMRMSG, if any.
    pub smrmsg: Option<InputFile>,
    /// Sensor file.
    pub sensor: InputFile,
    /// Run options.
    pub options: ManifestOptions,
    /// One per tile, in input-name order.
    pub entries: Vec<Entry>,
}

/// What [`plan_tpu`] needs.
#[derive(Debug, Clone)]
pub struct TpuPlan<'a> {
    /// Where the manifest will be written (paths are stored relative to its directory).
    pub manifest: &'a Path,
    /// The tiles (LAS/LAZ), in the order of the entries.
    pub tiles: &'a [PathBuf],
    /// Directory of the outputs (created; each output has its input's file name).
    pub output_dir: &'a Path,
    /// SBET.
    pub trajectory: &'a Path,
    /// SMRMSG, if any.
    pub smrmsg: Option<&'a Path>,
    /// Sensor file.
    pub sensor: &'a Path,
    /// Run options.
    pub options: &'a TpuOptions,
}

/// The outcome of [`run_entry`].
#[derive(Debug, Clone, PartialEq)]
pub struct EntryOutcome {
    /// True when the entry was already complete and nothing was done.
    pub skipped: bool,
    /// The tile's report (paths as in the manifest).
    pub report: TileReport,
}

/// A tile report as stored: the completion marker of one entry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct StoredTileReport {
    format: String,
    key: String,
    index: usize,
    id: String,
    input: PathBuf,
    output: PathBuf,
    output_size: u64,
    output_blake3: String,
    summary: StoredSummary,
}

fn manifest_error(path: &Path, message: impl Into<String>) -> Error {
    Error::Manifest {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

fn io_error(path: &Path, source: std::io::Error) -> Error {
    Error::Io(lidarqa_io::Error::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// The directory a manifest's relative paths are relative to.
fn base_dir(manifest: &Path) -> PathBuf {
    match manifest.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// `path` relative to `base` when it lies under it, else absolute (both canonicalised).
fn stored_path(base: &Path, path: &Path) -> Result<PathBuf> {
    let canon = |p: &Path| p.canonicalize().map_err(|e| io_error(p, e));
    let (b, p) = (canon(base)?, canon(path)?);
    Ok(match p.strip_prefix(&b) {
        Ok(rel) => rel.to_path_buf(),
        Err(_) => p,
    })
}

fn input_file(base: &Path, path: &Path) -> Result<InputFile> {
    let d = FileDigest::of_file(path)?;
    Ok(InputFile {
        path: stored_path(base, path)?,
        size: d.size,
        blake3: d.blake3,
    })
}

/// Plans a TPU survey: one entry per tile, every input hashed; creates the output directory.
/// The sensor file, trajectory and SMRMSG are read and checked as a run would.
///
/// # Errors
/// I/O errors naming the file; [`Error::Manifest`] for no tiles or two tiles with one file
/// name (their outputs would collide); lidarqa-io's `OutputIsInput` when an output would
/// overwrite an input.
pub fn plan_tpu(plan: &TpuPlan<'_>) -> Result<Manifest> {
    if plan.tiles.is_empty() {
        return Err(manifest_error(plan.manifest, "no tiles to plan"));
    }
    // What every entry will read, read once now: a sensor file with a typo or a truncated
    // trajectory is refused here, not by every array task.
    TpuContext::from_files(
        plan.sensor,
        plan.trajectory,
        plan.smrmsg,
        plan.options.clone(),
    )?;
    lidarqa_io::check_distinct_inputs(plan.tiles)?;
    let base = base_dir(plan.manifest);
    std::fs::create_dir_all(&base).map_err(|e| io_error(&base, e))?;
    std::fs::create_dir_all(plan.output_dir).map_err(|e| io_error(plan.output_dir, e))?;
    let out_dir = stored_path(&base, plan.output_dir)?;
    let mut shared = vec![plan.trajectory, plan.sensor];
    shared.extend(plan.smrmsg);
    let mut entries: Vec<Entry> = Vec::with_capacity(plan.tiles.len());
    for (index, tile) in plan.tiles.iter().enumerate() {
        let name = tile
            .file_name()
            .ok_or_else(|| manifest_error(tile, "a tile path without a file name"))?;
        let output = out_dir.join(name);
        let mut inputs: Vec<&Path> = shared.clone();
        inputs.push(tile);
        lidarqa_io::check_not_an_input(plan.output_dir.join(name), &inputs)?;
        if let Some(other) = entries.iter().find(|e| e.output == output) {
            return Err(manifest_error(
                tile,
                format!(
                    "has the same file name as {}: their outputs would collide",
                    other.input.path.display()
                ),
            ));
        }
        let id = Path::new(name)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let mut report = output.clone().into_os_string();
        report.push(REPORT_SUFFIX);
        entries.push(Entry {
            index,
            seed: seed_for_tile(&id),
            id,
            input: input_file(&base, tile)?,
            output,
            report: PathBuf::from(report),
        });
    }
    let m = Manifest {
        format: MANIFEST_FORMAT.into(),
        task: Task::Tpu,
        trajectory: input_file(&base, plan.trajectory)?,
        smrmsg: plan.smrmsg.map(|p| input_file(&base, p)).transpose()?,
        sensor: input_file(&base, plan.sensor)?,
        options: ManifestOptions::from_options(plan.options)?,
        entries,
    };
    m.check_paths(plan.manifest)?;
    Ok(m)
}

impl Manifest {
    /// Reads and checks a manifest.
    ///
    /// # Errors
    /// I/O errors naming the file; [`Error::Manifest`] naming the key for bad JSON, another
    /// format, or entries whose `index` is not their position.
    pub fn read(path: &Path) -> Result<Manifest> {
        let text = std::fs::read_to_string(path).map_err(|e| io_error(path, e))?;
        let m: Manifest = serde_json::from_str(&text)
            .map_err(|e| manifest_error(path, format!("not a lidarqa manifest: {e}")))?;
        if m.format != MANIFEST_FORMAT {
            return Err(manifest_error(
                path,
                format!("\"format\": \"{}\" is not \"{MANIFEST_FORMAT}\"", m.format),
            ));
        }
        if let Some((i, e)) = m.entries.iter().enumerate().find(|(i, e)| e.index != *i) {
            return Err(manifest_error(
                path,
                format!("\"entries\"[{i}]: \"index\" is {}, not {i}", e.index),
            ));
        }
        m.check_paths(path)?;
        Ok(m)
    }

    /// Refuses paths that would let a run write outside the manifest's directory or over a
    /// file it reads (SPEC §7): a `..` component anywhere, an output or report that is
    /// absolute outside the manifest's directory, or one equal to any entry's input, the
    /// trajectory, the SMRMSG, the sensor file, the manifest itself, or another output or report.
    ///
    /// # Errors
    /// [`Error::Manifest`] naming the entry and the key.
    pub fn check_paths(&self, manifest: &Path) -> Result<()> {
        let bad =
            |what: String, message: String| manifest_error(manifest, format!("{what}: {message}"));
        let mut inputs: Vec<(String, &Path)> = vec![
            ("\"trajectory\"".into(), &self.trajectory.path),
            ("\"sensor\"".into(), &self.sensor.path),
        ];
        if let Some(s) = &self.smrmsg {
            inputs.push(("\"smrmsg\"".into(), &s.path));
        }
        for (i, e) in self.entries.iter().enumerate() {
            inputs.push((format!("\"entries\"[{i}].\"input\""), &e.input.path));
        }
        let mut outputs: Vec<(String, &Path)> = Vec::new();
        for (i, e) in self.entries.iter().enumerate() {
            outputs.push((format!("\"entries\"[{i}].\"output\""), &e.output));
            outputs.push((format!("\"entries\"[{i}].\"report\""), &e.report));
        }
        for (what, p) in inputs.iter().chain(&outputs) {
            if p.components().any(|c| c == std::path::Component::ParentDir) {
                return Err(bad(
                    what.clone(),
                    format!(
                        "{} has a `..` component; a manifest's paths may not climb out of its directory",
                        p.display()
                    ),
                ));
            }
        }
        let root = base_dir(manifest);
        let root_canon = root.canonicalize().unwrap_or_else(|_| root.clone());
        for (what, p) in &outputs {
            if p.is_absolute() && !p.starts_with(&root_canon) && !p.starts_with(&root) {
                return Err(bad(
                    what.clone(),
                    format!(
                        "{} is outside the manifest's directory {}; outputs must be written under it",
                        p.display(),
                        root_canon.display()
                    ),
                ));
            }
        }
        // Resolved through symbolic links (`lnk -> ..`): where a write would land must lie under
        // the manifest's directory too, not only the path as spelled.
        let root_resolved = lidarqa_io::resolved(&root);
        for (what, p) in &outputs {
            let lands = lidarqa_io::resolved(&resolve(manifest, p));
            if !lands.starts_with(&root_resolved) {
                return Err(bad(
                    what.clone(),
                    format!(
                        "{} resolves through a symbolic link to {}, outside the manifest's \
                         directory {}; outputs must be written under it",
                        p.display(),
                        lands.display(),
                        root_resolved.display()
                    ),
                ));
            }
        }
        let mut read: Vec<PathBuf> = inputs.iter().map(|(_, p)| resolve(manifest, p)).collect();
        read.push(manifest.to_path_buf());
        let read = lidarqa_io::InputSet::new(&read);
        let mut written: std::collections::HashMap<PathBuf, &str> = Default::default();
        for (what, p) in &outputs {
            let out = resolve(manifest, p);
            if let Err(lidarqa_io::Error::OutputIsInput { input, .. }) = read.check(&out) {
                return Err(bad(
                    what.clone(),
                    format!(
                        "{} is also an input ({}); a run would overwrite it",
                        p.display(),
                        input.display()
                    ),
                ));
            }
            if let Some(other) = written.insert(out, what) {
                return Err(bad(
                    what.clone(),
                    format!(
                        "{} is also {other}; one would overwrite the other",
                        p.display()
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Writes the manifest atomically (pretty JSON).
    ///
    /// # Errors
    /// I/O errors naming the file.
    pub fn write(&self, path: &Path) -> Result<()> {
        let mut inputs: Vec<PathBuf> = vec![
            resolve(path, &self.trajectory.path),
            resolve(path, &self.sensor.path),
        ];
        inputs.extend(self.smrmsg.iter().map(|s| resolve(path, &s.path)));
        inputs.extend(self.entries.iter().map(|e| resolve(path, &e.input.path)));
        let mut f = AtomicFile::create(path, &inputs)?;
        serde_json::to_writer_pretty(&mut f, self).map_err(|e| io_error(path, e.into()))?;
        writeln!(f).map_err(|e| io_error(path, e))?;
        f.commit()?;
        Ok(())
    }

    /// The entry at `index`.
    ///
    /// # Errors
    /// [`Error::Manifest`] when there is none.
    pub fn entry(&self, manifest: &Path, index: usize) -> Result<&Entry> {
        self.entries.get(index).ok_or_else(|| {
            manifest_error(
                manifest,
                format!(
                    "no entry {index}: the manifest has {} (indices 0 to {})",
                    self.entries.len(),
                    self.entries.len().saturating_sub(1)
                ),
            )
        })
    }

    /// The shared context (sensor, trajectory, SMRMSG, options), after checking that those
    /// files still have their planned digests.
    ///
    /// # Errors
    /// [`Error::Manifest`] naming a changed file; as [`TpuContext::from_files`].
    pub fn context(&self, manifest: &Path) -> Result<TpuContext> {
        for f in [
            Some(&self.trajectory),
            Some(&self.sensor),
            self.smrmsg.as_ref(),
        ]
        .into_iter()
        .flatten()
        {
            check_unchanged(manifest, f)?;
        }
        let smrmsg = self.smrmsg.as_ref().map(|s| resolve(manifest, &s.path));
        TpuContext::from_files(
            &resolve(manifest, &self.sensor.path),
            &resolve(manifest, &self.trajectory.path),
            smrmsg.as_deref(),
            self.options.to_options()?,
        )
    }

    /// The key a complete entry's report carries: BLAKE3 of everything its output depends on.
    fn key(&self, entry: &Entry) -> String {
        let what = serde_json::json!({
            "lidarqa": env!("CARGO_PKG_VERSION"),
            "task": self.task,
            "input": entry.input,
            "output": entry.output,
            "trajectory": self.trajectory,
            "smrmsg": self.smrmsg,
            "sensor": self.sensor,
            "options": self.options,
        });
        blake3::hash(what.to_string().as_bytes())
            .to_hex()
            .to_string()
    }
}

/// A manifest path resolved against the manifest's directory.
pub fn resolve(manifest: &Path, path: &Path) -> PathBuf {
    if path.is_absolute() {
        path.to_path_buf()
    } else {
        base_dir(manifest).join(path)
    }
}

fn check_unchanged(manifest: &Path, f: &InputFile) -> Result<()> {
    let path = resolve(manifest, &f.path);
    let now = FileDigest::of_file(&path)?;
    if now != f.digest() {
        return Err(manifest_error(
            &path,
            format!(
                "changed since the manifest {} was planned (size {} → {} bytes, blake3 {}… → {}…); run lidarqa plan again",
                manifest.display(),
                f.size,
                now.size,
                &f.blake3[..12.min(f.blake3.len())],
                &now.blake3[..12]
            ),
        ));
    }
    Ok(())
}

/// The entry's report when the entry is complete (module docs), or why it is not.
///
/// # Errors
/// Never for an incomplete entry (that is `Ok(Err(reason))`); [`Error::Manifest`] when
/// `index` is out of range.
pub fn entry_status(
    manifest_path: &Path,
    manifest: &Manifest,
    index: usize,
) -> Result<std::result::Result<TileReport, String>> {
    let entry = manifest.entry(manifest_path, index)?;
    let report_path = resolve(manifest_path, &entry.report);
    let text = match std::fs::read_to_string(&report_path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Ok(Err("no tile report".into()));
        }
        Err(e) => return Ok(Err(format!("tile report unreadable: {e}"))),
    };
    let stored: StoredTileReport = match serde_json::from_str(&text) {
        Ok(s) => s,
        Err(e) => return Ok(Err(format!("tile report is not valid: {e}"))),
    };
    if stored.format != TILE_REPORT_FORMAT || stored.key != manifest.key(entry) {
        return Ok(Err(
            "tile report is from another plan (an input or option changed)".into(),
        ));
    }
    let output = FileDigest {
        size: stored.output_size,
        blake3: stored.output_blake3.clone(),
    };
    if !output.matches(&resolve(manifest_path, &entry.output)) {
        return Ok(Err(
            "output is missing or differs from the one its report recorded".into(),
        ));
    }
    match stored.summary.restore() {
        Ok(summary) => Ok(Ok(TileReport {
            input: entry.input.path.clone(),
            output: entry.output.clone(),
            summary,
        })),
        Err(m) => Ok(Err(format!("tile report: {m}"))),
    }
}

/// Runs entry `index` unless it is complete (then returns its report with `skipped`); with
/// `force`, runs it whatever its state. The input tile is checked against its planned digest
/// first, complete or not. `context` is built from the manifest when `None`
/// (pass one to run many entries of a manifest in one process).
///
/// # Errors
/// [`Error::Manifest`] for an index out of range or an input changed since the plan; as
/// [`tpu_tile`]; I/O errors naming the report.
pub fn run_entry(
    manifest_path: &Path,
    manifest: &Manifest,
    index: usize,
    context: Option<&TpuContext>,
    force: bool,
) -> Result<EntryOutcome> {
    let entry = manifest.entry(manifest_path, index)?;
    // First, even for a complete entry: its output would be stale for the input on disk now.
    check_unchanged(manifest_path, &entry.input)?;
    if !force && let Ok(report) = entry_status(manifest_path, manifest, index)? {
        return Ok(EntryOutcome {
            skipped: true,
            report,
        });
    }
    let input = resolve(manifest_path, &entry.input.path);
    let owned;
    let ctx = match context {
        Some(c) => c,
        None => {
            owned = manifest.context(manifest_path)?;
            &owned
        }
    };
    let output = resolve(manifest_path, &entry.output);
    let report_path = resolve(manifest_path, &entry.report);
    if let Some(dir) = output.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| io_error(dir, e))?;
    }
    // The old marker goes first: from here until the new one is committed the entry is
    // incomplete, whatever happens to this process.
    match std::fs::remove_file(&report_path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            return Err(io_error(&report_path, e));
        }
        _ => {}
    }
    let mut report = tpu_tile(&TpuTileJob {
        input: &input,
        output: &output,
        context: ctx,
        progress: Default::default(),
    })?;
    let digest = FileDigest::of_file(&output)?;
    let stored = StoredTileReport {
        format: TILE_REPORT_FORMAT.into(),
        key: manifest.key(entry),
        index,
        id: entry.id.clone(),
        input: entry.input.path.clone(),
        output: entry.output.clone(),
        output_size: digest.size,
        output_blake3: digest.blake3,
        summary: StoredSummary::from(&report.summary),
    };
    let mut f = AtomicFile::create(&report_path, &[&input, &output])?;
    serde_json::to_writer(&mut f, &stored).map_err(|e| io_error(&report_path, e.into()))?;
    writeln!(f).map_err(|e| io_error(&report_path, e))?;
    f.commit()?;
    report.input = entry.input.path.clone();
    report.output = entry.output.clone();
    Ok(EntryOutcome {
        skipped: false,
        report,
    })
}

/// Reads a manifest and runs one entry ([`run_entry`] without a shared context): what a job
/// array task or a Dask task calls.
///
/// # Errors
/// As [`Manifest::read`] and [`run_entry`].
pub fn run_manifest_entry(manifest_path: &Path, index: usize, force: bool) -> Result<EntryOutcome> {
    let m = Manifest::read(manifest_path)?;
    run_entry(manifest_path, &m, index, None, force)
}

/// Merges every entry's report, in manifest order, into the survey summary that `lidarqa tpu`
/// writes over the same tiles.
///
/// # Errors
/// [`Error::Manifest`] naming a shared input (trajectory, SMRMSG, sensor file) changed since
/// the plan, or listing the incomplete entries (index and reason, the first few: a tile changed
/// since the plan is one).
pub fn collect(
    manifest_path: &Path,
    manifest: &Manifest,
) -> Result<(TpuSummary, TpuSummaryDocument)> {
    // Reports computed from inputs that changed since the plan describe files no longer there:
    // the shared inputs and every tile are compared with the digests the plan recorded.
    for f in [
        Some(&manifest.trajectory),
        Some(&manifest.sensor),
        manifest.smrmsg.as_ref(),
    ]
    .into_iter()
    .flatten()
    {
        check_unchanged(manifest_path, f)?;
    }
    let mut reports = Vec::with_capacity(manifest.entries.len());
    let mut missing = Vec::new();
    for (i, entry) in manifest.entries.iter().enumerate() {
        if let Err(e) = check_unchanged(manifest_path, &entry.input) {
            missing.push(format!("{i} ({e})"));
            continue;
        }
        match entry_status(manifest_path, manifest, i)? {
            Ok(r) => reports.push(r),
            Err(reason) => missing.push(format!("{i} ({reason})")),
        }
    }
    if !missing.is_empty() {
        let shown: Vec<&str> = missing.iter().take(5).map(String::as_str).collect();
        return Err(manifest_error(
            manifest_path,
            format!(
                "{} of {} entries are not complete: {}{}; run them with lidarqa run",
                missing.len(),
                manifest.entries.len(),
                shown.join(", "),
                if missing.len() > shown.len() {
                    ", …"
                } else {
                    ""
                }
            ),
        ));
    }
    TileReport::merge(&reports).ok_or_else(|| manifest_error(manifest_path, "no entries"))
}
