//! Output helpers shared by the subcommands: `--format`, JSON to stdout, fixed-width tables.

use anyhow::Context as _;
use lidarqa_io::AtomicFile;
use std::io::Write;
use std::path::Path;

/// `--format`: a table for people (default) or JSON for programs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum OutputFormat {
    /// Aligned text for people.
    #[default]
    Table,
    /// One JSON object, stable field names (docs/reference/formats.md).
    Json,
}

/// Print one JSON value (pretty) to stdout. Every JSON summary has `warnings` (SPEC §7): an
/// object without the key gets an empty list (commands with findings put theirs in).
pub fn print_json(value: &impl serde::Serialize) -> anyhow::Result<()> {
    let mut value = serde_json::to_value(value)?;
    if let Some(map) = value.as_object_mut() {
        map.entry("warnings")
            .or_insert_with(|| serde_json::Value::Array(Vec::new()));
    }
    let mut out = std::io::stdout().lock();
    serde_json::to_writer_pretty(&mut out, &value)?;
    writeln!(out)?;
    Ok(())
}

/// Print text to stdout (errors such as a closed pipe are returned, not panicked on).
pub fn print_text(text: &str) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())?;
    out.flush()?;
    Ok(())
}

/// Metres as centimetres with two decimals, right-aligned in `width`.
pub fn cm(v: f64, width: usize) -> String {
    format!("{:>width$.2}", v * 100.0)
}

/// The six components of `a` (north, east, up, horizontal, vertical, 3-D) as [`cm`] columns of
/// `width`: the centimetre row of every σ table.
pub fn axes_cm(a: &lidarqa_model::Axes, width: usize) -> String {
    [a.north, a.east, a.up, a.horizontal, a.vertical, a.three_d]
        .map(|v| cm(v, width))
        .concat()
}

/// Print each warning to stderr, one line each (SPEC §7).
pub fn print_warnings(warnings: &[lidarqa_model::Warning]) {
    for w in warnings {
        eprintln!("lidarqa: warning: {} ({})", w.message, w.code);
    }
}

/// Write `value` as pretty JSON (one final newline) to `path` atomically (temporary file, then
/// rename); an output that is one of `inputs` is refused.
pub fn write_json_file<P: AsRef<Path>>(
    path: &Path,
    value: &impl serde::Serialize,
    inputs: &[P],
) -> anyhow::Result<()> {
    let mut f = AtomicFile::create(path, inputs)?;
    serde_json::to_writer_pretty(&mut f, value).with_context(|| format!("{}", path.display()))?;
    writeln!(f).with_context(|| format!("{}", path.display()))?;
    f.commit()?;
    Ok(())
}
