//! Writing a LAS/LAZ file atomically ([`LasWriter`], [`LasWriteOptions`]).

use super::extra_bytes::{
    CarriedExtraBytes, EB_F32, EB_F64, EXTRA_BYTES_DESCRIPTOR_LEN, EXTRA_BYTES_RECORD,
    EXTRA_BYTES_USER, descriptor, encode_extra, is_prefix,
};
use super::info::LasInfo;
use super::point::LasPoint;
use super::raw_chunk::RawChunk;
use crate::atomic::AtomicFile;
use crate::crs::RawVlr;
use crate::error::{Error, Result};
use crate::gpstime::LasTimeBase;
use std::io::{BufWriter, Seek};
use std::path::{Path, PathBuf};

/// How to write a LAS/LAZ file.
#[derive(Clone, Debug, PartialEq)]
pub struct LasWriteOptions {
    /// LAS minor version, 2–4 (1.2, 1.3, 1.4).
    pub version_minor: u8,
    /// Point data record format, 0–10 (waveform formats 4, 5, 9, 10 are refused: lidarqa does
    /// not carry waveform packets).
    pub point_format: u8,
    /// Scale factors (x, y, z): the coordinate resolution, CRS units.
    pub scale: [f64; 3],
    /// Offsets (x, y, z), CRS units.
    pub offset: [f64; 3],
    /// Time base written to the global encoding.
    pub time_base: LasTimeBase,
    /// CRS VLRs copied verbatim.
    pub crs_vlrs: Vec<RawVlr>,
    /// Extra-bytes dimensions, all f32: (name ≤ 32 bytes, description ≤ 32 bytes).
    pub extra_dims: Vec<(String, String)>,
    /// Extra-bytes dimensions after those, all f64 (e.g. variances in m², which f32 would
    /// round): (name, description) as for `extra_dims`.
    pub extra_dims_f64: Vec<(String, String)>,
    /// File source id (LAS 1.1+), e.g. the strip's point source id.
    pub file_source_id: u16,
    /// The input's own extra bytes, carried ahead of `extra_dims` in every record (set by
    /// [`LasWriteOptions::carry_extra_bytes`]; empty: none).
    pub carried_extra: CarriedExtraBytes,
}

impl LasWriteOptions {
    /// The SPEC §7 output for `input`: LAS 1.4, the input's point format when it has GPS time
    /// (waveform formats mapped to their non-waveform twin: 4→1, 5→3, 9→6, 10→7), point format 6
    /// otherwise; the input's scale, offset, time base and CRS VLRs; the given f32 extra
    /// dimensions.
    pub fn for_input(input: &LasInfo, extra_dims: &[(&str, &str)]) -> Self {
        let point_format = if input.has_gps_time {
            match input.point_format {
                4 => 1,
                5 => 3,
                9 => 6,
                10 => 7,
                f => f,
            }
        } else {
            6
        };
        LasWriteOptions {
            version_minor: 4,
            point_format,
            scale: input.scale,
            offset: input.offset,
            time_base: if input.has_gps_time {
                input.time_base
            } else {
                LasTimeBase::AdjustedStandard
            },
            crs_vlrs: input.crs.vlrs.clone(),
            extra_dims: extra_dims
                .iter()
                .map(|(n, d)| (n.to_string(), d.to_string()))
                .collect(),
            extra_dims_f64: Vec::new(),
            file_source_id: 0,
            carried_extra: CarriedExtraBytes::default(),
        }
    }

