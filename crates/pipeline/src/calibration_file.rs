//! The one reader of `calibration.json` (its format: `docs/reference/formats.md`): the
//! calibrated mounting `correct` applies, the strip adjustment's per-line corrections, and the
//! refusals of values no adjustment stands behind (held parameters edited by hand, values and σ
//! outside physical ranges). `TpuContext::with_calibration` reads the file through it too.

use crate::error::{Error, Result};
use lidarqa_model::Mounting;
use std::path::Path;

/// The text of a `calibration.json` (SPEC §8) as JSON, for [`lidarqa_calib::mounting_from_json`]
/// and [`lidarqa_calib::calibrated_sensor`]: the one reader of the file.
pub(crate) fn read_calibration_json(path: &Path) -> Result<serde_json::Value> {
    let fail = |m: String| Error::Calib {
        path: path.to_path_buf(),
        source: lidarqa_calib::Error::InvalidCalibration(m),
    };
    let text = std::fs::read_to_string(path).map_err(|e| fail(format!("cannot read: {e}")))?;
    serde_json::from_str(&text).map_err(|e| fail(format!("not JSON: {e}")))
}

/// The calibrated mounting of the `calibration.json` at `path` (what `lidarqa correct` and the
/// Python `correct_tile` apply).
///
/// # Errors
/// [`Error::Calib`] naming the file when it cannot be read, is not JSON or lacks a parameter.
pub fn read_calibrated_mounting(path: &Path) -> Result<Mounting> {
    let doc = read_calibration_json(path)?;
    check_calibration_values(path, &doc)?;
    lidarqa_calib::mounting_from_json(&doc).map_err(|source| Error::Calib {
        path: path.to_path_buf(),
        source,
    })
}

/// Refuses a `calibration.json` whose held parameters (σ `null`: not estimated, so kept at the
/// prior) differ from `prior`, the sensor file's mounting the strips were made with: a value
/// edited by hand that no adjustment stands behind (a boresight of 5° with σ `null` would move
/// the points by metres, unchecked against any σ).
///
/// # Errors
/// [`Error::Calib`] naming the key, both values and the likely cause.
pub fn check_held_parameters(path: &Path, prior: &Mounting) -> Result<()> {
    let doc = read_calibration_json(path)?;
    let (Some(params), Some(sigma)) = (
        doc.get("parameters").and_then(serde_json::Value::as_object),
        doc.get("sigma").and_then(serde_json::Value::as_object),
    ) else {
        return Ok(());
    };
    let prior = lidarqa_calib::mounting_to_vector(prior);
    for p in lidarqa_calib::Param::ALL {
        let key = p.key();
        let (Some(v), Some(serde_json::Value::Null)) = (
            params.get(key).and_then(serde_json::Value::as_f64),
            sigma.get(key),
        ) else {
            continue;
        };
        let was = p.to_display(prior[p.index()]);
        // The file stores the prior as printed: a rounding's worth of difference is the same.
        let tolerance = 1e-6 * (1.0 + was.abs());
        if (v - was).abs() > tolerance {
            return Err(Error::Calib {
                path: path.to_path_buf(),
                source: lidarqa_calib::Error::InvalidCalibration(format!(
                    "parameters.{key} is {v} but sigma.{key} is null (held: not estimated), so it \
                     must be the sensor file's value {was}: a value edited by hand? give it the σ \
                     it was determined with, or calibrate again"
                )),
            });
        }
    }
    Ok(())
}

/// The strip adjustment's per-line corrections of the `calibration.json` at `path`
/// (`strip_adjustment.lines`), each with its point source id (which, with its time span, tells
/// its points: [`crate::correct_tile_with_lines`]) and the stem of its file when it lies in
/// one; empty when the calibration has none. A calibration written before lines were named by
/// point source id gives `None` there (its lines are matched to files by their stem).
///
/// # Errors
/// [`Error::Calib`] naming the file and the key when a line cannot be read.
pub fn read_line_corrections(path: &Path) -> Result<Vec<(crate::LineMatch, Option<String>)>> {
    let doc = read_calibration_json(path)?;
    let Some(lines) = doc
        .pointer("/strip_adjustment/lines")
        .and_then(|v| v.as_array())
    else {
        return Ok(Vec::new());
    };
    let bad = |m: String| Error::Calib {
        path: path.to_path_buf(),
        source: lidarqa_calib::Error::InvalidCalibration(m),
    };
    lines
        .iter()
        .enumerate()
        .map(|(k, v)| {
            let line = lidarqa_calib::LineCorrection::from_json(v)
                .map_err(|m| bad(format!("strip_adjustment.lines[{k}].{m}")))?;
            let file = v.get("file").and_then(|f| f.as_str()).map(str::to_string);
            let point_source_id = match v.get("point_source_id") {
                None | Some(serde_json::Value::Null) => None,
                Some(id) => Some(id.as_u64().and_then(|i| u16::try_from(i).ok()).ok_or_else(
                    || {
                        bad(format!(
                            "strip_adjustment.lines[{k}].point_source_id: {id} is not a \
                                 point source id (0–65535)"
                        ))
                    },
                )?),
            };
            Ok((
                crate::LineMatch {
                    correction: line,
                    point_source_id,
                },
                file,
            ))
        })
        .collect()
}

/// A calibration's values and σ against physical ranges (the sensor file's, lidarqa-io's
/// [`lidarqa_io::mounting_implausible`] and [`lidarqa_io::sigma_limit`]): a lever arm of 500 m, a
/// boresight of 180° or a σ of 1e6 m is refused, naming the key and the likely slip.
pub(crate) fn check_calibration_values(path: &Path, doc: &serde_json::Value) -> Result<()> {
    let fail = |m: String| Error::Calib {
        path: path.to_path_buf(),
        source: lidarqa_calib::Error::InvalidCalibration(m),
    };
    if let Ok(m) = lidarqa_calib::mounting_from_json(doc)
        && let Some(message) = lidarqa_io::mounting_implausible(&m, "parameters.")
    {
        return Err(fail(message));
    }
    if let Some(sigma) = doc.get("sigma").and_then(serde_json::Value::as_object) {
        for (key, v) in sigma {
            if let (Some(v), Some((limit, slip))) = (v.as_f64(), lidarqa_io::sigma_limit(key))
                && v > limit
            {
                return Err(fail(format!(
                    "sigma.{key}: a σ of {v} is more than {limit}: {slip}"
                )));
            }
        }
    }
    Ok(())
}
