//! The stages every streaming command is built from, so that the threads, the bounded
//! channels, the buffers' reuse and which error a failed run reports live in one place:
//! a reader stage ([`read_chunks`]: the chunks of one or several LAS/LAZ files, decoded on their
//! own thread), a compute stage (the caller's, per chunk, on the calling thread with rayon) and
//! a writer stage ([`write_chunks`]: one output, encoded on its own thread, committed only when
//! everything was computed). [`run_stages`] joins all three, [`for_each_chunk`] the first two
//! for a pass that only reads. They are generic over the caller's error type, which converts
//! from this crate's [`Error`]. [`Progress`] is the optional callback a job carries, so that a
//! command is one function whether or not a bar is drawn.
//!
//! Call the stages from a plain thread, never from a rayon task: the compute stage blocks its
//! thread on a channel, and the reader's LAZ decoding runs on rayon's workers, so workers
//! blocked in compute stages can leave no worker to decode for them (pipeline's `tpu_tiles`
//! and calibrate's first passes run their files on plain threads, [`on_plain_threads`], for
//! this reason).

use crate::{Error, LasReader, LasWriter, PointChunk, RawChunk, Result};
use std::fmt;
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::sync::{Mutex, PoisonError};

/// An optional callback told how far a run has come (`T`: points or pulses done since the last
/// call, or a step of a longer run), from any thread. The default tells nobody.
///
/// ```
/// use lidarqa_io::Progress;
/// use std::sync::atomic::{AtomicU64, Ordering};
///
/// let done = AtomicU64::new(0);
/// let count = |n: u64| {
///     done.fetch_add(n, Ordering::Relaxed);
/// };
/// let progress = Progress::new(&count);
/// progress.report(3);
/// progress.report(4);
/// Progress::<u64>::default().report(100);
/// assert_eq!(done.load(Ordering::Relaxed), 7);
/// ```
pub struct Progress<'a, T = u64>(Option<&'a (dyn Fn(T) + Sync)>);

impl<'a, T> Progress<'a, T> {
    /// Tells nobody.
    pub const NONE: Self = Progress(None);

    /// Calls `callback` on each report.
    pub fn new(callback: &'a (dyn Fn(T) + Sync)) -> Self {
        Progress(Some(callback))
    }

    /// Hands `value` to the callback, if there is one.
    pub fn report(&self, value: T) {
        if let Some(f) = self.0 {
            f(value);
        }
    }
}

impl<T> Clone for Progress<'_, T> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<T> Copy for Progress<'_, T> {}

impl<T> Default for Progress<'_, T> {
    fn default() -> Self {
        Progress::NONE
    }
}

impl<T> fmt::Debug for Progress<'_, T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(if self.0.is_some() {
            "Progress(callback)"
        } else {
            "Progress(none)"
        })
    }
}

/// What the compute stage hands the writer stage.
#[derive(Debug)]
pub enum WriteMsg<W> {
    /// One computed chunk.
    Chunk(W),
    /// Everything was computed: commit the output. Any other end drops the temporary file.
    Finish,
}

/// A chunk the reader stage fills from a [`LasReader`]: the records as stored ([`RawChunk`]) or
/// decoded points ([`PointChunk`]).
pub trait Fill: Default + Send {
    /// Replaces the chunk's contents with up to `max` next points of `reader`; returns how many
    /// (0 at the end).
    ///
    /// # Errors
    /// The reader's.
    fn fill_from(&mut self, reader: &mut LasReader, max: usize) -> Result<usize>;
}

impl Fill for RawChunk {
    fn fill_from(&mut self, reader: &mut LasReader, max: usize) -> Result<usize> {
        reader.fill_raw(self, max)
    }
}

impl Fill for PointChunk {
    fn fill_from(&mut self, reader: &mut LasReader, max: usize) -> Result<usize> {
        reader.fill(self, max)
    }
}