    /// Carries `input`'s own extra bytes into the output ahead of the dimensions already named
    /// (`extra_dims`, `extra_dims_f64`: set them first): the input's descriptors go ahead of
    /// lidarqa's in the extra-bytes VLR and each record's extra bytes are copied unchanged by
    /// [`RawChunk::push`] and [`LasWriter::write_raw`]. An input dimension named as one of
    /// lidarqa's is renamed with the suffix `_input`. Returns the warning that says so
    /// (`extra_bytes_renamed`), or, when the records would outgrow the 65 535 bytes a LAS
    /// record can have, the warning that nothing is carried to `output`
    /// ([`LasInfo::extra_bytes_not_carried`]).
    pub fn carry_extra_bytes(
        &mut self,
        input: &LasInfo,
        output: &Path,
    ) -> Option<lidarqa_model::Warning> {
        self.carried_extra = CarriedExtraBytes::default();
        if input.extra_bytes_len == 0 {
            return None;
        }
        let base = las::point::Format::new(self.point_format).map_or(0, |f| usize::from(f.len()));
        let own_len = 4 * self.extra_dims.len() + 8 * self.extra_dims_f64.len();
        if base + own_len + input.extra_bytes_len > usize::from(u16::MAX) {
            return input.extra_bytes_not_carried(
                output,
                &format!(
                    "{} bytes a record with lidarqa's {own_len} would exceed the 65 535 of a LAS \
                     record",
                    input.extra_bytes_len
                ),
            );
        }
        let own: Vec<&str> = self
            .extra_dims
            .iter()
            .chain(&self.extra_dims_f64)
            .map(|(n, _)| n.as_str())
            .collect();
        self.carried_extra = CarriedExtraBytes::new(&input.extra_dims, input.extra_bytes_len, &own);
        let renamed = &self.carried_extra.renamed;
        (!renamed.is_empty()).then(|| {
            let pairs: Vec<String> = renamed
                .iter()
                .map(|(a, b)| format!("`{a}` as `{b}`"))
                .collect();
            lidarqa_model::Warning::new(
                "extra_bytes_renamed",
                format!(
                    "{}: its own extra-bytes dimensions are carried into {}, {} (lidarqa writes \
                     a dimension of that name itself)",
                    input.path.display(),
                    output.display(),
                    pairs.join(", ")
                ),
            )
        })
    }

    fn header(&self, path: &Path) -> Result<las::Header> {
        let invalid = |message: String| Error::InvalidLas {
            path: path.to_path_buf(),
            message,
        };
        if !(2..=4).contains(&self.version_minor) {
            return Err(invalid(format!(
                "cannot write LAS 1.{}: lidarqa writes 1.2, 1.3 and 1.4",
                self.version_minor
            )));
        }
        if matches!(self.point_format, 4 | 5 | 9 | 10) {
            return Err(invalid(format!(
                "cannot write waveform point format {}",
                self.point_format
            )));
        }
        let mut seen = std::collections::HashSet::new();
        for (name, description) in self.extra_dims.iter().chain(&self.extra_dims_f64) {
            if name.is_empty() || name.len() > 32 || description.len() > 32 {
                return Err(invalid(format!(
                    "extra-bytes name `{name}` / description `{description}` must be 1–32 and \
                     0–32 bytes"
                )));
            }
            if !seen.insert(name) {
                return Err(invalid(format!("extra-bytes name `{name}` given twice")));
            }
        }
        if self.scale.iter().any(|s| !(s.is_finite() && *s > 0.0))
            || self.offset.iter().any(|o| !o.is_finite())
        {
            return Err(invalid(format!(
                "scale {:?} must be positive and offset {:?} finite",
                self.scale, self.offset
            )));
        }
        let mut format =
            las::point::Format::new(self.point_format).map_err(|e| Error::las(path, e))?;
        format.extra_bytes = u16::try_from(
            self.carried_extra.len() + 4 * self.extra_dims.len() + 8 * self.extra_dims_f64.len(),
        )
        .map_err(|_| invalid("too many extra-bytes dimensions".into()))?;
        format.is_compressed = is_laz(path);
        let mut b = las::Builder::from(las::Header::default());
        b.version = las::Version::new(1, self.version_minor);
        b.point_format = format;
        b.system_identifier = "lidarqa".into();
        b.generating_software = format!("lidarqa {}", env!("CARGO_PKG_VERSION"));
        b.file_source_id = self.file_source_id;
        b.gps_time_type = match self.time_base {
            LasTimeBase::AdjustedStandard => las::GpsTimeType::Standard,
            LasTimeBase::GpsWeekSeconds => las::GpsTimeType::Week,
        };
        let tr = |i: usize| las::Transform {
            scale: self.scale[i],
            offset: self.offset[i],
        };
        b.transforms = las::Vector {
            x: tr(0),
            y: tr(1),
            z: tr(2),
        };
        for v in &self.crs_vlrs {
            b.vlrs.push(las::Vlr::from(v));
        }
        // The WKT bit is defined from LAS 1.4 on (and required there for formats 6–10).
        b.has_wkt_crs =
            self.version_minor >= 4 && self.crs_vlrs.iter().any(|v| v.record_id == 2112);
        let carried = &self.carried_extra.descriptors;
        if !(self.extra_dims.is_empty() && self.extra_dims_f64.is_empty() && carried.is_empty()) {
            let n = carried.len() + self.extra_dims.len() + self.extra_dims_f64.len();
            let mut data = Vec::with_capacity(EXTRA_BYTES_DESCRIPTOR_LEN * n);
            for d in carried {
                data.extend_from_slice(d);
            }
            for (name, description) in &self.extra_dims {
                data.extend_from_slice(&descriptor(EB_F32, name, description));
            }
            for (name, description) in &self.extra_dims_f64 {
                data.extend_from_slice(&descriptor(EB_F64, name, description));
            }
            b.vlrs.push(las::Vlr {
                user_id: EXTRA_BYTES_USER.into(),
                record_id: EXTRA_BYTES_RECORD,
                description: "lidarqa extra bytes".into(),
                data,
            });
        }
        b.into_header().map_err(|e| Error::las(path, e))
    }
}

