//! The stages of the streaming commands: what the reader stage delivers from several files, and
//! which error a failed run reports (and that it commits nothing).

use lidarqa_io::{
    Error, LasPoint, LasTimeBase, LasWriteOptions, LasWriter, PointChunk, RawChunk, WriteMsg,
    for_each_chunk, on_plain_threads, run_stages,
};
use std::path::{Path, PathBuf};

/// A caller's own error type, as the stages see it: anything lidarqa-io's errors convert into.
#[derive(Debug, PartialEq)]
enum CallerError {
    Io(String),
    Stop,
}

impl From<Error> for CallerError {
    fn from(e: Error) -> Self {
        CallerError::Io(e.to_string())
    }
}

fn options() -> LasWriteOptions {
    LasWriteOptions {
        version_minor: 4,
        point_format: 6,
        scale: [0.001, 0.001, 0.001],
        offset: [500_000.0, 4_982_000.0, 0.0],
        time_base: LasTimeBase::AdjustedStandard,
        crs_vlrs: Vec::new(),
        extra_dims: Vec::new(),
        file_source_id: 1,
        carried_extra: Default::default(),
        extra_dims_f64: Vec::new(),
    }
}

/// A file of `n` points whose x are `x0`, `x0 + 1`, … metres.
fn write(path: &Path, x0: f64, n: u16) {
    let mut w = LasWriter::create(path, &options(), &[] as &[&Path]).unwrap();
    for i in 0..n {
        let p = LasPoint {
            x: x0 + f64::from(i),
            y: 4_982_950.0,
            z: 100.0,
            gps_time_s: Some(1.0e6 + f64::from(i)),
            return_number: 1,
            number_of_returns: 1,
            ..LasPoint::default()
        };
        w.write_point(&p, &[]).unwrap();
    }
    assert_eq!(w.finish().unwrap(), u64::from(n));
}

fn two_files(dir: &Path) -> Vec<PathBuf> {
    let a = dir.join("a.las");
    let b = dir.join("b.laz");
    write(&a, 500_000.0, 10);
    write(&b, 501_000.0, 4);
    vec![a, b]
}

/// Every point of every file once, in the files' order and each file's order, in chunks of at
/// most the size asked that never span two files.
#[test]
fn reader_stage_reads_several_files_in_order() {
    let dir = tempfile::tempdir().unwrap();
    let files = two_files(dir.path());
    let mut chunks: Vec<Vec<f64>> = Vec::new();
    for_each_chunk(
        &files,
        4,
        |c: &mut PointChunk| -> Result<(), Error> {
            chunks.push(c.points.iter().map(|p| p.x - 500_000.0).collect());
            Ok(())
        },
        |_| panic!("no thread panics"),
    )
    .unwrap();
    let sizes: Vec<usize> = chunks.iter().map(Vec::len).collect();
    assert_eq!(sizes, [4, 4, 2, 4]);
    let xs: Vec<f64> = chunks.concat();
    let expected: Vec<f64> = (0..10)
        .map(f64::from)
        .chain((0..4).map(|i| 1000.0 + f64::from(i)))
        .collect();
    assert_eq!(xs, expected);
}

/// A file that cannot be opened is reported naming it, after the chunks before it.
#[test]
fn reader_stage_reports_a_missing_file() {
    let dir = tempfile::tempdir().unwrap();
    let mut files = two_files(dir.path());
    files.insert(1, dir.path().join("missing.las"));
    let mut points = 0;
    let e = for_each_chunk(
        &files,
        100,
        |c: &mut RawChunk| -> Result<(), CallerError> {
            points += c.len();
            Ok(())
        },
        |_| panic!("no thread panics"),
    )
    .unwrap_err();
    assert_eq!(points, 10);
    let CallerError::Io(message) = e else {
        panic!("{e:?}")
    };
    assert!(message.contains("missing.las"), "{message}");
}

/// The compute stage's error stops the run and is the one reported.
#[test]
fn compute_error_stops_the_reader() {
    let dir = tempfile::tempdir().unwrap();
    let files = two_files(dir.path());
    let mut calls = 0;
    let e = for_each_chunk(
        &files,
        2,
        |_: &mut RawChunk| -> Result<(), CallerError> {
            calls += 1;
            Err(CallerError::Stop)
        },
        |_| panic!("no thread panics"),
    );
    assert_eq!(e, Err(CallerError::Stop));
    assert_eq!(calls, 1);
}

/// A reader thread that panics after some chunks must not leave a committed output with only
/// those chunks: the run is refused as the reader's panic, and the writer never sees `Finish`.
#[test]
fn a_panicked_reader_commits_nothing() {
    let r = run_stages(
        1,
        |tx| {
            for i in 0..3u64 {
                tx.send(Ok(i)).unwrap();
            }
            panic!("reader stops early");
        },
        |rx| -> Result<Option<u64>, String> {
            let mut n = 0;
            for msg in rx {
                match msg {
                    WriteMsg::Chunk(_) => n += 1,
                    WriteMsg::Finish => return Ok(Some(n)),
                }
            }
            Ok(None)
        },
        |rx, tx| {
            for msg in rx {
                tx.send(WriteMsg::Chunk(msg?)).map_err(|e| e.to_string())?;
            }
            Ok(())
        },
        |thread| format!("{thread} panicked"),
    );
    assert_eq!(r, Err("reader panicked".into()));
}

