//! `lidarqa run`: run one entry of a tile manifest (what a SLURM array task or a Kubernetes
//! Indexed Job pod calls), skipping it when it is already complete and valid (SPEC §9).

use anyhow::{Context, Result, bail};
use clap::Args;
use lidarqa_pipeline::{Manifest, run_entry};
use std::path::PathBuf;

pub const AFTER_HELP: &str = "\
Examples:
  lidarqa run manifest.json --index 3
  lidarqa run manifest.json     # index from $SLURM_ARRAY_TASK_ID or $JOB_COMPLETION_INDEX

An entry is complete when its tile report exists, was written for this plan, and the output still
has the size and BLAKE3 the report recorded; a complete entry is skipped (--force runs it anyway).
The output is written atomically and the report after it, so a killed run never leaves a tile that
looks complete. An input changed since `lidarqa plan` is refused.

The entry's output and report are replaced when the entry is not complete; a manifest whose
paths leave its directory or name an input is refused.";

/// Environment variables that carry the index of a job array task, in the order tried.
const INDEX_VARIABLES: [&str; 2] = ["SLURM_ARRAY_TASK_ID", "JOB_COMPLETION_INDEX"];

/// Flags of `lidarqa run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// The manifest from `lidarqa plan`.
    #[arg(value_name = "MANIFEST")]
    manifest: PathBuf,
    /// The entry to run (default: $SLURM_ARRAY_TASK_ID, else $JOB_COMPLETION_INDEX).
    #[arg(long, value_name = "N")]
    index: Option<usize>,
    /// Run the entry even when it is complete.
    #[arg(long)]
    force: bool,
}

/// The index from the flag or the job array's environment.
fn index_of(flag: Option<usize>, env: impl Fn(&str) -> Option<String>) -> Result<usize> {
    if let Some(i) = flag {
        return Ok(i);
    }
    for name in INDEX_VARIABLES {
        if let Some(v) = env(name) {
            return v
                .trim()
                .parse()
                .with_context(|| format!("${name}: '{v}' is not an entry index"));
        }
    }
    bail!("--index is missing and neither $SLURM_ARRAY_TASK_ID nor $JOB_COMPLETION_INDEX is set")
}

/// Run `lidarqa run`.
pub fn run(a: RunArgs) -> Result<()> {
    let index = index_of(a.index, |k| std::env::var(k).ok())?;
    let manifest = Manifest::read(&a.manifest)?;
    let outcome = run_entry(&a.manifest, &manifest, index, None, a.force)?;
    let s = &outcome.report.summary;
    eprintln!(
        "lidarqa: entry {index} {}: {} -> {} ({} points read, {} written)",
        if outcome.skipped {
            "skipped (already complete)"
        } else {
            "done"
        },
        outcome.report.input.display(),
        outcome.report.output.display(),
        s.points_read,
        s.points_written
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_from_flag_then_slurm_then_kubernetes() {
        let none = |_: &str| None;
        assert_eq!(index_of(Some(4), none).unwrap(), 4);
        assert!(index_of(None, none).is_err());
        let slurm = |k: &str| (k == "SLURM_ARRAY_TASK_ID").then(|| "7".to_string());
        assert_eq!(index_of(None, slurm).unwrap(), 7);
        let k8s = |k: &str| (k == "JOB_COMPLETION_INDEX").then(|| "2\n".to_string());
        assert_eq!(index_of(None, k8s).unwrap(), 2);
        let bad = |k: &str| (k == "JOB_COMPLETION_INDEX").then(|| "x".to_string());
        let e = format!("{:#}", index_of(None, bad).unwrap_err());
        assert!(e.contains("$JOB_COMPLETION_INDEX: 'x'"), "{e}");
    }
}
