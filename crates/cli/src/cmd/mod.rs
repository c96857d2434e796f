//! One module per subcommand: each parses its flags into a checked plan, calls the libraries and
//! prints.

mod budget;
mod budget_table;
mod calibrate;
mod calibrate_table;
mod collect;
mod correct;
mod demo;
mod evaluate;
mod overlap;
mod plan;
mod qc;
mod report;
mod run;
mod sensor;
mod simulate;
mod targets;
mod tile;
mod tpu;
mod tpu_csd;
mod tpu_flags;
mod tpu_table;
mod trajectory;

use clap::Subcommand;

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// The main job on the built-in survey: simulate, predict, measure, calibrate, correct, measure
    /// again, report.
    #[command(after_help = demo::AFTER_HELP)]
    Demo(demo::DemoArgs),
    /// Error budget of one observation geometry, or a sweep over one variable.
    #[command(after_help = budget::AFTER_HELP)]
    Budget(budget::BudgetArgs),
    /// Extract high-reflectivity targets near control points and fit their centres.
    #[command(after_help = targets::AFTER_HELP)]
    Targets(targets::TargetsArgs),
    /// Accuracy statistics of targets against control (Zhang et al. 2018, ASPRS Ed. 2, NSSDA).
    #[command(after_help = evaluate::AFTER_HELP)]
    Evaluate(evaluate::EvaluateArgs),
    /// Simulate a survey with known truth: strips, trajectory, control, truth.json, sensor.toml.
    #[command(after_help = simulate::AFTER_HELP)]
    Simulate(simulate::SimulateArgs),
    /// Per-point TPU of a LAS/LAZ strip (or a directory of tiles) with its trajectory.
    #[command(after_help = tpu::AFTER_HELP)]
    Tpu(tpu::TpuArgs),
    /// Print a sensor file from the spec-sheet presets (a scanner with a navigation grade), or
    /// list them.
    #[command(after_help = sensor::AFTER_HELP)]
    Sensor(sensor::SensorArgs),
    /// Rebuild the trajectory of strips without one from their multi-return pulses.
    #[command(after_help = trajectory::AFTER_HELP)]
    Trajectory(trajectory::TrajectoryArgs),
    /// HTML report from the JSON products in a directory (one offline file, inline SVG plots).
    #[command(after_help = report::AFTER_HELP)]
    Report(report::ReportArgs),
    /// Boresight + lever-arm self-calibration from overlapping strips (virtual tie point model, Zhang & Jiang 2011).
    #[command(after_help = calibrate::AFTER_HELP)]
    Calibrate(calibrate::CalibrateArgs),
    /// Re-georeference strips with a calibration.
    #[command(after_help = correct::AFTER_HELP)]
    Correct(correct::CorrectArgs),
    /// Swath-to-swath consistency of overlapping strips (RMSDz, dz grid, profile).
    #[command(after_help = overlap::AFTER_HELP)]
    Overlap(overlap::OverlapArgs),
    /// Delivery QC against the standards (USGS LBS 2024, ASPRS 2023, IHO S-44): verdict tables,
    /// qc.json and GeoTIFF rasters.
    #[command(after_help = qc::AFTER_HELP)]
    Qc(qc::QcArgs),
    /// Cut strips into a grid of tiles (input of `lidarqa plan` and `lidarqa tpu DIR`).
    #[command(after_help = tile::AFTER_HELP)]
    Tile(tile::TileArgs),
    /// Write a tile manifest for job arrays and Dask (docs/guide/beyond-one-machine.md).
    #[command(after_help = plan::AFTER_HELP)]
    Plan(plan::PlanArgs),
    /// Run one entry of a tile manifest, skipping it when already complete.
    #[command(after_help = run::AFTER_HELP)]
    Run(run::RunArgs),
    /// Merge a manifest's tile reports into the survey summary.
    #[command(after_help = collect::AFTER_HELP)]
    Collect(collect::CollectArgs),
}

/// Run a parsed subcommand.
pub fn run(command: Command) -> anyhow::Result<()> {
    match command {
        Command::Demo(args) => demo::run(args),
        Command::Budget(args) => budget::run(args),
        Command::Calibrate(args) => calibrate::run(args),
        Command::Correct(args) => correct::run(args),
        Command::Overlap(args) => overlap::run(args),
        Command::Qc(args) => qc::run(args),
        Command::Simulate(args) => simulate::run(&args),
        Command::Targets(args) => targets::run(args),
        Command::Evaluate(args) => evaluate::run(args),
        Command::Tpu(args) => tpu::run(args),
        Command::Trajectory(args) => trajectory::run(args),
        Command::Sensor(args) => sensor::run(args),
        Command::Report(args) => report::run(args),
        Command::Tile(args) => tile::run(args),
        Command::Plan(args) => plan::run(args),
        Command::Run(args) => run::run(args),
        Command::Collect(args) => collect::run(args),
    }
}
