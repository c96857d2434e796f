//! One module per subcommand: each parses its flags into a checked plan, calls the libraries and
//! prints.

mod budget;

use clap::Subcommand;

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Error budget of one observation geometry, or a sweep over one variable.
    #[command(after_help = budget::AFTER_HELP)]
    Budget(budget::BudgetArgs),
}

/// Run a parsed subcommand.
pub fn run(command: Command) -> anyhow::Result<()> {
    match command {
        Command::Budget(args) => budget::run(args),
    }
}
