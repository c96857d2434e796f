//! A chunk of point records kept as the file's bytes ([`RawChunk`]): for commands that change
//! only the coordinates (`correct`) or append values to each record (`tpu`), so every other
//! field passes through untouched and no record is decoded into a
//! [`LasPoint`](super::point::LasPoint) and encoded back. [`RawPoint`] is the one place that
//! reads the fields these commands need straight from a record's bytes.

use super::extra_bytes::{ExtraDim, encode_extra, is_prefix};
use crate::error::{Error, Result};
use std::path::Path;

/// Up to a chunk of point records in the layout of the file they were read from, with that
/// file's scale and offset; filled by [`LasReader::fill_raw`](super::reader::LasReader::fill_raw)
/// and written by [`LasWriter::write_raw`](super::writer::LasWriter::write_raw); or an
/// output's records, made by [`LasWriter::raw_chunk`](super::writer::LasWriter::raw_chunk) and
/// filled by [`RawChunk::push`].
#[derive(Clone, Debug)]
pub struct RawChunk {
    pub(super) data: las::PointData,
    /// Byte offset of the GPS time in a record, when the format has one.
    pub(super) gps_time_at: Option<usize>,
    /// Index in the file of the chunk's first point.
    pub(super) first_index: u64,
    /// The file's extra-bytes dimensions (offsets inside a record's extra bytes).
    pub(super) extra_dims: Vec<ExtraDim>,
    /// The f32 and f64 extra-bytes values [`RawChunk::push`] appends (an output's chunk).
    extra_counts: (usize, usize),
    /// The input's extra bytes [`RawChunk::push`] carries ahead of them, per record.
    carried: usize,
}

/// One record of a [`RawChunk`], decoded field by field on demand (as `las` decodes them).
#[derive(Clone, Copy, Debug)]
pub struct RawPoint<'a> {
    record: &'a [u8],
    chunk: &'a RawChunk,
    /// Index in the chunk.
    index: usize,
}

impl<'a> RawPoint<'a> {
    /// X, Y, Z in the file's CRS units (scale and offset applied).
    #[inline]
    pub fn xyz(&self) -> [f64; 3] {
        record_xyz(self.record, self.chunk.data.transforms())
    }

    /// GPS time, `None` for point formats without time.
    #[inline]
    pub fn gps_time(&self) -> Option<f64> {
        record_gps_time(self.record, self.chunk.gps_time_at)
    }

    /// The classification code as stored: the low 5 bits of the class byte in formats 0–5, the
    /// class byte in formats 6–10 (class 12 stays 12: no overlap flag is derived from it).
    #[inline]
    pub fn classification(&self) -> u8 {
        if self.chunk.data.format().is_extended {
            self.record[16]
        } else {
            self.record[15] & 0b1_1111
        }
    }

    /// The point source id (bytes 18–19 in formats 0–5, 20–21 in 6–10).
    #[inline]
    pub fn point_source_id(&self) -> u16 {
        let at = point_source_id_at(self.chunk.data.format());
        u16::from_le_bytes([self.record[at], self.record[at + 1]])
    }

    /// Scan angle, degrees: formats 0–5 store whole degrees (i8 at byte 16), 6–10 steps of
    /// 0.006° (i16 at byte 18); the same f32 as `las` gives.
    #[inline]
    pub fn scan_angle_deg(&self) -> f32 {
        let r = self.record;
        if self.chunk.data.format().is_extended {
            f32::from(i16::from_le_bytes([r[18], r[19]])) * 0.006
        } else {
            f32::from(r[16] as i8)
        }
    }

    /// The record's extra bytes (after its format's fields).
    fn extra_bytes(&self) -> &[u8] {
        let n = usize::from(self.chunk.data.format().extra_bytes);
        &self.record[self.record.len() - n..]
    }
}

impl Default for RawChunk {
    fn default() -> Self {
        RawChunk {
            data: las::PointDataBuilder::new().build(),
            gps_time_at: None,
            first_index: 0,
            extra_dims: Vec::new(),
            extra_counts: (0, 0),
            carried: 0,
        }
    }
}

impl RawChunk {
    /// An empty chunk.
    pub fn new() -> Self {
        Self::default()
    }

    /// An empty chunk of `data`'s layout whose records end in `carried` bytes of the input's
    /// then `n32` f32 then `n64` f64 values.
    pub(super) fn with_layout(
        data: las::PointData,
        carried: usize,
        n32: usize,
        n64: usize,
    ) -> Self {
        RawChunk {
            gps_time_at: gps_time_offset(data.format()),
            data,
            first_index: 0,
            extra_dims: Vec::new(),
            extra_counts: (n32, n64),
            carried,
        }
    }