fn is_laz(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("laz"))
}

/// The scan angle to hand to `las` so that it stores the nearest 0.006° step.
///
/// las 0.11 converts with `(deg / 0.006) as i16`, which truncates toward zero and loses up to
/// one step; the spec's value is the rounded one. Handing it the nearest step plus half a step
/// away from zero makes the truncation land on that step whatever the f32 rounding, and the
/// legacy formats' whole-degree rank (rounded by las from the same value) is unchanged.
fn scan_angle_for_las(deg: f32) -> f32 {
    const STEP: f32 = 0.006;
    let k = (deg / STEP).round();
    if k == 0.0 {
        0.0
    } else {
        k * STEP + 0.5 * STEP * k.signum()
    }
}

/// Writes a LAS/LAZ file atomically; see the module docs.
pub struct LasWriter {
    inner: las::Writer<BufWriter<Sink>>,
    path: PathBuf,
    format: las::point::Format,
    n_extra: usize,
    n_extra_f64: usize,
    /// The input's extra bytes carried ahead of lidarqa's values, per record.
    carried: usize,
    index: u64,
    /// Encoded records not yet handed to `las`: they go in batches of [`WRITE_BATCH_POINTS`]
    /// so that the parallel LAZ compressor has whole chunks to spread over the cores. The same
    /// buffer serves every batch (a fresh one each time came from `mmap`, page faults and all).
    pending: las::PointData,
    /// One record encoded by [`LasWriter::write_point_f64`] before it joins `pending`.
    scratch: Vec<u8>,
}

/// Points a [`LasWriter`] encodes before it hands them to `las` in one slab: several LAZ chunks
/// (50 000 points each), so `las`'s parallel compressor (`laz-parallel`) uses every core, and a
/// bounded buffer (a few tens of MB).
pub const WRITE_BATCH_POINTS: usize = 200_000;

