//! `lidarqa collect`: merge the tile reports of a manifest into the survey summary, the same
//! summary `lidarqa tpu` writes over the same tiles (SPEC §9).

use super::tpu_table::table;
use crate::format::{OutputFormat, print_json, print_text, print_warnings, write_json_file};
use anyhow::Result;
use clap::Args;
use lidarqa_pipeline::{Manifest, collect, resolve};
use std::path::{Path, PathBuf};

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
    let (_, report) = collect(&a.manifest, &manifest)?;
    print_warnings(&report.summary.warnings);
    if let Some(path) = &a.summary {
        let mut inputs: Vec<PathBuf> = vec![a.manifest.clone()];
        inputs.extend(
            manifest
                .entries
                .iter()
                .flat_map(|e| [&e.input.path, &e.output, &e.report])
                .map(|p| resolve(&a.manifest, p)),
        );
        let inputs: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
        write_json_file(path, &report, &inputs)?;
    }
    match a.format {
        OutputFormat::Json => print_json(&report),
        OutputFormat::Table => print_text(&table(&report)),
    }
}
