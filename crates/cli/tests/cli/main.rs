//! The integration tests of the `lidarqa` binary, one module per command or theme, in one test
//! binary (one link, one harness: `binary.rs` runs the built `lidarqa` and checks its refusals).
//!
//! Run one module with `cargo test -p lidarqa --test cli MODULE::`, e.g.
//! `cargo test -p lidarqa --test cli hostile3::`.

mod binary;

use serde::Serialize;
use serde::de::DeserializeOwned;
use serde_json::Value;
use std::path::Path;

mod armo_calibrate;
mod armo_tile;
mod bathymetry;
mod beam_calibrate;
mod beam_truth;
mod budget;
mod calib_independent;
mod calibrate_cut;
mod correct;
mod crs;
mod csd;
mod deliveries;
mod demo;
mod flight_lines;
mod hardening;
mod help_examples;
mod hostile;
mod hostile2;
mod hostile3;
mod manifest;
mod plain_ties;
mod plausibility;
mod qc;
mod sensor;
mod simulate;
mod strip_adjust_independent;
mod targets;
mod titan;
mod tpu;
mod tpu_calibration;
mod trajectory;

/// Whether `a` and `b` have the same keys in the same order and the same values (floats to
/// 1e-15 relative); `at` names the place in a failure.
fn same(a: &Value, b: &Value, at: &str) {
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            let (kx, ky): (Vec<_>, Vec<_>) = (x.keys().collect(), y.keys().collect());
            assert_eq!(kx, ky, "keys of {at}");
            for (k, v) in x {
                same(v, &y[k], &format!("{at}.{k}"));
            }
        }
        (Value::Array(x), Value::Array(y)) => {
            assert_eq!(x.len(), y.len(), "length of {at}");
            for (i, (v, w)) in x.iter().zip(y).enumerate() {
                same(v, w, &format!("{at}[{i}]"));
            }
        }
        (Value::Number(x), Value::Number(y)) if x.is_f64() || y.is_f64() => {
            let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
            assert!(
                (x - y).abs() <= 1e-15 * x.abs().max(y.abs()),
                "{at}: {x} vs {y}"
            );
        }
        _ => assert_eq!(a, b, "{at}"),
    }
}

/// Parses the product at `path` into its lidarqa-products type `T` and writes it back: the same
/// keys in the same order with the same values, so a field the writer has and the type lacks
/// (refused, or dropped by a type that ignores unknown fields), or one the type adds, fails
/// here. Numbers are compared to 1e-15 relative: serde_json's default parser may return a float
/// one unit in the last place off.
pub(crate) fn assert_round_trips<T: DeserializeOwned + Serialize>(path: &Path) {
    let text = std::fs::read_to_string(path).unwrap();
    assert_text_round_trips::<T>(&text, &path.display().to_string());
}

/// [`assert_round_trips`] of a command's JSON output `text` (`what` names it in a failure).
pub(crate) fn assert_text_round_trips<T: DeserializeOwned + Serialize>(text: &str, what: &str) {
    let doc: T =
        serde_json::from_str(text).unwrap_or_else(|e| panic!("{what} does not parse: {e}"));
    let file: Value = serde_json::from_str(text).unwrap();
    same(&file, &serde_json::to_value(&doc).unwrap(), what);
}
