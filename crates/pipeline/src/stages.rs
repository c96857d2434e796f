//! The reader → compute → writer stage loop of `tpu_tile` and `correct_tile`: one home for the
//! threads, the bounded channels, the reader's and the writer's loops, and which error a failed
//! run reports.

use crate::error::{Error, Result};
use lidarqa_io::{LasReader, LasWriter, RawChunk};
use std::path::Path;
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};

/// What the compute stage hands the writer.
pub(crate) enum WriteMsg<W> {
    /// One computed chunk.
    Chunk(W),
    /// Everything was computed: commit the output. Any other end drops the temporary file.
    Finish,
}

/// Runs `read` and `write` on their own threads and `compute` on the calling one (which uses
/// rayon), joined by channels holding one item each, so memory is a few chunks whatever the
/// file size and decoding, computing and encoding overlap. `write` returns `Some(points)` after
/// a commit, `None` when its channel closed without [`WriteMsg::Finish`].
///
/// Errors, in this order: a panicked writer thread; the writer's own error (when the compute
/// stage only saw its channel close, the writer's error is the cause); the compute stage's
/// (which carries the reader's, sent through the channel).
pub(crate) fn run_stages<R: Send, W: Send>(
    path: &Path,
    read: impl FnOnce(SyncSender<Result<R>>) + Send,
    write: impl FnOnce(Receiver<WriteMsg<W>>) -> Result<Option<u64>> + Send,
    compute: impl FnOnce(&Receiver<Result<R>>, &SyncSender<WriteMsg<W>>) -> Result<()>,
) -> Result<u64> {
    std::thread::scope(|scope| {
        let (tx_read, rx_read) = sync_channel::<Result<R>>(1);
        let (tx_write, rx_write) = sync_channel::<WriteMsg<W>>(1);
        let reader_thread = scope.spawn(move || read(tx_read));
        let writer_thread = scope.spawn(move || write(rx_write));
        let main = compute(&rx_read, &tx_write);
        if main.is_ok() {
            let _ = tx_write.send(WriteMsg::Finish);
        }
        drop(tx_write);
        drop(rx_read);
        let written = writer_thread.join();
        let _ = reader_thread.join();
        let worker = |what: &str| Error::Worker {
            path: path.to_path_buf(),
            message: format!("the {what} thread panicked"),
        };
        match (main, written) {
            (_, Err(_)) => Err(worker("writer")),
            (_, Ok(Err(e))) => Err(e),
            (Err(e), _) => Err(e),
            (Ok(()), Ok(Ok(Some(points)))) => Ok(points),
            (Ok(()), Ok(Ok(None))) => Err(worker("writer")),
        }
    })
}

/// The reader stage: opens `input` on its own thread (las's reader is not `Send`), fills chunks of
/// up to `chunk_points` records (the spare ones a later stage hands back on `spares`, new ones
/// when none is there) and sends each. Stops at the end of the file, at a read error (sent on,
/// so that the compute stage reports it as the cause), or when the compute stage has hung up.
pub(crate) fn read_chunks(
    input: &Path,
    chunk_points: usize,
    spares: &Receiver<RawChunk>,
    tx: &SyncSender<Result<RawChunk>>,
) {
    let mut reader = match LasReader::from_path(input) {
        Ok(r) => r,
        Err(e) => {
            let _ = tx.send(Err(e.into()));
            return;
        }
    };
    loop {
        let mut chunk = spares.try_recv().unwrap_or_default();
        match reader.fill_raw(&mut chunk, chunk_points) {
            Err(e) => {
                let _ = tx.send(Err(e.into()));
                return;
            }
            Ok(0) => return,
            Ok(_) => {}
        }
        if tx.send(Ok(chunk)).is_err() {
            return;
        }
    }
}

/// The writer stage: hands each computed chunk to `write` and commits `writer` on
/// [`WriteMsg::Finish`]. Returns `Some(points)` after the commit, `None` when the channel closed
/// without it (the temporary file is then dropped, nothing is left at the output).
pub(crate) fn write_chunks<W>(
    mut writer: LasWriter,
    rx: Receiver<WriteMsg<W>>,
    mut write: impl FnMut(&mut LasWriter, W) -> Result<()>,
) -> Result<Option<u64>> {
    for msg in rx {
        match msg {
            WriteMsg::Chunk(chunk) => write(&mut writer, chunk)?,
            WriteMsg::Finish => return Ok(Some(writer.finish()?)),
        }
    }
    Ok(None)
}
