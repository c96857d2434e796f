//! Criterion micro-benchmarks of lidarqa (see `benches/` and Cargo.toml).