impl LasWriter {
    /// Starts writing `path` (LAZ when it ends in `.laz`, any case), refusing to overwrite any
    /// of `inputs`.
    ///
    /// # Errors
    /// [`Error::OutputIsInput`], [`Error::InvalidLas`] for bad options, [`Error::Las`],
    /// [`Error::Io`].
    pub fn create<P: AsRef<Path>>(
        path: impl AsRef<Path>,
        options: &LasWriteOptions,
        inputs: &[P],
    ) -> Result<Self> {
        let path = path.as_ref();
        let header = options.header(path)?;
        let format = *header.point_format();
        let file = Sink::new(AtomicFile::create(path, inputs)?);
        let inner =
            las::Writer::new(BufWriter::new(file), header).map_err(|e| Error::las(path, e))?;
        let pending = las::PointDataBuilder::new()
            .for_header(inner.header())
            .build();
        Ok(LasWriter {
            inner,
            path: path.to_path_buf(),
            format,
            n_extra: options.extra_dims.len(),
            n_extra_f64: options.extra_dims_f64.len(),
            carried: options.carried_extra.len(),
            index: 0,
            pending,
            scratch: Vec::new(),
        })
    }

    /// Appends a point with its extra-bytes values (one per dimension, in option order); the
    /// bytes carried from an input ([`LasWriteOptions::carried_extra`]) are zeros.
    ///
    /// # Errors
    /// [`Error::PointMismatch`] when the point lacks an attribute the format needs (GPS time,
    /// colour, NIR) or has the wrong number of extra values; [`Error::LasPoint`] when `las`
    /// rejects it (coordinates beyond the i32 range of the scale/offset, a class or return
    /// number the format cannot hold).
    pub fn write_point(&mut self, p: &LasPoint, extra: &[f32]) -> Result<()> {
        self.write_point_f64(p, extra, &[])
    }

    /// As [`LasWriter::write_point`], with the values of the f64 dimensions
    /// ([`LasWriteOptions::extra_dims_f64`]) after the f32 ones.
    ///
    /// # Errors
    /// As [`LasWriter::write_point`].
    pub fn write_point_f64(&mut self, p: &LasPoint, extra: &[f32], extra64: &[f64]) -> Result<()> {
        let mismatch = |message: String| Error::PointMismatch {
            path: self.path.clone(),
            index: self.index,
            message,
        };
        self.check_extra(extra.len(), extra64.len())?;
        let f = &self.format;
        let gps_time = match (f.has_gps_time, p.gps_time_s) {
            (true, None) => return Err(mismatch("the point format needs a GPS time".into())),
            (true, Some(t)) => Some(t),
            (false, _) => None,
        };
        let color = match (f.has_color, p.rgb) {
            (true, None) => return Err(mismatch("the point format needs a colour".into())),
            (true, Some([r, g, b])) => Some(las::Color::new(r, g, b)),
            (false, _) => None,
        };
        let nir = match (f.has_nir, p.nir) {
            (true, None) => return Err(mismatch("the point format needs NIR".into())),
            (true, n) => n,
            (false, _) => None,
        };
        let classification =
            las::point::Classification::new(p.classification).map_err(|source| {
                Error::LasPoint {
                    path: self.path.clone(),
                    index: self.index,
                    source,
                }
            })?;
        if !(p.scan_angle_deg.is_finite() && p.scan_angle_deg.abs() <= 180.0) {
            return Err(mismatch(format!(
                "scan angle {}° is outside ±180°",
                p.scan_angle_deg
            )));
        }
        let mut extra_bytes = vec![0; self.carried + 4 * extra.len() + 8 * extra64.len()];
        encode_extra(&mut extra_bytes[self.carried..], extra, extra64);
        let point = las::Point {
            x: p.x,
            y: p.y,
            z: p.z,
            intensity: p.intensity,
            return_number: p.return_number,
            number_of_returns: p.number_of_returns,
            scan_direction: if p.scan_direction_positive {
                las::point::ScanDirection::LeftToRight
            } else {
                las::point::ScanDirection::RightToLeft
            },
            is_edge_of_flight_line: p.edge_of_flight_line,
            classification,
            is_synthetic: p.synthetic,
            is_key_point: p.key_point,
            is_withheld: p.withheld,
            is_overlap: p.overlap,
            scanner_channel: p.scanner_channel,
            scan_angle: scan_angle_for_las(p.scan_angle_deg),
            user_data: p.user_data,
            point_source_id: p.point_source_id,
            gps_time,
            color,
            waveform: None,
            nir,
            extra_bytes,
        };
        if !point.matches(&self.format) {
            return Err(mismatch(format!(
                "the point's attributes do not match point format {}",
                self.format
            )));
        }
        // A point that does not convert (a coordinate beyond the i32 range) leaves the writer
        // usable: nothing of it is buffered.
        let raw = point
            .into_raw(self.inner.header().transforms())
            .map_err(|source| Error::LasPoint {
                path: self.path.clone(),
                index: self.index,
                source,
            })?;
        self.scratch.clear();
        if let Err(source) = raw.write_to(&mut self.scratch, &self.format) {
            return Err(Error::LasPoint {
                path: self.path.clone(),
                index: self.index,
                source,
            });
        }
        let n = self.pending.len();
        let len = self.pending.record_len();
        self.pending.resize_for(n + 1)[n * len..].copy_from_slice(&self.scratch);
        self.index += 1;
        if self.pending.len() >= WRITE_BATCH_POINTS {
            self.flush_pending()?;
        }
        Ok(())
    }

