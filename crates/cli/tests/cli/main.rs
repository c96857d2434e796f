//! The integration tests of the `lidarqa` binary, one module per command or theme, in one test
//! binary (one link, one harness: `binary.rs` runs the built `lidarqa` and checks its refusals).
//!
//! Run one module with `cargo test -p lidarqa --test cli MODULE::`, e.g.
//! `cargo test -p lidarqa --test cli hostile3::`.

mod binary;

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
