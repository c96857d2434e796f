//! Progress bars of the long commands (indicatif): drawn on stderr only when it is a terminal and
//! `--quiet` was not given, so they never reach a pipe, a log file or the JSON on stdout.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};

static QUIET: AtomicBool = AtomicBool::new(false);

/// Records the global `--quiet` flag (called once by `main`).
pub fn set_quiet(quiet: bool) {
    QUIET.store(quiet, Ordering::Relaxed);
}

/// A bar of `total` `unit`s labelled `what` (and the bar's message after it, for a command
/// that says which step it is in); hidden when stderr is not a terminal or `--quiet`.
pub fn bar(what: &str, total: u64, unit: &str) -> ProgressBar {
    if QUIET.load(Ordering::Relaxed) || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
    bar.set_style(
        ProgressStyle::with_template(&format!(
            "{what} [{{elapsed_precise}}] {{wide_bar}} {{human_pos}}/{{human_len}} {unit} ({{per_sec:0}}, eta {{eta}}) {{msg}}"
        ))
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
}

/// The points the files' headers declare, summed: a bar's length (no point is read).
///
/// # Errors
/// A file that cannot be opened or whose header is not LAS, naming it.
pub fn points_in<'a>(
    files: impl IntoIterator<Item = &'a std::path::Path>,
) -> lidarqa_io::Result<u64> {
    files
        .into_iter()
        .map(|p| lidarqa_io::LasReader::from_path(p).map(|r| r.info().point_count))
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quiet_hides_the_bar() {
        set_quiet(true);
        assert!(bar("tpu", 10, "points").is_hidden());
        set_quiet(false);
    }
}
