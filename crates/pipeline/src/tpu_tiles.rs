//! Per-point TPU over several tiles at once: the scheduler behind `lidarqa tpu DIR`.

use crate::error::{Error, Result};
use crate::summary::TileReport;
use crate::tile::{TpuTileJob, tpu_tile};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// Runs the tiles on up to `available_parallelism` plain threads, each tile's points in
/// parallel on rayon's pool, and returns their reports in input order (each job tells its own
/// progress). Tiles are not run as rayon tasks themselves: `tpu_tile` blocks its thread on its
/// reader / writer channels, and a rayon worker blocked that way could starve the pool its own
/// chunks need. The first failing
/// tile (in input order) stops the run; tiles already finished are complete files, the failing
/// one leaves nothing.
///
/// # Errors
/// The first failing tile's error; an empty `jobs`.
pub fn tpu_tiles(jobs: &[TpuTileJob<'_>]) -> Result<Vec<TileReport>> {
    let Some(first) = jobs.first() else {
        return Err(Error::InvalidOption("no tiles".into()));
    };
    let workers = std::thread::available_parallelism()
        .map_or(1, usize::from)
        .min(jobs.len())
        .max(1);
    let next = AtomicUsize::new(0);
    let stop = AtomicBool::new(false);
    let results: Mutex<Vec<Option<Result<TileReport>>>> =
        Mutex::new(jobs.iter().map(|_| None).collect());
    std::thread::scope(|scope| {
        for _ in 0..workers {
            scope.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::SeqCst);
                    if i >= jobs.len() || stop.load(Ordering::SeqCst) {
                        break;
                    }
                    let r = tpu_tile(&jobs[i]);
                    if r.is_err() {
                        stop.store(true, Ordering::SeqCst);
                    }
                    if let Ok(mut all) = results.lock() {
                        all[i] = Some(r);
                    }
                }
            });
        }
    });
    let internal = |message: &str| Error::Worker {
        path: first.input.to_path_buf(),
        message: message.into(),
    };
    let results = results
        .into_inner()
        .map_err(|_| internal("a tile thread panicked"))?;
    let mut reports = Vec::with_capacity(jobs.len());
    // A tile not started after an earlier failure has no result; the failure is returned.
    for r in results.into_iter().flatten() {
        reports.push(r?);
    }
    if reports.len() != jobs.len() {
        return Err(internal("a tile thread stopped without a result"));
    }
    Ok(reports)
}
