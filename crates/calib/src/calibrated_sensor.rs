//! A sensor with a calibration applied: the calibrated mounting and its covariance replace the
//! sensor file's nominal mounting and mounting σ (SPEC §8; Li et al. 2016, §2), so the TPU predicts
//! with what the calibration actually determined instead of the manufacturer's guess.

use crate::calibrate::mounting_from_json;
use crate::error::{Error, Result};
use crate::params::{PARAM_COUNT, Param};
use lidarqa_model::{Correlation, Sensor, Source};
use nalgebra::DMatrix;
use serde_json::Value;

/// The error source of a mounting parameter (SPEC §4).
fn source_of(p: Param) -> Source {
    match p {
        Param::LeverX => Source::LeverX,
        Param::LeverY => Source::LeverY,
        Param::LeverZ => Source::LeverZ,
        Param::BoresightRoll => Source::BoresightRoll,
        Param::BoresightPitch => Source::BoresightPitch,
        Param::BoresightYaw => Source::BoresightYaw,
    }
}

/// `sensor` with the calibration `doc` (a parsed `calibration.json`) applied:
/// - the mounting is the calibrated one (every parameter, held ones at their prior);
/// - each parameter with a `sigma` takes it (SI) in place of the sensor's; a parameter whose
///   `sigma` is `null` (held, not determined) keeps the sensor file's σ;
/// - the calibration's correlations between the parameters it determined replace any the sensor
///   file had between mounting sources; the sensor's other correlations are kept.
///
/// # Errors
/// [`Error::InvalidCalibration`] naming the key at fault (missing parameters, a σ that is not a
/// finite number ≥ 0, a correlation matrix that is not 6 × 6 or not a valid correlation).
pub fn calibrated_sensor(sensor: &Sensor, doc: &Value) -> Result<Sensor> {
    let bad = |m: String| Error::InvalidCalibration(m);
    let mounting = mounting_from_json(doc)?;
    let sigma_doc = doc
        .get("sigma")
        .and_then(Value::as_object)
        .ok_or_else(|| bad("no \"sigma\" object".into()))?;
    let mut sigma = sensor.sigma;
    let mut determined = [false; PARAM_COUNT];
    for p in Param::ALL {
        match sigma_doc.get(p.key()) {
            None | Some(Value::Null) => {}
            Some(v) => {
                let s = v
                    .as_f64()
                    .filter(|s| s.is_finite() && *s >= 0.0)
                    .ok_or_else(|| bad(format!("sigma.{} must be a number >= 0", p.key())))?;
                sigma = sigma
                    .with(source_of(p), p.from_display(s))
                    .map_err(|e| bad(format!("sigma.{}: {e}", p.key())))?;
                determined[p.index()] = true;
            }
        }
    }
    let rho = read_correlation(doc)?;

    // The sensor's correlations between sources other than the mounting, then the calibration's
    // between the determined parameters; everything else is uncorrelated.
    let mounting_sources: Vec<Source> = Param::ALL.iter().map(|p| source_of(*p)).collect();
    let mut sources: Vec<Source> = sensor
        .correlation
        .as_ref()
        .map(|c| {
            c.sources()
                .iter()
                .copied()
                .filter(|s| !mounting_sources.contains(s))
                .collect()
        })
        .unwrap_or_default();
    let kept = sources.len();
    let params: Vec<Param> = Param::ALL
        .iter()
        .copied()
        .filter(|p| determined[p.index()])
        .collect();
    sources.extend(params.iter().map(|p| source_of(*p)));
    let n = sources.len();
    let matrix = DMatrix::from_fn(n, n, |i, j| {
        if i == j {
            1.0
        } else if i < kept && j < kept {
            sensor
                .correlation
                .as_ref()
                .map_or(0.0, |c| c.between(sources[i], sources[j]))
        } else if i >= kept && j >= kept {
            rho[params[i - kept].index()][params[j - kept].index()].unwrap_or(0.0)
        } else {
            0.0
        }
    });
    let correlation = if n == 0 {
        None
    } else {
        Some(Correlation::new(sources, matrix).map_err(|e| bad(format!("correlation: {e}")))?)
    };
    Ok(Sensor {
        scanner: sensor.scanner.clone(),
        mounting,
        sigma,
        correlation,
    })
}