    /// An empty chunk in this file's layout (point format and scale/offset), to fill with
    /// [`RawChunk::push`] and write with [`LasWriter::write_raw`].
    pub fn raw_chunk(&self) -> RawChunk {
        RawChunk::with_layout(
            las::PointDataBuilder::new()
                .for_header(self.inner.header())
                .build(),
            self.carried,
            self.n_extra,
            self.n_extra_f64,
        )
    }

    /// Refuses extra-bytes values that do not match the dimensions.
    fn check_extra(&self, n32: usize, n64: usize) -> Result<()> {
        if n32 == self.n_extra && n64 == self.n_extra_f64 {
            return Ok(());
        }
        Err(Error::PointMismatch {
            path: self.path.clone(),
            index: self.index,
            message: if self.n_extra_f64 == 0 && n64 == 0 {
                format!("{n32} extra-bytes values for {} dimensions", self.n_extra)
            } else {
                format!(
                    "{n32} f32 + {n64} f64 extra-bytes values for {} + {} dimensions",
                    self.n_extra, self.n_extra_f64
                )
            },
        })
    }

    fn raw_mismatch(&self, chunk: &RawChunk) -> Error {
        let data = &chunk.data;
        Error::PointMismatch {
            path: self.path.clone(),
            index: self.index,
            message: format!(
                "records of point format {} and scale/offset {:?} cannot be written as format {} \
                 with {:?}",
                data.format(),
                data.transforms(),
                self.format,
                self.inner.header().transforms()
            ),
        }
    }

    /// Writes the records of `chunk` (read from a file by
    /// [`LasReader::fill_raw`](super::reader::LasReader::fill_raw)) as they are, but for the
    /// fields this file's point format does not have: a record of the input's format is cut to
    /// this one when this one is its prefix (the same base, time and colour, without the
    /// waveform packet, NIR or extra bytes that follow them), e.g. `correct`'s output of a
    /// format 9 input in format 6; the record's extra bytes stay when this file carries them
    /// ([`LasWriteOptions::carry_extra_bytes`], and no value of lidarqa's follows them). Earlier
    /// points given to [`LasWriter::write_point`] come first.
    ///
    /// # Errors
    /// [`Error::PointMismatch`] when the formats or the scale and offset differ otherwise;
    /// [`Error::LasPoint`] when `las` cannot write them.
    pub fn write_raw(&mut self, chunk: &RawChunk) -> Result<()> {
        let data = &chunk.data;
        let (out, inp) = (self.format, *data.format());
        // The input's extra bytes kept at the end of each record (0: none).
        let carried = usize::from(out.extra_bytes);
        let carries =
            self.carried > 0 && self.carried == carried && usize::from(inp.extra_bytes) == carried;
        let prefix = is_prefix(&out, &inp) && (out.extra_bytes == 0 || carries)
            || out.len() == inp.len() && {
                let mut same = inp;
                same.is_compressed = out.is_compressed;
                same == out
            };
        if !prefix || data.transforms() != self.inner.header().transforms() {
            return Err(self.raw_mismatch(chunk));
        }
        self.flush_pending()?;
        let (out_len, in_len) = (usize::from(out.len()), usize::from(inp.len()));
        if out_len == in_len {
            let first = self.index;
            self.inner
                .write_points(data)
                .map_err(|source| Error::LasPoint {
                    path: self.path.clone(),
                    index: first,
                    source,
                })?;
            self.index += data.len() as u64;
            Ok(())
        } else {
            let mut bytes = Vec::with_capacity(out_len * data.len());
            for r in data.raw_bytes().chunks_exact(in_len) {
                bytes.extend_from_slice(&r[..out_len - carried]);
                bytes.extend_from_slice(&r[in_len - carried..]);
            }
            self.write_slab(bytes)
        }
    }

