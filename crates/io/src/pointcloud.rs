//! LAS/LAZ point clouds through the `las` crate (SPEC §7).
//!
//! - [`LasReader`] streams points in chunks into a reusable [`PointChunk`] (memory bounded by the
//!   chunk size, whatever the file size), decoding each record once into a plain [`LasPoint`]
//!   plus the file's extra-bytes dimensions by name;
//! - [`RawChunk`] keeps a chunk's records as the file stores them, for commands that pass them
//!   through (`correct` rewrites X, Y, Z; `tpu` appends its σ with [`RawChunk::push`]);
//!   [`RawPoint`] reads the few fields they need straight from a record's bytes;
//! - [`LasInfo`] holds the header facts lidarqa needs: version, point format, count, bounds, GPS
//!   time base, creation date, scale/offset and the CRS ([`LasCrs`](crate::crs::LasCrs): the
//!   raw CRS VLRs to copy into outputs and the EPSG code when one is present);
//! - [`LasWriter`] writes LAS 1.2–1.4 (by default 1.4, point format 6 or the input's format when
//!   it has GPS time) with the input's scale/offset and CRS VLRs and f32 extra-bytes dimensions
//!   (`sigma_north`, …, `total_thu`, `total_tvu`), compressed when the path ends in `.laz`, always
//!   through an [`AtomicFile`](crate::atomic::AtomicFile).
//!
//! # What is done by hand, and why
//! las 0.11 stores a point's extra bytes as an opaque `Vec<u8>` and sizes them from the record
//! length, but has no type for the LAS 1.4 extra-bytes VLR (user `LASF_Spec`, record 4) that
//! names and types them. This module therefore encodes and decodes that VLR's 192-byte
//! descriptors itself (LAS 1.4 R15 §2.5.8, table 24) and packs the values into
//! `Point::extra_bytes`; everything else (headers, VLR storage, point records, LAZ) is the crate's.
//! The CRS VLRs are read by the crs module ([`LasCrs`](crate::crs::LasCrs)).
//!
//! An input's own extra bytes are readable by name. An output has the dimensions its caller
//! names, and the input's own extra bytes when the caller asks for them
//! ([`LasWriteOptions::carry_extra_bytes`]): the input's descriptors ahead of the caller's in
//! the extra-bytes VLR, each record's bytes copied unchanged, a name the caller writes itself
//! renamed with the suffix `_input`.
//!
//! # Full disks and corrupt input
//! `las::Writer` finishes a file in its `Drop` and panics if that fails (a full disk). The file
//! under a [`LasWriter`] therefore stops writing after its first I/O error and reports that error
//! from [`finish`](LasWriter::finish) (or from the write that hit it); the temporary file is
//! removed, nothing panics. [`LasReader`] checks the header's claims against the file size before
//! `las` sizes anything from them, and turns a panic inside `las`/`laz` into an error.
//!
//! # Modules
//! One job each: `point` the shared plain types, `extra_bytes` the extra-bytes VLR codec,
//! `info` the header facts, `reader` and `writer`, `raw_chunk` the records kept as bytes, and
//! `laz_layout` the checks of a LAZ file's own layout. The children use one another, never
//! this module.

mod extra_bytes;
mod info;
mod laz_layout;
mod point;
mod raw_chunk;
mod reader;
mod writer;

pub use extra_bytes::{CarriedExtraBytes, ExtraDim};
pub use info::LasInfo;
pub use point::{CLASS_BATHYMETRY, CLASS_WATER_SURFACE, LasPoint};
pub use raw_chunk::{CoordinateBlock, RawChunk, RawPoint};
pub use reader::{LasReader, PointChunk};
pub use writer::{LasWriteOptions, LasWriter, WRITE_BATCH_POINTS};