/// Runs `read` and `write` on their own threads and `compute` on the calling one (which may use
/// rayon), joined by channels, so memory is a few chunks whatever the file size and decoding,
/// computing and encoding overlap. The reader's channel holds one item; the writer's holds
/// `write_queue` (at least one): the compute stage may run that many items ahead of the
/// encoding. A compute stage that hands the writer small items, each encoded on the writer's
/// thread, and then works a while between them (`tpu`: a chunk's pieces, then the next chunk's
/// surface judgement) needs about a chunk's worth queued, or it waits on the writer while
/// the writer has nothing to do during the pauses. `write` returns `Some(points)` after
/// a commit, `None` when its channel closed without [`WriteMsg::Finish`]. The output is
/// committed only when `compute` succeeded and the reader thread ended normally, so a reader
/// that stopped early never leaves a truncated output.
///
/// Errors, in this order: a panicked writer thread; the writer's own error (when the compute
/// stage only saw its channel close, the writer's error is the cause); the compute stage's
/// (which carries the reader's, sent through the channel); a panicked reader thread. A panic is
/// reported as `panicked("writer")` or `panicked("reader")`, in the caller's error type.
///
/// # Errors
/// As above.
pub fn run_stages<R: Send, W: Send, E: Send>(
    write_queue: usize,
    read: impl FnOnce(SyncSender<std::result::Result<R, E>>) + Send,
    write: impl FnOnce(Receiver<WriteMsg<W>>) -> std::result::Result<Option<u64>, E> + Send,
    compute: impl FnOnce(
        &Receiver<std::result::Result<R, E>>,
        &SyncSender<WriteMsg<W>>,
    ) -> std::result::Result<(), E>,
    panicked: impl Fn(&str) -> E,
) -> std::result::Result<u64, E> {
    std::thread::scope(|scope| {
        let (tx_read, rx_read) = sync_channel(1);
        let (tx_write, rx_write) = sync_channel::<WriteMsg<W>>(write_queue.max(1));
        let reader_thread = scope.spawn(move || read(tx_read));
        let writer_thread = scope.spawn(move || write(rx_write));
        let main = compute(&rx_read, &tx_write);
        // The reader stops at its next send, if it has not ended yet.
        drop(rx_read);
        let read = reader_thread.join();
        if main.is_ok() && read.is_ok() {
            let _ = tx_write.send(WriteMsg::Finish);
        }
        drop(tx_write);
        let written = writer_thread.join();
        match (main, written, read) {
            (_, Err(_), _) => Err(panicked("writer")),
            (_, Ok(Err(e)), _) => Err(e),
            (Err(e), _, _) => Err(e),
            (Ok(()), _, Err(_)) => Err(panicked("reader")),
            (Ok(()), Ok(Ok(Some(points))), Ok(())) => Ok(points),
            (Ok(()), Ok(Ok(None)), Ok(())) => Err(panicked("writer")),
        }
    })
}

/// The reader stage: opens each of `inputs` in turn on its own thread (las's reader is not
/// `Send`), fills chunks of up to `chunk_points` records (the spare ones a later stage hands
/// back on `spares`, new ones when none is there; a chunk never spans two files) and sends
/// each. Stops after the last file, at an error (sent on, so that the compute stage reports it
/// as the cause), or when the compute stage has hung up.
pub fn read_chunks<C: Fill, E: From<Error>>(
    inputs: &[impl AsRef<Path>],
    chunk_points: usize,
    spares: &Receiver<C>,
    tx: &SyncSender<std::result::Result<C, E>>,
) {
    for input in inputs {
        let mut reader = match LasReader::from_path(input) {
            Ok(r) => r,
            Err(e) => {
                let _ = tx.send(Err(e.into()));
                return;
            }
        };
        loop {
            let mut chunk = spares.try_recv().unwrap_or_default();
            match chunk.fill_from(&mut reader, chunk_points) {
                Err(e) => {
                    let _ = tx.send(Err(e.into()));
                    return;
                }
                Ok(0) => break,
                Ok(_) => {}
            }
            if tx.send(Ok(chunk)).is_err() {
                return;
            }
        }
    }
}

/// The writer stage: hands each computed chunk to `write` and commits `writer` on
/// [`WriteMsg::Finish`]. Returns `Some(points)` after the commit, `None` when the channel closed
/// without it (the temporary file is then dropped, nothing is left at the output).
///
/// # Errors
/// `write`'s, and the writer's when it commits.
pub fn write_chunks<W, E: From<Error>>(
    mut writer: LasWriter,
    rx: Receiver<WriteMsg<W>>,
    mut write: impl FnMut(&mut LasWriter, W) -> std::result::Result<(), E>,
) -> std::result::Result<Option<u64>, E> {
    for msg in rx {
        match msg {
            WriteMsg::Chunk(chunk) => write(&mut writer, chunk)?,
            WriteMsg::Finish => return Ok(Some(writer.finish()?)),
        }
    }
    Ok(None)
}