    /// Removes every point (the buffer is kept).
    pub fn clear(&mut self) {
        self.data.resize_for(0);
    }

    /// Appends `from` (a point of a chunk read from a file) as a record of this chunk's layout:
    /// its bytes up to this format's fields (without the waveform packet, NIR or extra bytes
    /// this format does not have), its extra bytes unchanged when this chunk carries them
    /// ([`LasWriteOptions::carry_extra_bytes`](super::writer::LasWriteOptions::carry_extra_bytes)),
    /// then `extra` and `extra64`. No field is decoded.
    ///
    /// # Errors
    /// [`Error::PointMismatch`] naming `path` (the file the chunk is for) when this format's
    /// fields are not a prefix of `from`'s record, the scale and offset differ, `from` has not
    /// the extra bytes this chunk carries, or the values do not match this chunk's extra-bytes
    /// dimensions.
    pub fn push(
        &mut self,
        path: &Path,
        from: RawPoint<'_>,
        extra: &[f32],
        extra64: &[f64],
    ) -> Result<()> {
        let mut base = *self.data.format();
        base.extra_bytes = 0;
        let src = &from.chunk.data;
        let carried = self.carried;
        if !is_prefix(&base, src.format())
            || src.transforms() != self.data.transforms()
            || (extra.len(), extra64.len()) != self.extra_counts
            || (carried > 0 && usize::from(src.format().extra_bytes) != carried)
        {
            return Err(Error::PointMismatch {
                path: path.to_path_buf(),
                index: from.chunk.first_index + from.index as u64,
                message: format!(
                    "a record of point format {} and scale/offset {:?} with {} f32 + {} f64 \
                     values cannot be written as format {} with {:?}, {carried} bytes of the \
                     input's and {} + {}",
                    src.format(),
                    src.transforms(),
                    extra.len(),
                    extra64.len(),
                    self.data.format(),
                    self.data.transforms(),
                    self.extra_counts.0,
                    self.extra_counts.1
                ),
            });
        }
        let (n, len, head) = (
            self.data.len(),
            self.data.record_len(),
            usize::from(base.len()),
        );
        let record = &mut self.data.resize_for(n + 1)[n * len..];
        record[..head].copy_from_slice(&from.record[..head]);
        record[head..head + carried].copy_from_slice(&from.record[from.record.len() - carried..]);
        encode_extra(&mut record[head + carried..], extra, extra64);
        Ok(())
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.data.len()
    }

    /// Whether the chunk holds no point.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// Point `i` (panics beyond [`len`](Self::len), as slice indexing does).
    #[inline]
    pub fn point(&self, i: usize) -> RawPoint<'_> {
        let n = self.data.record_len();
        RawPoint {
            record: &self.data.raw_bytes()[i * n..(i + 1) * n],
            chunk: self,
            index: i,
        }
    }

    /// Every point, in order.
    pub fn points(&self) -> impl ExactSizeIterator<Item = RawPoint<'_>> + Clone + '_ {
        self.data
            .raw_bytes()
            .chunks_exact(self.data.record_len())
            .enumerate()
            .map(move |(index, record)| RawPoint {
                record,
                chunk: self,
                index,
            })
    }

    /// X, Y, Z of every point in the file's CRS units (scale and offset applied), with the GPS
    /// time (`None` for point formats without time).
    pub fn coordinates(&self) -> impl Iterator<Item = ([f64; 3], Option<f64>)> + '_ {
        self.points().map(|p| (p.xyz(), p.gps_time()))
    }

    /// The file's extra-bytes dimensions, in file order.
    pub fn extra_dims(&self) -> &[ExtraDim] {
        &self.extra_dims
    }

    /// All values of extra dimension `name`, in point order (scale and offset applied; NaN where
    /// a value is not decodable); `None` when the file has no such dimension.
    pub fn extra_column(&self, name: &str) -> Option<Vec<f64>> {
        let d = self.extra_dims.iter().find(|d| d.name == name)?;
        Some(
            self.points()
                .map(|p| d.decode(p.extra_bytes()).unwrap_or(f64::NAN))
                .collect(),
        )
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
        let mut xyz = xyz.into_iter();
        for mut block in self.coordinate_blocks(self.len().max(1)) {
            for (k, p) in (0..block.len()).zip(xyz.by_ref()) {
                block.set(path, k, p)?;
            }
        }
        Ok(())
    }

    /// The records cut into runs of up to `points` (at least 1), each of which reads and
    /// rewrites its points' coordinates in place: for a caller that moves the points of a
    /// chunk in parallel, one run per task, without copying the coordinates out and back.
    pub fn coordinate_blocks(&mut self, points: usize) -> Vec<CoordinateBlock<'_>> {
        let points = points.max(1);
        let transforms = *self.data.transforms();
        let (gps_time_at, first_index) = (self.gps_time_at, self.first_index);
        let point_source_id_at = point_source_id_at(self.data.format());
        let record_len = self.data.record_len();
        let len = self.data.len();
        self.data
            .resize_for(len)
            .chunks_mut(record_len * points)
            .enumerate()
            .map(|(b, records)| CoordinateBlock {
                records,
                record_len,
                transforms,
                gps_time_at,
                point_source_id_at,
                first_index: first_index + (b * points) as u64,
            })
            .collect()
    }
}

