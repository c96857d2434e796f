//! The tile manifest of `lidarqa plan/run/collect` (crates/pipeline `Manifest::read`), then
//! what a job-array task derives from it before touching any input: its options and entries.
//! `Manifest::read` takes a path, so each input is written to one scratch file per process.
//! `Manifest::read` also runs the path checks (`..`, outside the directory, through a symbolic
//! link, over an input); every output is then resolved as `run` resolves it.
#![no_main]

use libfuzzer_sys::fuzz_target;
use lidarqa_pipeline::{Manifest, resolve};
use std::path::PathBuf;
use std::sync::OnceLock;

static SCRATCH: OnceLock<PathBuf> = OnceLock::new();

fuzz_target!(|data: &[u8]| {
    let path = SCRATCH.get_or_init(|| {
        std::env::temp_dir()
            .join(format!("lidarqa-fuzz-{}", std::process::id()))
            .join("manifest.json")
    });
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(path, data).unwrap();
    if let Ok(m) = Manifest::read(path) {
        let _ = m.options.to_options();
        let _ = resolve(path, &m.sensor.path);
        for i in 0..m.entries.len().min(8) + 1 {
            if let Ok(e) = m.entry(path, i) {
                let _ = lidarqa_io::resolved(&resolve(path, &e.output));
                let _ = lidarqa_io::resolved(&resolve(path, &e.report));
            }
        }
    }
});
