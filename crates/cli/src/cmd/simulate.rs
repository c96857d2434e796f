//! `lidarqa simulate`: write a simulated survey with known truth.
//!
//! Parses the flags, builds the checked scenario, and simulates and writes the survey as it is
//! computed with [`lidarqa_sim::simulate_to_dir`] (one LAS/LAZ per strip, `sbet.out` + `smrmsg.out`, `control.csv`,
//! `truth.json`, `sensor.toml`; every file atomic).

use anyhow::Context;
use lidarqa_sim::{Progress, Scenario, SimOptions, builtin_toml, simulate_to_dir};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Example shown after `lidarqa simulate --help`.
pub const AFTER_HELP: &str = "\
Examples:
  lidarqa simulate --scenario demo -o sim/
  lidarqa simulate --scenario calibration --print > my-survey.toml
  lidarqa simulate --scenario my-survey.toml --seed 7 --format las -o sim7/
  lidarqa simulate --scenario bathymetry --truth -o bathy/   # + each point's actual error

Built-in scenarios: demo, calibration, bathymetry, forest.

Files of the same name in the output directory are replaced; an output that is an input
(--scenario) is refused.";

/// Point-cloud output format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum CloudFormat {
    /// Compressed LAZ.
    Laz,
    /// Uncompressed LAS 1.4.
    Las,
}

/// Flags of `lidarqa simulate`.
#[derive(Debug, clap::Args)]
pub struct SimulateArgs {
    /// Built-in scenario (demo, calibration, bathymetry, forest) or a scenario TOML file.
    #[arg(long, value_name = "NAME|FILE", default_value = "demo")]
    pub scenario: String,
    /// Print the scenario as TOML (a starting point for your own) and exit.
    #[arg(long)]
    pub print: bool,
    /// Output directory (created if missing).
    #[arg(
        short = 'o',
        long = "output",
        value_name = "DIR",
        default_value = "lidarqa-sim"
    )]
    pub output: PathBuf,
    /// Seed of every random draw (overrides the scenario's).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Point-cloud format of the strips.
    #[arg(long, value_enum, default_value_t = CloudFormat::Laz)]
    pub format: CloudFormat,
    /// Also write each point's actual error, lidar − true, as extra bytes `error_x`, `error_y`,
    /// `error_z` (f32 metres along the projected x, y and up axes, of the coordinates as stored),
    /// so any TPU can be scored against the truth point by point.
    #[arg(long)]
    pub truth: bool,
}

/// Reads the scenario named by `--scenario` (built-in name first, then a file), with the seed
/// override; also returns its text for `--print`.
fn load(args: &SimulateArgs) -> anyhow::Result<(Scenario, String)> {
    let (text, origin) = match builtin_toml(&args.scenario) {
        Some(t) => (
            t.to_string(),
            format!("built-in scenario {}", args.scenario),
        ),
        None => {
            let path = Path::new(&args.scenario);
            let text = std::fs::read_to_string(path).with_context(|| {
                format!(
                    "{}: not a built-in scenario (demo, calibration, bathymetry, forest) and not a readable file",
                    path.display()
                )
            })?;
            (text, path.display().to_string())
        }
    };
    let mut scenario = Scenario::from_toml_str(&text).with_context(|| origin.clone())?;
    if let Some(seed) = args.seed {
        scenario = scenario.with_seed(seed);
    }
    // A built-in without overrides prints with its comments; anything else as re-serialised.
    let printable = if args.seed.is_none() {
        text
    } else {
        scenario.to_toml_string()
    };
    Ok((scenario, printable))
}

/// Run `lidarqa simulate`.
///
/// # Errors
/// A one-line message naming the scenario key or the output file at fault.
pub fn run(args: &SimulateArgs) -> anyhow::Result<()> {
    let (scenario, text) = load(args)?;
    if args.print {
        let mut out = std::io::stdout().lock();
        out.write_all(text.as_bytes())?;
        return out.flush().map_err(Into::into);
    }
    let dir = &args.output;
    std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create", dir.display()))?;

    let bar = crate::progress::bar("simulating", scenario.pulse_count(), "pulses");
    let progress = |n| bar.inc(n);
    let options = SimOptions {
        keep_truth: args.truth,
        progress: Progress::new(&progress),
        ..SimOptions::default()
    };
    // SPEC §7: an output equal to an input (a scenario file kept in the output directory under
    // an output's name) is refused before anything is written.
    let scenario_path = Path::new(&args.scenario);
    let inputs: &[&Path] = if builtin_toml(&args.scenario).is_none() {
        std::slice::from_ref(&scenario_path)
    } else {
        &[]
    };
    let (survey, _) = simulate_to_dir(
        dir,
        &scenario,
        &options,
        args.format == CloudFormat::Laz,
        inputs,
    )
    .map_err(|e| match e {
        lidarqa_sim::Error::Io(e) => anyhow::Error::new(e),
        e => anyhow::Error::new(e).context(format!("scenario {}", scenario.name())),
    })?;
    bar.finish_and_clear();
    println!(
        "wrote {} points in {} strips ({} pulses), sbet.out, smrmsg.out, control.csv ({} targets), truth.json and sensor.toml to {}",
        survey.point_count(),
        survey.strips.len(),
        scenario.pulse_count(),
        survey.control.len(),
        dir.display()
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
        args: SimulateArgs,
    }

    #[test]
    fn flags_parse() {
        let cli = Cli::try_parse_from([
            "simulate",
            "--scenario",
            "calibration",
            "-o",
            "out",
            "--seed",
            "9",
            "--format",
            "las",
        ])
        .unwrap();
        assert_eq!(cli.args.scenario, "calibration");
        assert_eq!(cli.args.output, PathBuf::from("out"));
        assert_eq!(cli.args.seed, Some(9));
        assert_eq!(cli.args.format, CloudFormat::Las);
        assert!(!cli.args.print);
        assert!(Cli::try_parse_from(["simulate", "--format", "ply"]).is_err());
    }
}