/// A writer error is reported before the compute stage's (which then only saw its channel
/// close), and a complete run returns the writer's count.
#[test]
fn writer_error_comes_first_and_a_complete_run_commits() {
    let stages = |fail: bool| {
        run_stages(
            1,
            |tx| {
                for i in 0..5u64 {
                    if tx.send(Ok(i)).is_err() {
                        return;
                    }
                }
            },
            move |rx| -> Result<Option<u64>, String> {
                let mut n = 0;
                for msg in rx {
                    match msg {
                        WriteMsg::Chunk(_) if fail => return Err("disk full".into()),
                        WriteMsg::Chunk(_) => n += 1,
                        WriteMsg::Finish => return Ok(Some(n)),
                    }
                }
                Ok(None)
            },
            |rx, tx| {
                for msg in rx {
                    tx.send(WriteMsg::Chunk(msg?))
                        .map_err(|_| "writer gone".to_string())?;
                }
                Ok(())
            },
            |thread| format!("{thread} panicked"),
        )
    };
    assert_eq!(stages(true), Err("disk full".into()));
    assert_eq!(stages(false), Ok(5));
}

/// The compute stage may run `write_queue` items ahead of a writer that has not taken any yet
/// (a writer encoding on its own thread then has work queued while the compute stage pauses),
/// and no further: the next item waits.
#[test]
fn the_compute_stage_runs_write_queue_items_ahead_of_the_writer() {
    for queue in [1, 4, 12] {
        let (release, wait) = std::sync::mpsc::channel::<()>();
        let r = run_stages(
            queue,
            |tx| {
                let _ = tx.send(Ok(()));
            },
            move |rx| -> Result<Option<u64>, String> {
                // Takes nothing until the compute stage has filled the queue.
                wait.recv().map_err(|e| e.to_string())?;
                let mut n = 0;
                for msg in rx {
                    match msg {
                        WriteMsg::Chunk(()) => n += 1,
                        WriteMsg::Finish => return Ok(Some(n)),
                    }
                }
                Ok(None)
            },
            |rx, tx| {
                for msg in rx {
                    msg?;
                }
                for i in 0..queue {
                    tx.try_send(WriteMsg::Chunk(()))
                        .map_err(|e| format!("item {i} of a queue of {queue}: {e}"))?;
                }
                let full = tx.try_send(WriteMsg::Chunk(())).is_err();
                release.send(()).map_err(|e| e.to_string())?;
                if !full {
                    return Err(format!("a queue of {queue} took one more"));
                }
                Ok(())
            },
            |thread| format!("{thread} panicked"),
        );
        assert_eq!(r, Ok(queue as u64), "queue of {queue}");
    }
}

/// More LAZ files than cores, each read through the reader stage by its own job on
/// `on_plain_threads` (as calibrate's first passes do): every file's points arrive, the results
/// in input order, while the reader threads decode on rayon's workers. Run as rayon tasks that
/// block on the stage's channel, the same jobs could leave no worker to decode.
#[test]
fn stages_run_on_plain_threads_for_many_files() {
    let dir = tempfile::tempdir().unwrap();
    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    let files: Vec<PathBuf> = (0..2 * cores + 3)
        .map(|k| {
            let path = dir.path().join(format!("f{k}.laz"));
            write(&path, 500_000.0 + 100.0 * k as f64, 50 + k as u16);
            path
        })
        .collect();
    let firsts = on_plain_threads(&files, |_, path| {
        let mut xs = Vec::new();
        for_each_chunk(
            &[path],
            16,
            |c: &mut PointChunk| -> Result<(), Error> {
                xs.extend(c.points.iter().map(|p| p.x));
                Ok(())
            },
            |_| panic!("no thread panics"),
        )?;
        Ok::<_, Error>((xs.len(), xs[0]))
    })
    .unwrap();
    let expected: Vec<(usize, f64)> = (0..files.len())
        .map(|k| (50 + k, 500_000.0 + 100.0 * k as f64))
        .collect();
    assert_eq!(firsts, expected);
    // A failing file stops the run and is the error reported, naming the file.
    let mut with_missing = files.clone();
    with_missing.insert(2, dir.path().join("missing.laz"));
    let e = on_plain_threads(&with_missing, |_, path| {
        for_each_chunk(
            &[path],
            16,
            |_: &mut RawChunk| -> Result<(), Error> { Ok(()) },
            |_| panic!("no thread panics"),
        )
    })
    .unwrap_err();
    assert!(e.to_string().contains("missing.laz"), "{e}");
}
