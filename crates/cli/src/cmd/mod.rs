//! One module per subcommand: each parses its flags into a checked plan, calls the libraries and
//! prints.

mod budget;
mod evaluate;
mod report;
mod simulate;
mod targets;
mod tpu;

use clap::Subcommand;

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Error budget of one observation geometry, or a sweep over one variable.
    #[command(after_help = budget::AFTER_HELP)]
    Budget(budget::BudgetArgs),
    /// Extract high-reflectivity targets near control points and fit their centres.
    #[command(after_help = targets::AFTER_HELP)]
    Targets(targets::TargetsArgs),
    /// Accuracy statistics of targets against control (seed 000, ASPRS Ed. 2, NSSDA).
    #[command(after_help = evaluate::AFTER_HELP)]
    Evaluate(evaluate::EvaluateArgs),
    /// Simulate a survey with known truth: strips, trajectory, control, truth.json, sensor.toml.
    #[command(after_help = simulate::AFTER_HELP)]
    Simulate(simulate::SimulateArgs),
    /// Per-point TPU of a LAS/LAZ strip (or a directory of tiles) with its trajectory.
    #[command(after_help = tpu::AFTER_HELP)]
    Tpu(tpu::TpuArgs),
    /// HTML report from the JSON products in a directory (one offline file, inline SVG plots).
    #[command(after_help = report::AFTER_HELP)]
    Report(report::ReportArgs),
}

/// Run a parsed subcommand.
pub fn run(command: Command) -> anyhow::Result<()> {
    match command {
        Command::Budget(args) => budget::run(args),
        Command::Simulate(args) => simulate::run(&args),
        Command::Targets(args) => targets::run(args),
        Command::Evaluate(args) => evaluate::run(args),
        Command::Tpu(args) => tpu::run(args),
        Command::Report(args) => report::run(args),
    }
}