    /// Hands the buffered records to `las` in one slab (header statistics and LAZ chunks).
    fn flush_pending(&mut self) -> Result<()> {
        if self.pending.is_empty() {
            return Ok(());
        }
        let first = self.index - self.pending.len() as u64;
        let written = self.inner.write_points(&self.pending);
        self.pending.resize_for(0);
        written.map_err(|source| Error::LasPoint {
            path: self.path.clone(),
            index: first,
            source,
        })
    }

    /// Appends whole records already encoded in this file's point format, scale and offset
    /// (`records.len()` a multiple of the record length), after the points given before: for a
    /// producer that encodes its own records (the simulator, without a `las::Point` per point).
    /// They go to `las` as one slab, so give them in [`WRITE_BATCH_POINTS`] for the parallel
    /// LAZ compressor.
    ///
    /// # Errors
    /// [`Error::PointMismatch`] for bytes that are not whole records; [`Error::LasPoint`] when
    /// `las` cannot write them.
    pub fn write_records(&mut self, records: Vec<u8>) -> Result<()> {
        let len = usize::from(self.format.len());
        if records.len() % len != 0 {
            return Err(Error::PointMismatch {
                path: self.path.clone(),
                index: self.index,
                message: format!(
                    "{} bytes are not whole records of point format {} ({len} bytes each)",
                    records.len(),
                    self.format
                ),
            });
        }
        self.flush_pending()?;
        self.write_slab(records)
    }

    /// Hands `bytes`, whole records of this file's layout, to `las` as one slab, after the
    /// points given before.
    fn write_slab(&mut self, bytes: Vec<u8>) -> Result<()> {
        let (first, n) = (self.index, bytes.len() / usize::from(self.format.len()));
        las::PointDataBuilder::new()
            .for_header(self.inner.header())
            .build_from_bytes(bytes)
            .and_then(|data| self.inner.write_points(&data))
            .map_err(|source| Error::LasPoint {
                path: self.path.clone(),
                index: first,
                source,
            })?;
        self.index += n as u64;
        Ok(())
    }

    /// Points written so far.
    pub fn len(&self) -> u64 {
        self.index
    }

    /// Whether no point was written yet.
    pub fn is_empty(&self) -> bool {
        self.index == 0
    }

    /// Completes the header, flushes, and renames the file into place; returns the point count.
    ///
    /// # Errors
    /// [`Error::Las`] / [`Error::Io`] naming the file; nothing is left at the path then.
    pub fn finish(self) -> Result<u64> {
        let (file, n) = self.finish_uncommitted()?;
        file.commit()?;
        Ok(n)
    }

