//! The reader → compute → writer stage loop of `tpu_tile` and `correct_tile`: one home for the
//! threads, the bounded channels and which error a failed run reports.

use crate::error::{Error, Result};
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
