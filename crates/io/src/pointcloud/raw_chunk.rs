//! A chunk of point records kept as the file's bytes ([`RawChunk`]): for commands that change
//! only the coordinates (`correct`), so every other field passes through untouched and no
//! record is decoded into a [`LasPoint`](super::point::LasPoint) and encoded back.

use crate::error::{Error, Result};
use std::path::Path;

/// Up to a chunk of point records in the layout of the file they were read from, with that
/// file's scale and offset; filled by [`LasReader::fill_raw`](super::reader::LasReader::fill_raw)
/// and written by [`LasWriter::write_raw`](super::writer::LasWriter::write_raw).
#[derive(Clone, Debug)]
pub struct RawChunk {
    pub(super) data: las::PointData,
    /// Byte offset of the GPS time in a record, when the format has one.
    pub(super) gps_time_at: Option<usize>,
    /// Index in the file of the chunk's first point.
    pub(super) first_index: u64,
}

impl Default for RawChunk {
    fn default() -> Self {
        RawChunk {
            data: las::PointDataBuilder::new().build(),
            gps_time_at: None,
            first_index: 0,
        }
    }
}

impl RawChunk {
    /// An empty chunk.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.data.len()
    }

    /// Whether the chunk holds no point.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// The records, `len()` × the record length.
    fn records(&self) -> std::slice::ChunksExact<'_, u8> {
        self.data.raw_bytes().chunks_exact(self.data.record_len())
    }

    /// X, Y, Z of every point in the file's CRS units (scale and offset applied), with the GPS
    /// time (`None` for point formats without time).
    pub fn coordinates(&self) -> impl Iterator<Item = ([f64; 3], Option<f64>)> + '_ {
        let t = *self.data.transforms();
        let g = self.gps_time_at;
        self.records().map(move |r| {
            let i = |k: usize| i32::from_le_bytes([r[k], r[k + 1], r[k + 2], r[k + 3]]);
            let time = g.map(|g| {
                let mut b = [0u8; 8];
                b.copy_from_slice(&r[g..g + 8]);
                f64::from_le_bytes(b)
            });
            ([t.x.direct(i(0)), t.y.direct(i(4)), t.z.direct(i(8))], time)
        })
    }

    /// Index in the file of the chunk's first point.
    pub fn first_index(&self) -> u64 {
        self.first_index
    }

    /// Replaces the coordinates of every point, in order, with `xyz` (CRS units; the file's
    /// scale and offset, rounded to the nearest step as `las` does).
    ///
    /// # Errors
    /// [`Error::LasPoint`] naming `path` (the file the chunk is written to) and the first point
    /// whose coordinate does not fit the record (beyond the i32 range of the scale and offset);
    /// the chunk is then partly updated.
    pub fn set_coordinates(
        &mut self,
        path: &Path,
        xyz: impl IntoIterator<Item = [f64; 3]>,
    ) -> Result<()> {
        let t = *self.data.transforms();
        let len = self.data.len();
        let record_len = self.data.record_len();
        let bytes = self.data.resize_for(len);
        for (k, (r, p)) in bytes.chunks_exact_mut(record_len).zip(xyz).enumerate() {
            let raw = [t.x.inverse(p[0]), t.y.inverse(p[1]), t.z.inverse(p[2])];
            for (j, v) in raw.into_iter().enumerate() {
                let v = v.map_err(|source| Error::LasPoint {
                    path: path.to_path_buf(),
                    index: self.first_index + k as u64,
                    source,
                })?;
                r[4 * j..4 * j + 4].copy_from_slice(&v.to_le_bytes());
            }
        }
        Ok(())
    }
}