/// Reader → compute, for a pass that writes nothing: the chunks of `inputs` (in order, each
/// file's in file order, up to `chunk_points` each) are read on their own thread while
/// `compute` takes the one before on the calling thread, one chunk waiting between them, and
/// each spent chunk goes back to the reader for reuse. Memory is three chunks whatever the
/// files' size.
///
/// # Errors
/// `compute`'s first error; the reader's (opening or reading a file), in the caller's error
/// type; `panicked("reader")` when the reader thread panicked.
pub fn for_each_chunk<C: Fill, E: From<Error> + Send>(
    inputs: &[impl AsRef<Path> + Sync],
    chunk_points: usize,
    mut compute: impl FnMut(&mut C) -> std::result::Result<(), E>,
    panicked: impl Fn(&str) -> E,
) -> std::result::Result<(), E> {
    std::thread::scope(|scope| {
        let (tx, rx) = sync_channel::<std::result::Result<C, E>>(1);
        let (tx_spare, rx_spare) = sync_channel::<C>(1);
        let reader_thread = scope.spawn(move || read_chunks(inputs, chunk_points, &rx_spare, &tx));
        let main = (|| {
            for msg in &rx {
                let mut chunk = msg?;
                compute(&mut chunk)?;
                let _ = tx_spare.try_send(chunk);
            }
            Ok(())
        })();
        drop(rx);
        match (main, reader_thread.join()) {
            (Err(e), _) => Err(e),
            (Ok(()), Err(_)) => Err(panicked("reader")),
            (Ok(()), Ok(())) => Ok(()),
        }
    })
}

/// Runs `job` on each of `items` on up to `available_parallelism` plain threads, not rayon
/// tasks, so that each job may run the stages (which block their thread on channels while the
/// reader's decoding runs on rayon's workers) and still use rayon inside. Items start in input
/// order; after a job fails no further item starts. Returns every job's result in input order,
/// or the first error in input order (every item before the failed one has run).
///
/// ```
/// use lidarqa_io::on_plain_threads;
///
/// let squares = on_plain_threads(&[1, 2, 3], |_, &n| Ok::<_, String>(n * n));
/// assert_eq!(squares, Ok(vec![1, 4, 9]));
/// let first = on_plain_threads(&[1, 2, 3], |i, _| if i >= 1 { Err(i) } else { Ok(()) });
/// assert_eq!(first, Err(1));
/// ```
///
/// # Errors
/// The first failing item's error, in input order.
///
/// # Panics
/// When a job panics (the panic is passed on after every thread has ended).
pub fn on_plain_threads<T: Sync, R: Send, E: Send>(
    items: &[T],
    job: impl Fn(usize, &T) -> std::result::Result<R, E> + Sync,
) -> std::result::Result<Vec<R>, E> {
    let workers = std::thread::available_parallelism()
        .map_or(1, usize::from)
        .min(items.len())
        .max(1);
    let next = AtomicUsize::new(0);
    let stop = AtomicBool::new(false);
    let slots: Vec<Mutex<Option<std::result::Result<R, E>>>> =
        items.iter().map(|_| Mutex::new(None)).collect();
    std::thread::scope(|scope| {
        for _ in 0..workers {
            scope.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::SeqCst);
                    if i >= items.len() || stop.load(Ordering::SeqCst) {
                        break;
                    }
                    let r = job(i, &items[i]);
                    if r.is_err() {
                        stop.store(true, Ordering::SeqCst);
                    }
                    *slots[i].lock().unwrap_or_else(PoisonError::into_inner) = Some(r);
                }
            });
        }
    });
    let mut out = Vec::with_capacity(items.len());
    for slot in slots {
        match slot.into_inner().unwrap_or_else(PoisonError::into_inner) {
            Some(Ok(r)) => out.push(r),
            Some(Err(e)) => return Err(e),
            // Items are taken in input order, so one is skipped only after an earlier failure,
            // which was returned above.
            None => unreachable!("an item is skipped only after an earlier one failed"),
        }
    }
    Ok(out)
}
