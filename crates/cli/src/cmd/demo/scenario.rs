//! The demo scenarios: the built-in ones with the demo's seed, fewer pulses with `--quick`,
//! written beside the products so that the `simulate` step reads an ordinary file.

use anyhow::{Context, Result, bail};
use std::path::{Path, PathBuf};

/// The demo scenario, 80 % of the pulses with `--quick`, its trajectory errors' correlation
/// times (GNSS, attitude; s), which the calibration is told as a user reads them from the
/// navigation processing report, and its number of flight lines (one strip each).
pub(super) fn topographic(
    dir: &Path,
    quick: bool,
    seed: u64,
) -> Result<(PathBuf, [String; 2], usize)> {
    let text = lidarqa_sim::builtin_toml("demo").context("the built-in demo scenario")?;
    let mut table: toml::Table = toml::from_str(text).context("the built-in demo scenario")?;
    let tau = |key: &str| {
        table
            .get("errors")
            .and_then(|e| e.get(key))
            .and_then(toml::Value::as_float)
            .map(|v| v.to_string())
            .with_context(|| format!("the built-in demo scenario: errors.{key}"))
    };
    let taus = [
        tau("gnss_correlation_time_s")?,
        tau("attitude_correlation_time_s")?,
    ];
    let lines = table
        .get("lines")
        .and_then(toml::Value::as_array)
        .map_or(0, Vec::len);
    if lines == 0 {
        bail!("the built-in demo scenario has no [[lines]]");
    }
    table.insert("seed".into(), toml::Value::Integer(seed as i64));
    line_errors(&mut table)?;
    if quick {
        // Not half: at half the pulses the automatic ties no longer determine boresight yaw
        // (held at its prior, not observable).
        scale_pulse_rate(&mut table, "demo", 0.8)?;
    }
    let path = dir.join("scenario.toml");
    std::fs::write(&path, toml::to_string(&table)?)
        .with_context(|| format!("{}", path.display()))?;
    Ok((path, taus, lines))
}

/// σ of each line's own GNSS error in the demo (`[errors] line_*`): offset and drift (north,
/// east, up; m). Several times the sensor file's GNSS σ (1 / 1 / 2 cm), as real surveys carry
/// them: what the strip adjustment estimates and a calibration of the mounting alone cannot
/// correct. No attitude offset beyond the scenario's own (its 20 s correlation time already
/// makes each 9 s line's attitude error nearly constant): a line's pitch offset is its own
/// boresight pitch, and 0.003° more per line moved boresight pitch 0.006° off in both runs.
const LINE_ERRORS: [(&str, [f64; 3]); 2] = [
    ("line_gnss_offset_m", [0.03, 0.03, 0.03]),
    ("line_gnss_drift_m", [0.02, 0.02, 0.02]),
];

/// Sets [`LINE_ERRORS`] in the scenario's `[errors]`.
fn line_errors(table: &mut toml::Table) -> Result<()> {
    let errors = table
        .get_mut("errors")
        .and_then(toml::Value::as_table_mut)
        .context("the built-in demo scenario: no [errors]")?;
    for (key, v) in LINE_ERRORS {
        errors.insert(
            key.into(),
            toml::Value::Array(v.iter().map(|x| toml::Value::Float(*x)).collect()),
        );
    }
    Ok(())
}

/// The built-in bathymetry scenario with the demo's seed, half the pulses with `--quick`.
pub(super) fn bathymetry(dir: &Path, quick: bool, seed: u64) -> Result<PathBuf> {
    let text =
        lidarqa_sim::builtin_toml("bathymetry").context("the built-in bathymetry scenario")?;
    let mut table: toml::Table =
        toml::from_str(text).context("the built-in bathymetry scenario")?;
    table.insert("seed".into(), toml::Value::Integer(seed as i64));
    if quick {
        scale_pulse_rate(&mut table, "bathymetry", 0.5)?;
    }
    let path = dir.join("scenario.toml");
    std::fs::write(&path, toml::to_string(&table)?)
        .with_context(|| format!("{}", path.display()))?;
    Ok(path)
}

/// `--quick`: the built-in scenario `name` at `factor` times its pulse rate.
fn scale_pulse_rate(table: &mut toml::Table, name: &str, factor: f64) -> Result<()> {
    let scanner = table
        .get_mut("scanner")
        .and_then(toml::Value::as_table_mut)
        .with_context(|| format!("the built-in {name} scenario: no [scanner]"))?;
    let rate = scanner
        .get("pulse_rate_hz")
        .and_then(toml::Value::as_float)
        .with_context(|| format!("the built-in {name} scenario: scanner.pulse_rate_hz"))?;
    scanner.insert("pulse_rate_hz".into(), toml::Value::Float(rate * factor));
    Ok(())
}
