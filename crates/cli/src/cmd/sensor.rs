//! `lidarqa sensor`: print a sensor file from the spec-sheet presets (a scanner with a navigation
//! grade), or list them (lidarqa-io's `presets`).

use crate::format::{OutputFormat, print_json, print_text};
use anyhow::{Result, bail};
use clap::Args;
use lidarqa_io::presets::{IMU_PRESETS, SCANNER_PRESETS, preset_sensor_text};
use serde::Serialize;
use std::fmt::Write as _;

pub const AFTER_HELP: &str = "\
Example:
  lidarqa sensor --list
  lidarqa sensor riegl-vux-240 --imu applanix-ap40 > sensor.toml
  lidarqa tpu strip.laz --trajectory sbet.out --sensor sensor.toml -o strip_tpu.laz

Each preset is a commented sensor file: every number names the maker's document and year it
came from, or says it is not published and which conservative value stands in. A scanner comes
with a typical navigation grade; --imu picks another, --imu none leaves the trajectory sigma
out (for a trajectory file that carries its own). Write your installation's boresight and lever
arm into [mounting] from its calibration report.";

/// Flags of `lidarqa sensor`.
#[derive(Debug, Args)]
pub struct SensorArgs {
    /// The scanner preset (see --list).
    #[arg(value_name = "NAME", required_unless_present = "list")]
    name: Option<String>,
    /// The navigation-grade preset combined with the scanner, or `none`.
    #[arg(long, value_name = "NAME")]
    imu: Option<String>,
    /// List the scanner and navigation presets.
    #[arg(long)]
    list: bool,
    /// Output format of --list.
    #[arg(long, value_enum, default_value_t = OutputFormat::Table)]
    format: OutputFormat,
}

#[derive(Serialize)]
struct Listed {
    name: &'static str,
    summary: &'static str,
    #[serde(skip_serializing_if = "Option::is_none")]
    default_imu: Option<&'static str>,
}

#[derive(Serialize)]
struct Listing {
    scanners: Vec<Listed>,
    imus: Vec<Listed>,
}

/// Run `lidarqa sensor`.
pub fn run(a: SensorArgs) -> Result<()> {
    if a.list {
        if a.name.is_some() || a.imu.is_some() {
            bail!("--list takes no preset name and no --imu");
        }
        let listing = Listing {
            scanners: SCANNER_PRESETS
                .iter()
                .map(|p| Listed {
                    name: p.name,
                    summary: p.summary,
                    default_imu: Some(p.default_imu),
                })
                .collect(),
            imus: IMU_PRESETS
                .iter()
                .map(|p| Listed {
                    name: p.name,
                    summary: p.summary,
                    default_imu: None,
                })
                .collect(),
        };
        return match a.format {
            OutputFormat::Json => print_json(&listing),
            OutputFormat::Table => print_text(&table(&listing)),
        };
    }
    let name = a.name.as_deref().unwrap_or_default();
    let text = preset_sensor_text(name, a.imu.as_deref()).map_err(anyhow::Error::msg)?;
    print_text(&text)
}

fn table(l: &Listing) -> String {
    let mut s = String::from("scanners (lidarqa sensor NAME):\n");
    for p in &l.scanners {
        let _ = writeln!(
            s,
            "  {:<24} {}  [--imu {}]",
            p.name,
            p.summary,
            p.default_imu.unwrap_or("")
        );
    }
    s.push_str("navigation grades (--imu NAME, or none):\n");
    for p in &l.imus {
        let _ = writeln!(s, "  {:<24} {}", p.name, p.summary);
    }
    s
}
