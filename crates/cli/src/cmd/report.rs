//! `lidarqa report DIR`: one self-contained HTML report from the JSON products in a directory.

use anyhow::{Context, Result, bail};
use clap::Args;
use std::path::PathBuf;

pub const AFTER_HELP: &str = "\
Examples:
  lidarqa report lidarqa-demo                 writes lidarqa-demo/report.html
  lidarqa report run1 -o run1-client.html
  lidarqa budget --preset czmil --format json > out/budget.json && lidarqa report out

Reads whatever products DIR holds (budget.json, budget_sweep_*.json, tpu_summary.json,
evaluate_before.json / evaluate_after.json, calibration.json, calibration_iterations.json,
truth.json, overlap_before.json / overlap_after.json, iho.json); a section appears only for the
products present. A malformed product is skipped with a warning (an error with --strict).
The report is one offline HTML file: inline CSS and SVG plots, no script, no network. An existing
report of the same name is replaced, never over a product it reads.";

/// Flags of `lidarqa report`.
#[derive(Debug, Args)]
pub struct ReportArgs {
    /// Directory holding the JSON products of a run.
    #[arg(value_name = "DIR")]
    pub dir: PathBuf,
    /// Output HTML file [default: DIR/report.html].
    #[arg(short, long, value_name = "FILE")]
    pub output: Option<PathBuf>,
    /// Fail on a malformed product instead of skipping its section.
    #[arg(long)]
    pub strict: bool,
}

/// Reads the products, writes the report atomically, and says where it is (on stderr).
pub fn run(args: ReportArgs) -> Result<()> {
    let report = lidarqa_report::Report::from_dir(&args.dir)?;
    if let Some(first) = report.skipped().first()
        && args.strict
    {
        bail!("{first} (--strict)");
    }
    for e in report.skipped() {
        eprintln!("lidarqa: warning: skipped {e}");
    }
    let output = args
        .output
        .unwrap_or_else(|| args.dir.join(lidarqa_report::REPORT_FILE));
    report
        .write(&output)
        .with_context(|| format!("writing the report {}", output.display()))?;
    let present = report.products().present();
    eprintln!(
        "lidarqa: wrote {} ({} product{}{})",
        output.display(),
        present.len(),
        if present.len() == 1 { "" } else { "s" },
        if present.is_empty() {
            ": none found, the report says so".to_string()
        } else {
            format!(": {}", present.join(", "))
        }
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Debug, Parser)]
    struct Cli {
        #[command(flatten)]
        args: ReportArgs,
    }

    #[test]
    fn output_defaults_to_none_and_takes_short_and_long_flags() {
        let c = Cli::try_parse_from(["report", "run1"]).unwrap();
        assert_eq!(c.args.dir, PathBuf::from("run1"));
        assert!(c.args.output.is_none());
        assert!(!c.args.strict);
        let c = Cli::try_parse_from(["report", "run1", "-o", "x.html", "--strict"]).unwrap();
        assert_eq!(c.args.output, Some(PathBuf::from("x.html")));
        assert!(c.args.strict);
        let c = Cli::try_parse_from(["report", "run1", "--output", "y.html"]).unwrap();
        assert_eq!(c.args.output, Some(PathBuf::from("y.html")));
        assert!(Cli::try_parse_from(["report"]).is_err());
    }

    #[test]
    fn writes_the_report_into_the_directory() {
        let dir = tempfile::tempdir().unwrap();
        run(ReportArgs {
            dir: dir.path().to_path_buf(),
            output: None,
            strict: false,
        })
        .unwrap();
        let html = std::fs::read_to_string(dir.path().join("report.html")).unwrap();
        assert!(html.contains("No lidarqa products were found"));
    }

    #[test]
    fn strict_refuses_a_malformed_product_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("budget.json"), "{").unwrap();
        let e = run(ReportArgs {
            dir: dir.path().to_path_buf(),
            output: None,
            strict: true,
        })
        .unwrap_err();
        assert!(format!("{e:#}").contains("budget.json"), "{e:#}");
        assert!(!dir.path().join("report.html").exists());
    }
}
