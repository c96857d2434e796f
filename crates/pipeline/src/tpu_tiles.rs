//! Per-point TPU over several tiles at once: the scheduler behind `lidarqa tpu DIR`.

use crate::error::{Error, Result};
use crate::summary::TileReport;
use crate::tile::{TpuTileJob, tpu_tile};

/// Runs the tiles on up to `available_parallelism` plain threads (lidarqa-io's
/// `on_plain_threads`), each tile's points in parallel on rayon's pool, and returns their
/// reports in input order (each job tells its own progress). Tiles are not run as rayon tasks
/// themselves: `tpu_tile` blocks its thread on its reader / writer channels, and a rayon worker
/// blocked that way could starve the pool its own chunks need. A failing tile stops the run
/// (no further tile starts); tiles already finished are complete files, the failing one leaves
/// nothing.
///
/// # Errors
/// The first failing tile's error; an empty `jobs`.
pub fn tpu_tiles(jobs: &[TpuTileJob<'_>]) -> Result<Vec<TileReport>> {
    if jobs.is_empty() {
        return Err(Error::InvalidOption("no tiles".into()));
    }
    lidarqa_io::on_plain_threads(jobs, |_, job| tpu_tile(job))
}