/// A run of consecutive records of a [`RawChunk`] whose X, Y and Z are rewritten in place
/// ([`RawChunk::coordinate_blocks`]); every other byte stays as read.
#[derive(Debug)]
pub struct CoordinateBlock<'a> {
    records: &'a mut [u8],
    record_len: usize,
    transforms: las::Vector<las::Transform>,
    gps_time_at: Option<usize>,
    /// Byte offset of the point source id in a record (18 in formats 0–5, 20 in 6–10).
    point_source_id_at: usize,
    /// Index in the file of the run's first point.
    first_index: u64,
}

impl CoordinateBlock<'_> {
    /// The point source id of point `k` of the run.
    #[inline]
    pub fn point_source_id(&self, k: usize) -> u16 {
        let at = k * self.record_len + self.point_source_id_at;
        u16::from_le_bytes([self.records[at], self.records[at + 1]])
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.records.len() / self.record_len
    }

    /// Whether the run holds no point.
    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }

    /// Index in the file of point `k` of the run.
    #[inline]
    pub fn index(&self, k: usize) -> u64 {
        self.first_index + k as u64
    }

    /// X, Y, Z of point `k` in the file's CRS units and its GPS time (`None` for point formats
    /// without time), as [`RawPoint::xyz`] and [`RawPoint::gps_time`] read them.
    #[inline]
    pub fn get(&self, k: usize) -> ([f64; 3], Option<f64>) {
        let r = &self.records[k * self.record_len..(k + 1) * self.record_len];
        (
            record_xyz(r, &self.transforms),
            record_gps_time(r, self.gps_time_at),
        )
    }

    /// Replaces the coordinates of point `k` with `xyz` (CRS units; the file's scale and
    /// offset, rounded to the nearest step as `las` does).
    ///
    /// # Errors
    /// [`Error::LasPoint`] naming `path` (the file the chunk is written to) and the point when
    /// a coordinate does not fit the record (beyond the i32 range of the scale and offset); the
    /// record is then unchanged.
    #[inline]
    pub fn set(&mut self, path: &Path, k: usize, xyz: [f64; 3]) -> Result<()> {
        let t = &self.transforms;
        let raw = [
            step_of(&t.x, xyz[0]),
            step_of(&t.y, xyz[1]),
            step_of(&t.z, xyz[2]),
        ];
        let raw = match raw {
            [Some(x), Some(y), Some(z)] => [x, y, z],
            // Beyond the range (or NaN): `las`'s own function, its value or its error.
            _ => {
                let index = self.index(k);
                let las = |t: &las::Transform, v: f64| {
                    t.inverse(v).map_err(|source| Error::LasPoint {
                        path: path.to_path_buf(),
                        index,
                        source,
                    })
                };
                [las(&t.x, xyz[0])?, las(&t.y, xyz[1])?, las(&t.z, xyz[2])?]
            }
        };
        let r = &mut self.records[k * self.record_len..][..12];
        for (b, v) in r.chunks_exact_mut(4).zip(raw) {
            b.copy_from_slice(&v.to_le_bytes());
        }
        Ok(())
    }
}

