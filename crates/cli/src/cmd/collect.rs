//! `lidarqa collect`: merge the tile reports of a manifest into the survey summary, the same
//! summary `lidarqa tpu` writes over the same tiles (SPEC §9).

use super::tpu_table::table;
use crate::format::{OutputFormat, print_json, print_text, print_warnings, write_json_file};
use anyhow::Result;
use clap::Args;
use lidarqa_pipeline::{Manifest, collect, resolve};
use std::path::PathBuf;

pub const AFTER_HELP: &str = "\
Example:
  lidarqa collect manifest.json --summary summary.json

Fails, listing the entries, when any entry is not complete (run them with `lidarqa run`).

An existing --summary file is replaced, never an input.";

/// Flags of `lidarqa collect`.
#[derive(Debug, Args)]
pub struct CollectArgs {
    /// The manifest from `lidarqa plan`.
    #[arg(value_name = "MANIFEST")]
    manifest: PathBuf,
    /// Also write the summary as JSON to this file (the JSON of `lidarqa tpu --summary`).
    #[arg(long, value_name = "FILE")]
    summary: Option<PathBuf>,
    /// Output format of the summary on stdout.
    #[arg(long, value_enum, default_value_t = OutputFormat::Table)]
    format: OutputFormat,
}

/// Run `lidarqa collect`.
pub fn run(a: CollectArgs) -> Result<()> {
    let manifest = Manifest::read(&a.manifest)?;
    let mut inputs: Vec<PathBuf> = Vec::new();
    if let Some(path) = &a.summary {
        // Before any work: the summary may be none of the files the manifest names (its shared
        // inputs, the tiles, their outputs and reports) nor the manifest itself.
        inputs.push(a.manifest.clone());
        inputs.extend(
            [&manifest.trajectory, &manifest.sensor]
                .into_iter()
                .chain(manifest.smrmsg.as_ref())
                .map(|f| resolve(&a.manifest, &f.path)),
        );
        inputs.extend(
            manifest
                .entries
                .iter()
                .flat_map(|e| [&e.input.path, &e.output, &e.report])
                .map(|p| resolve(&a.manifest, p)),
        );
        lidarqa_io::check_outputs(&[path], &inputs)?;
    }
    let (_, report) = collect(&a.manifest, &manifest)?;
    print_warnings(&report.warnings);
    if let Some(path) = &a.summary {
        write_json_file(path, &report, &inputs)?;
    }
    match a.format {
        OutputFormat::Json => print_json(&report),
        OutputFormat::Table => print_text(&table(&report)),
    }
}
