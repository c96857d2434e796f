//! `lidarqa`: the command-line tool. Argument parsing and wiring only; the work is in the library
//! crates (SPEC §2).

mod cmd;
mod format;
mod progress;

use clap::Parser;
use std::process::ExitCode;

/// lidarqa: how accurate airborne LiDAR points should be, how accurate they are, and how to make them
/// more accurate.
#[derive(Debug, Parser)]
#[command(name = "lidarqa", version, about, long_about = None, propagate_version = true)]
struct Cli {
    /// No progress bars (they are drawn only when stderr is a terminal anyway)
    #[arg(long, short, global = true)]
    quiet: bool,
    #[command(subcommand)]
    command: cmd::Command,
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => return usage_error(e),
    };
    progress::set_quiet(cli.quiet);
    bound_threads();
    match cmd::run(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // A closed pipe (`lidarqa budget … | head`) is not a failure.
            if e.chain().any(|c| {
                c.downcast_ref::<std::io::Error>()
                    .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
            }) {
                return ExitCode::SUCCESS;
            }
            eprintln!("lidarqa: {}", message(&e));
            ExitCode::from(1)
        }
    }
}

/// Most worker threads: four per core (RAYON_NUM_THREADS beyond it gains nothing and, in the
/// thousands, fails to spawn: rayon's global pool would then panic on first use).
fn max_threads() -> usize {
    std::thread::available_parallelism().map_or(1, usize::from) * 4
}

/// Builds the global thread pool from `RAYON_NUM_THREADS` bounded by [`max_threads`], with a
/// warning when it was lowered or unreadable; a pool that cannot be built falls back to one
/// thread rather than panicking later.
fn bound_threads() {
    let cap = max_threads();
    let requested = std::env::var("RAYON_NUM_THREADS").ok();
    let threads = match requested.as_deref().map(str::trim) {
        None | Some("") => 0,
        Some(text) => match text.parse::<usize>() {
            Ok(n) if n <= cap => n,
            Ok(n) => {
                eprintln!(
                    "lidarqa: warning: RAYON_NUM_THREADS={n} is more than {cap} (four per core); \
                     using {cap} (threads_bounded)"
                );
                cap
            }
            Err(_) => {
                eprintln!(
                    "lidarqa: warning: RAYON_NUM_THREADS='{text}' is not a number; using one \
                     thread per core (threads_bounded)"
                );
                0
            }
        },
    };
    if rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build_global()
        .is_err()
    {
        let _ = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build_global();
    }
}

/// The error and its causes on one line, `: `-separated, each said once: the library errors
/// already print their source (`sbet.out: No such file or directory (os error 2)`), which
/// anyhow's chain would otherwise repeat.
fn message(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if out.contains(&text) {
            continue;
        }
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&text);
    }
    out
}

/// clap's own errors: help and version go to stdout with exit 0; a usage error becomes one line and
/// exit code 1 (SPEC §6; clap's default would be 2 and several lines). `lidarqa` (or `lidarqa plan`)
/// without a command prints the help and exits 2, as a shell tool does when it was not told what
/// to do: a script that forgot the command must not pass.
fn usage_error(e: clap::Error) -> ExitCode {
    use clap::error::ErrorKind;
    match e.kind() {
        ErrorKind::DisplayHelp | ErrorKind::DisplayVersion => {
            let _ = e.print();
            ExitCode::SUCCESS
        }
        ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand | ErrorKind::MissingSubcommand => {
            let _ = e.print();
            ExitCode::from(2)
        }
        _ => {
            // The first paragraph of clap's message, folded onto one line.
            let text = e.to_string();
            let first: Vec<&str> = text
                .lines()
                .map(str::trim)
                .skip_while(|l| l.is_empty())
                .take_while(|l| !l.is_empty())
                .collect();
            let first = first.join(" ");
            let first = first.trim_start_matches("error: ");
            eprintln!("lidarqa: {first} (see --help)");
            ExitCode::from(1)
        }
    }
}