/// `las`'s [`Transform::inverse`](las::Transform::inverse) (the nearest step, halves away from
/// zero) for values well inside the i32 range, with the rounding done inline: `f64::round` is
/// a libm call on the default x86-64 target, and every coordinate of a corrected strip takes
/// it. `None` beyond ±(2³¹ − 1) and for NaN, which take `las`'s own function.
#[inline]
fn step_of(t: &las::Transform, n: f64) -> Option<i32> {
    let v = (n - t.offset) / t.scale;
    // (NaN fails the comparison.)
    if v.abs() < 2_147_483_647.0 {
        // |v| < 2³¹: the truncation is exact in i64 and `v − i` exact in f64; the halves go
        // away from zero. Without branches: the fractions are random.
        let i = v as i64;
        let f = v - i as f64;
        let r = i + i64::from(f >= 0.5) - i64::from(f <= -0.5);
        // |r| ≤ 2³¹ − 1: within i32.
        Some(r as i32)
    } else {
        None
    }
}

/// Byte offset of the point source id in a record of `format` (18 in formats 0–5, 20 in 6–10).
fn point_source_id_at(format: &las::point::Format) -> usize {
    if format.is_extended { 20 } else { 18 }
}

/// X, Y, Z of a record (scale and offset applied).
#[inline]
fn record_xyz(r: &[u8], t: &las::Vector<las::Transform>) -> [f64; 3] {
    let i = |k: usize| i32::from_le_bytes([r[k], r[k + 1], r[k + 2], r[k + 3]]);
    [t.x.direct(i(0)), t.y.direct(i(4)), t.z.direct(i(8))]
}

/// The GPS time of a record whose time is at byte `at` (`None`: the format has none).
#[inline]
fn record_gps_time(r: &[u8], at: Option<usize>) -> Option<f64> {
    at.map(|g| {
        let mut b = [0u8; 8];
        b.copy_from_slice(&r[g..g + 8]);
        f64::from_le_bytes(b)
    })
}

/// Byte offset of the GPS time in a record of `format` (after the 20 bytes of formats 0–5's
/// base record, the 22 of formats 6–10's), `None` without time.
pub(super) fn gps_time_offset(format: &las::point::Format) -> Option<usize> {
    format
        .has_gps_time
        .then_some(if format.is_extended { 22 } else { 20 })
}

#[cfg(test)]
mod tests {
    use super::step_of;

    #[test]
    fn inline_rounding_is_las_own_within_the_range() {
        // Halves on both sides of zero, values a few ulps off a half, the ends of the i32
        // range, beyond it and NaN, at three scales and offsets.
        let transforms = [
            las::Transform {
                scale: 0.001,
                offset: 0.0,
            },
            las::Transform {
                scale: 0.01,
                offset: 500_000.0,
            },
            las::Transform {
                scale: 0.000_25,
                offset: -1234.5,
            },
        ];
        for t in transforms {
            let mut values = vec![f64::NAN, 0.0, -0.0];
            for k in [
                -3.0f64,
                -2.0,
                -1.0,
                0.0,
                1.0,
                2.0,
                1e6,
                -1e6,
                2_147_483_646.0,
            ] {
                for half in [0.5, -0.5, 0.25, 0.75] {
                    let v = k + half;
                    for ulps in -3i64..=3 {
                        values.push(f64::from_bits((v.to_bits() as i64 + ulps) as u64));
                    }
                    // A few millionths of a step off a half.
                    for off in [1.01e-6, -1.01e-6, 3e-6, -3e-6] {
                        values.push(v + off);
                    }
                }
            }
            values.extend([
                2_147_483_647.0,
                2_147_483_647.4,
                2_147_483_647.6,
                -2_147_483_648.4,
            ]);
            values.extend([-2_147_483_648.6, 3e9, -3e9, f64::INFINITY]);
            let mut state = 0x9e37_79b9_7f4a_7c15u64;
            for _ in 0..100_000 {
                state = state
                    .wrapping_mul(6_364_136_223_846_793_005)
                    .wrapping_add(1);
                values.push(((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 4.4e9);
            }
            for v in values {
                let n = v * t.scale + t.offset;
                // Where it gives a step, las's; where not, las's is an error or NaN's 0.
                match (step_of(&t, n), t.inverse(n)) {
                    (Some(a), Ok(b)) => assert_eq!(a, b, "{n} {t:?}"),
                    (None, Err(_)) => {}
                    (None, Ok(_)) => {
                        assert!(n.is_nan() || ((n - t.offset) / t.scale).abs() >= 2_147_483_647.0)
                    }
                    (ours, las) => panic!("{n} {t:?}: {ours:?} {las:?}"),
                }
            }
        }
    }
}
