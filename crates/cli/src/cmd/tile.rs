//! `lidarqa tile`: cut strips into a grid of tiles (lidarqa-pipeline's `retile`), the input of
//! `lidarqa plan` and of `lidarqa tpu DIR`.

use anyhow::{Context, Result, bail};
use clap::Args;
use lidarqa_pipeline::{TileGrid, retile};
use std::path::PathBuf;

pub const AFTER_HELP: &str = "\
Example:
  lidarqa simulate --scenario demo -o sim/
  lidarqa tile sim/strip_*.laz --grid 4x4 -o tiles/

The grid covers the strips' extent; each tile holds the points of every strip that fall in it,
with all attributes (GPS time and extra bytes included, as stored), as tile_<column>_<row>.laz
from the south-west. Empty cells write no file. The input strips are never overwritten, and a
strip given twice is refused. A non-empty output directory is refused; with --overwrite the
tiles of an earlier run are replaced, and those the new grid does not write are removed (other
files are kept; point clouds that are not tiles are refused), so `lidarqa tpu DIR` reads only
the new grid.";

/// Flags of `lidarqa tile`.
#[derive(Debug, Args)]
pub struct TileArgs {
    /// Strips (LAS/LAZ) with one CRS, scale, offset, point format and extra-bytes layout.
    #[arg(required = true, value_name = "STRIP")]
    strips: Vec<PathBuf>,
    /// Columns x rows, e.g. 4x4.
    #[arg(long, value_name = "NXxNY", default_value = "4x4", value_parser = parse_grid)]
    grid: TileGrid,
    /// Output directory (created if missing).
    #[arg(short, long, value_name = "DIR")]
    output: PathBuf,
    /// Point-cloud format of the tiles.
    #[arg(long, value_name = "laz|las", default_value = "laz", value_parser = ["laz", "las"])]
    format: String,
    /// Replace the tiles of an earlier run in a non-empty output directory (and remove those
    /// the new grid does not write).
    #[arg(long)]
    overwrite: bool,
}

/// `4x4` → 4 columns, 4 rows.
fn parse_grid(text: &str) -> Result<TileGrid> {
    let (a, b) = text
        .split_once(['x', 'X'])
        .with_context(|| format!("'{text}' is not a grid like 4x4"))?;
    let n = |s: &str| -> Result<usize> {
        let v: usize = s
            .trim()
            .parse()
            .with_context(|| format!("'{text}' is not a grid like 4x4"))?;
        if v == 0 || v > 1000 {
            bail!("'{text}': columns and rows must be 1 to 1000");
        }
        Ok(v)
    };
    Ok(TileGrid {
        nx: n(a)?,
        ny: n(b)?,
    })
}

/// Run `lidarqa tile`.
pub fn run(a: TileArgs) -> Result<()> {
    if a.output.is_file() {
        bail!("{}: the output must be a directory", a.output.display());
    }
    let r = retile(&a.strips, a.grid, &a.output, &a.format, a.overwrite)?;
    eprintln!(
        "lidarqa: {} points in {} tiles ({} empty cells) in {}",
        r.points,
        r.tiles.len(),
        r.empty_cells,
        a.output.display()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_flag() {
        assert_eq!(parse_grid("4x4").unwrap(), TileGrid { nx: 4, ny: 4 });
        assert_eq!(parse_grid("8X2").unwrap(), TileGrid { nx: 8, ny: 2 });
        assert!(parse_grid("4").is_err());
        assert!(parse_grid("0x4").is_err());
        assert!(parse_grid("ax4").is_err());
    }
}