    /// As [`LasWriter::finish`], but leaves the complete file at its temporary path: committing
    /// the returned [`AtomicFile`] puts it in place, dropping it removes it (so that several
    /// files appear all together or not at all). Also returns the point count.
    ///
    /// # Errors
    /// As [`LasWriter::finish`].
    pub fn finish_uncommitted(mut self) -> Result<(AtomicFile, u64)> {
        self.flush_pending()?;
        let LasWriter {
            inner, path, index, ..
        } = self;
        let buffered = inner.into_inner().map_err(|e| Error::las(&path, e))?;
        let sink = buffered
            .into_inner()
            .map_err(|e| Error::io(&path, e.into_error()))?;
        // An error las or BufWriter did not pass on still fails the file.
        if let Some((kind, message)) = sink.error {
            return Err(Error::io(&path, std::io::Error::new(kind, message)));
        }
        Ok((sink.file, index))
    }
}

/// The file under a [`LasWriter`]'s buffer. `las::Writer` finishes the file in its `Drop` and
/// panics if that fails, and its `into_inner` drops it after a failed close: on a full disk
/// both would panic. So after the first I/O error a `Sink` remembers it and accepts every later
/// write and seek without touching the file (keeping a plausible position); the caller gets
/// the first error, [`LasWriter::finish`] reports it and the temporary file is removed.
struct Sink {
    file: AtomicFile,
    /// The first I/O error (kind, message); then everything is discarded.
    error: Option<(std::io::ErrorKind, String)>,
    /// Position and length as the writer sees them.
    pos: u64,
    len: u64,
}

impl Sink {
    fn new(file: AtomicFile) -> Sink {
        Sink {
            file,
            error: None,
            pos: 0,
            len: 0,
        }
    }

    fn advance(&mut self, n: usize) {
        self.pos = self.pos.saturating_add(n as u64);
        self.len = self.len.max(self.pos);
    }

    fn fail(&mut self, e: &std::io::Error) {
        if self.error.is_none() {
            self.error = Some((e.kind(), e.to_string()));
        }
    }
}

impl std::io::Write for Sink {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if self.error.is_some() {
            self.advance(buf.len());
            return Ok(buf.len());
        }
        match self.file.write(buf) {
            Ok(n) => {
                self.advance(n);
                Ok(n)
            }
            Err(e) => {
                self.fail(&e);
                Err(e)
            }
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        if self.error.is_some() {
            return Ok(());
        }
        self.file.flush().inspect_err(|e| self.fail(e))
    }
}

impl Seek for Sink {
    fn seek(&mut self, to: std::io::SeekFrom) -> std::io::Result<u64> {
        use std::io::SeekFrom;
        if self.error.is_some() {
            self.pos = match to {
                SeekFrom::Start(n) => n,
                SeekFrom::Current(d) => self.pos.saturating_add_signed(d),
                SeekFrom::End(d) => self.len.saturating_add_signed(d),
            };
            return Ok(self.pos);
        }
        match self.file.seek(to) {
            Ok(p) => {
                self.pos = p;
                self.len = self.len.max(p);
                Ok(p)
            }
            Err(e) => {
                self.fail(&e);
                Err(e)
            }
        }
    }
}

// las::Writer is not Debug; show what identifies the file.
impl std::fmt::Debug for LasWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LasWriter")
            .field("path", &self.path)
            .field("points", &self.index)
            .finish_non_exhaustive()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What las 0.11 stores for an f32 angle: `(deg / 0.006) as i16`.
    fn las_steps(deg: f32) -> i16 {
        (deg / 0.006) as i16
    }

    #[test]
    fn scan_angle_is_rounded_to_the_nearest_step() {
        for (deg, steps) in [
            (0.0059_f32, 1_i16),
            (-0.0059, -1),
            (0.0029, 0),
            (-14.994, -2499),
            (14.9971, 2500),
            (180.0, 30000),
            (-180.0, -30000),
        ] {
            assert_eq!(las_steps(scan_angle_for_las(deg)), steps, "{deg}");
        }
        // Without the correction las would truncate 0.0059° to 0.
        assert_eq!(las_steps(0.0059), 0);
    }
}