/// The 6 × 6 `correlation` of calibration.json in parameter order (`null` where held).
fn read_correlation(doc: &Value) -> Result<[[Option<f64>; PARAM_COUNT]; PARAM_COUNT]> {
    let bad = |m: &str| Error::InvalidCalibration(format!("correlation: {m}"));
    let rows = doc
        .get("correlation")
        .and_then(Value::as_array)
        .ok_or_else(|| bad("missing or not an array"))?;
    if rows.len() != PARAM_COUNT {
        return Err(bad("must have 6 rows, in the order of \"parameters\""));
    }
    let mut rho = [[None; PARAM_COUNT]; PARAM_COUNT];
    for (i, row) in rows.iter().enumerate() {
        let row = row
            .as_array()
            .filter(|r| r.len() == PARAM_COUNT)
            .ok_or_else(|| bad("each row must have 6 entries"))?;
        for (j, v) in row.iter().enumerate() {
            rho[i][j] = match v {
                Value::Null => None,
                v => Some(
                    v.as_f64()
                        .filter(|r| r.is_finite())
                        .ok_or_else(|| bad("entries must be numbers or null"))?,
                ),
            };
        }
    }
    Ok(rho)
}

#[cfg(test)]
mod tests {
    use super::*;
    use lidarqa_model::{Mounting, Scanner, Sigmas};
    use serde_json::json;

    fn sensor() -> Sensor {
        let mut sigma = Sigmas::zero();
        for (s, v) in [
            (Source::BoresightRoll, 0.01f64.to_radians()),
            (Source::BoresightPitch, 0.01f64.to_radians()),
            (Source::BoresightYaw, 0.02f64.to_radians()),
            (Source::LeverX, 0.02),
            (Source::LeverY, 0.02),
            (Source::LeverZ, 0.02),
            (Source::Range, 0.01),
        ] {
            sigma = sigma.with(s, v).unwrap();
        }
        Sensor {
            scanner: Scanner::Linear,
            mounting: Mounting::default(),
            sigma,
            correlation: None,
        }
    }

    fn doc() -> Value {
        json!({
            "parameters": {"lever_x_m": 0.05, "lever_y_m": -0.03, "lever_z_m": 0.02,
                "boresight_roll_deg": 0.05, "boresight_pitch_deg": -0.03, "boresight_yaw_deg": 0.0},
            "sigma": {"lever_x_m": 0.004, "lever_y_m": 0.003, "lever_z_m": 0.005,
                "boresight_roll_deg": 0.001, "boresight_pitch_deg": 0.001, "boresight_yaw_deg": null},
            "correlation": [
                [1.0, 0.0, 0.0, 0.0, -0.6, null],
                [0.0, 1.0, 0.0, 0.2, 0.0, null],
                [0.0, 0.0, 1.0, 0.0, 0.0, null],
                [0.0, 0.2, 0.0, 1.0, 0.0, null],
                [-0.6, 0.0, 0.0, 0.0, 1.0, null],
                [null, null, null, null, null, null]]
        })
    }

    #[test]
    fn calibrated_mounting_sigma_and_correlation_replace_the_sensor_files() {
        let s = calibrated_sensor(&sensor(), &doc()).unwrap();
        assert!((s.mounting.boresight_roll_rad - 0.05f64.to_radians()).abs() < 1e-15);
        assert!((s.mounting.lever_arm_m.y + 0.03).abs() < 1e-15);
        assert!((s.sigma.get(Source::BoresightRoll) - 0.001f64.to_radians()).abs() < 1e-15);
        assert!((s.sigma.get(Source::LeverZ) - 0.005).abs() < 1e-15);
        // Held yaw keeps the sensor file's σ; other sources are untouched.
        assert!((s.sigma.get(Source::BoresightYaw) - 0.02f64.to_radians()).abs() < 1e-15);
        assert!((s.sigma.get(Source::Range) - 0.01).abs() < 1e-15);
        let c = s.correlation.unwrap();
        assert_eq!(c.between(Source::LeverX, Source::BoresightPitch), -0.6);
        assert_eq!(c.between(Source::LeverY, Source::BoresightRoll), 0.2);
        assert_eq!(c.between(Source::BoresightYaw, Source::LeverX), 0.0);
    }

    #[test]
    fn a_bad_sigma_or_matrix_names_the_key() {
        let mut d = doc();
        d["sigma"]["lever_y_m"] = json!(-1.0);
        let e = calibrated_sensor(&sensor(), &d).unwrap_err().to_string();
        assert!(e.contains("sigma.lever_y_m"), "{e}");
        let mut d = doc();
        d["correlation"] = json!([[1.0]]);
        let e = calibrated_sensor(&sensor(), &d).unwrap_err().to_string();
        assert!(e.contains("correlation: must have 6 rows"), "{e}");
        let mut d = doc();
        d["correlation"][0][4] = json!(-1.5);
        d["correlation"][4][0] = json!(-1.5);
        let e = calibrated_sensor(&sensor(), &d).unwrap_err().to_string();
        assert!(e.contains("correlation"), "{e}");
    }
}
