//! The LAS 1.4 extra-bytes VLR (user `LASF_Spec`, record 4), by hand: las 0.11 has no type for
//! it (see the parent module's docs). Decodes its 192-byte descriptors into [`ExtraDim`]s and
//! builds the f32/f64 descriptors the writer puts in outputs (LAS 1.4 R15 §2.5.8, table 24).

use crate::error::{Error, Result};
use std::path::Path;

/// Extra-bytes VLR: user id, record id and descriptor length (LAS 1.4 R15 §2.5.8).
pub(super) const EXTRA_BYTES_USER: &str = "LASF_Spec";
pub(super) const EXTRA_BYTES_RECORD: u16 = 4;
pub(super) const EXTRA_BYTES_DESCRIPTOR_LEN: usize = 192;
/// Extra-bytes data type code of f32 (table 25).
pub(super) const EB_F32: u8 = 9;
/// Extra-bytes data type code of f64.
pub(super) const EB_F64: u8 = 10;

/// One extra-bytes dimension of a file.
#[derive(Clone, Debug, PartialEq)]
pub struct ExtraDim {
    /// Name, e.g. `sigma_up`.
    pub name: String,
    /// Description, e.g. `1-sigma vertical TPU (m)`.
    pub description: String,
    /// LAS data type code (1 u8 … 9 f32, 10 f64; 0 = untyped bytes).
    pub data_type: u8,
    /// Byte offset inside the point's extra bytes.
    pub offset: usize,
    /// Size in bytes.
    pub size: usize,
    /// Scale applied on read (value = raw · scale + offset), 1 when the descriptor has none.
    pub scale: f64,
    /// Offset applied on read, 0 when the descriptor has none.
    pub value_offset: f64,
    /// The descriptor as the file stores it, for an output that carries the dimension.
    pub(super) descriptor: [u8; EXTRA_BYTES_DESCRIPTOR_LEN],
}

impl ExtraDim {
    /// Decodes this dimension from a point's extra bytes; `None` for untyped or array types.
    pub(super) fn decode(&self, bytes: &[u8]) -> Option<f64> {
        let b = bytes.get(self.offset..self.offset + self.size)?;
        let raw = match self.data_type {
            1 => f64::from(b[0]),
            2 => f64::from(b[0] as i8),
            3 => f64::from(u16::from_le_bytes([b[0], b[1]])),
            4 => f64::from(i16::from_le_bytes([b[0], b[1]])),
            5 => f64::from(u32::from_le_bytes(b.try_into().ok()?)),
            6 => f64::from(i32::from_le_bytes(b.try_into().ok()?)),
            7 => u64::from_le_bytes(b.try_into().ok()?) as f64,
            8 => i64::from_le_bytes(b.try_into().ok()?) as f64,
            9 => f64::from(f32::from_le_bytes(b.try_into().ok()?)),
            10 => f64::from_le_bytes(b.try_into().ok()?),
            _ => return None,
        };
        Some(raw * self.scale + self.value_offset)
    }

    /// Whether `other` stores its values as this dimension does, so that one descriptor serves
    /// both files' records: the same position and size, and descriptors equal in type, name,
    /// options, no-data, scale, offset and description. The minimum and maximum (and the
    /// options bits saying they are present) may differ: each file records those of its own
    /// values.
    pub fn same_layout(&self, other: &ExtraDim) -> bool {
        let kept = |d: &[u8; EXTRA_BYTES_DESCRIPTOR_LEN]| {
            let mut d = *d;
            d[3] &= !0b110; // options bits 1 and 2: min, max present (table 24)
            d[64..112].fill(0); // min[3], max[3]
            d
        };
        self.offset == other.offset
            && self.size == other.size
            && kept(&self.descriptor) == kept(&other.descriptor)
    }
}

/// Size in bytes of extra-bytes data type `t` with `options` (untyped: `options` bytes).
fn eb_size(t: u8, options: u8) -> Option<usize> {
    Some(match t {
        0 => usize::from(options),
        1 | 2 => 1,
        3 | 4 => 2,
        5 | 6 | 9 => 4,
        7 | 8 | 10 => 8,
        // Deprecated 2- and 3-element arrays (11–20, 21–30).
        11..=20 => 2 * eb_size(t - 10, 0)?,
        21..=30 => 3 * eb_size(t - 20, 0)?,
        _ => return None,
    })
}

fn las_string(b: &[u8]) -> String {
    let end = b.iter().position(|&c| c == 0).unwrap_or(b.len());
    String::from_utf8_lossy(&b[..end]).into_owned()
}

/// Parses the extra-bytes VLR into dimensions, checking them against the record's extra length.
pub(super) fn parse_extra_dims(path: &Path, header: &las::Header) -> Result<Vec<ExtraDim>> {
    let Some(vlr) = header
        .all_vlrs()
        .find(|v| v.user_id == EXTRA_BYTES_USER && v.record_id == EXTRA_BYTES_RECORD)
    else {
        return Ok(Vec::new());
    };
    let invalid = |message: String| Error::InvalidLas {
        path: path.to_path_buf(),
        message,
    };
    if vlr.data.len() % EXTRA_BYTES_DESCRIPTOR_LEN != 0 {
        return Err(invalid(format!(
            "extra-bytes vlr of {} bytes is not a multiple of {EXTRA_BYTES_DESCRIPTOR_LEN}",
            vlr.data.len()
        )));
    }
    let mut dims = Vec::new();
    let mut offset = 0;
    for d in vlr.data.chunks_exact(EXTRA_BYTES_DESCRIPTOR_LEN) {
        let data_type = d[2];
        let options = d[3];
        let name = las_string(&d[4..36]);
        let size = eb_size(data_type, options).ok_or_else(|| {
            invalid(format!(
                "extra-bytes dimension `{name}` has unknown data type {data_type}"
            ))
        })?;
        let f = |r: std::ops::Range<usize>| {
            let mut b = [0u8; 8];
            b.copy_from_slice(&d[r]);
            f64::from_le_bytes(b)
        };
        // Options bit 3: scale present; bit 4: offset present (table 24).
        let scale = if options & 0b1000 != 0 {
            f(112..120)
        } else {
            1.0
        };
        let value_offset = if options & 0b1_0000 != 0 {
            f(136..144)
        } else {
            0.0
        };
        dims.push(ExtraDim {
            name,
            description: las_string(&d[160..192]),
            data_type,
            offset,
            size,
            scale,
            value_offset,
            descriptor: d.try_into().unwrap_or([0; EXTRA_BYTES_DESCRIPTOR_LEN]),
        });
        offset += size;
    }
    let available = usize::from(header.point_format().extra_bytes);
    if offset > available {
        return Err(invalid(format!(
            "extra-bytes vlr describes {offset} bytes per point but records have {available}"
        )));
    }
    Ok(dims)
}

/// Builds one f32 extra-bytes descriptor (LAS 1.4 R15 table 24).
pub(super) fn descriptor(
    data_type: u8,
    name: &str,
    description: &str,
) -> [u8; EXTRA_BYTES_DESCRIPTOR_LEN] {
    let mut d = [0u8; EXTRA_BYTES_DESCRIPTOR_LEN];
    d[2] = data_type;
    d[4..4 + name.len()].copy_from_slice(name.as_bytes());
    d[160..160 + description.len()].copy_from_slice(description.as_bytes());
    d
}

/// An input's own extra bytes as an output carries them: every record's extra bytes copied
/// unchanged ahead of lidarqa's own values, and the input's descriptors ahead of lidarqa's in
/// the extra-bytes VLR, a name lidarqa writes itself renamed ([`CarriedExtraBytes::renamed`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CarriedExtraBytes {
    /// The descriptors, as the input stores them but for a renamed name; bytes the input does
    /// not describe get an untyped descriptor (`input_extra_bytes`).
    pub(super) descriptors: Vec<[u8; EXTRA_BYTES_DESCRIPTOR_LEN]>,
    /// Bytes carried per record: all the input's extra bytes.
    pub(super) len: usize,
    /// (input name, output name) of each dimension renamed because lidarqa writes a dimension
    /// of that name itself.
    pub renamed: Vec<(String, String)>,
}

impl CarriedExtraBytes {
    /// The extra bytes of records of `extra_len` bytes described by `dims` (the input's), each
    /// name in `own` (lidarqa's dimensions) or met before renamed with the suffix `_input`
    /// (cut to 32 bytes, then numbered if still taken).
    pub(super) fn new(dims: &[ExtraDim], extra_len: usize, own: &[&str]) -> Self {
        let mut taken: std::collections::HashSet<String> =
            own.iter().map(|n| (*n).to_string()).collect();
        let mut renamed = Vec::new();
        let mut descriptors = Vec::with_capacity(dims.len() + 1);
        let free_name = |name: &str, taken: &mut std::collections::HashSet<String>| {
            let mut k = 1;
            let mut candidate = name.to_string();
            while taken.contains(&candidate) {
                let suffix = if k == 1 {
                    "_input".to_string()
                } else {
                    format!("_input{k}")
                };
                let mut stem = name.to_string();
                while stem.len() + suffix.len() > 32 {
                    stem.pop();
                }
                candidate = stem + &suffix;
                k += 1;
            }
            taken.insert(candidate.clone());
            candidate
        };
        let mut described = 0;
        for d in dims {
            let mut descriptor = d.descriptor;
            let name = free_name(&d.name, &mut taken);
            if name != d.name {
                descriptor[4..36].fill(0);
                descriptor[4..4 + name.len()].copy_from_slice(name.as_bytes());
                renamed.push((d.name.clone(), name));
            }
            descriptors.push(descriptor);
            described = described.max(d.offset + d.size);
        }
        // Bytes after the described ones: untyped descriptors of up to 255 bytes each.
        let mut rest = extra_len.saturating_sub(described);
        let mut k = 1;
        while rest > 0 {
            let n = rest.min(255);
            let base = if k == 1 {
                "input_extra_bytes".to_string()
            } else {
                format!("input_extra_bytes{k}")
            };
            k += 1;
            let name = free_name(&base, &mut taken);
            let mut d = descriptor(0, &name, "undescribed bytes of the input");
            d[3] = n as u8;
            descriptors.push(d);
            rest -= n;
        }
        CarriedExtraBytes {
            descriptors,
            len: extra_len,
            renamed,
        }
    }

    /// Bytes carried per record (0: nothing carried).
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether nothing is carried.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// Whether the fields of `out` (its extra bytes aside) are the start of a record of `inp`: the
/// same base, time and colour, `inp` may add NIR, a waveform packet and extra bytes.
pub(super) fn is_prefix(out: &las::point::Format, inp: &las::point::Format) -> bool {
    out.is_extended == inp.is_extended
        && out.has_gps_time == inp.has_gps_time
        && out.has_color == inp.has_color
        && (inp.has_nir || !out.has_nir)
        && !out.has_waveform
}

/// Puts the little-endian bytes of `extra` then `extra64` in `bytes` (4 and 8 bytes each).
pub(super) fn encode_extra(bytes: &mut [u8], extra: &[f32], extra64: &[f64]) {
    let (a, b) = bytes.split_at_mut(4 * extra.len());
    for (t, v) in a.chunks_exact_mut(4).zip(extra) {
        t.copy_from_slice(&v.to_le_bytes());
    }
    for (t, v) in b.chunks_exact_mut(8).zip(extra64) {
        t.copy_from_slice(&v.to_le_bytes());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extra_bytes_descriptor_layout() {
        let d = descriptor(EB_F32, "sigma_up", "1-sigma up (m)");
        assert_eq!(d[2], EB_F32);
        assert_eq!(d[3], 0, "no options: no scale, offset, min, max or no-data");
        assert_eq!(&d[4..12], b"sigma_up");
        assert_eq!(d[12], 0);
        assert_eq!(&d[160..174], b"1-sigma up (m)");
        let dim = ExtraDim {
            name: "v".into(),
            description: String::new(),
            data_type: 4,
            offset: 2,
            size: 2,
            scale: 0.01,
            value_offset: 100.0,
            descriptor: [0; EXTRA_BYTES_DESCRIPTOR_LEN],
        };
        // i16 −250 at byte 2, scale 0.01, offset 100 ⇒ 97.5.
        let bytes = [0, 0, (-250i16).to_le_bytes()[0], (-250i16).to_le_bytes()[1]];
        assert_eq!(dim.decode(&bytes), Some(97.5));
        assert_eq!(dim.decode(&bytes[..3]), None);
        // Another file's min and max do not change the layout; its scale does.
        let mut other = dim.clone();
        other.descriptor[3] |= 0b110;
        other.descriptor[64..72].copy_from_slice(&(-5.0f64).to_le_bytes());
        assert!(dim.same_layout(&other));
        other.descriptor[112..120].copy_from_slice(&0.001f64.to_le_bytes());
        assert!(!dim.same_layout(&other));
    }

    #[test]
    fn carried_extra_bytes_keep_descriptors_and_rename_clashes() {
        let dim = |name: &str, offset: usize, size: usize| {
            let mut d = descriptor(EB_F64, name, "kept as stored");
            d[3] = 0b1000; // a scale present: the descriptor is copied whole
            d[112..120].copy_from_slice(&0.5f64.to_le_bytes());
            ExtraDim {
                name: name.into(),
                description: "kept as stored".into(),
                data_type: EB_F64,
                offset,
                size,
                scale: 0.5,
                value_offset: 0.0,
                descriptor: d,
            }
        };
        let long = "a_name_of_exactly_thirty_two_by_";
        assert_eq!(long.len(), 32);
        let dims = [
            dim("SensorX", 0, 8),
            dim("sigma_up", 8, 8),
            dim(long, 16, 8),
        ];
        // 24 described bytes of 280: 256 undescribed ones follow (255 + 1).
        let c = CarriedExtraBytes::new(&dims, 280, &["sigma_up", long, "sigma_up_input"]);
        assert_eq!(c.len(), 280);
        assert_eq!(c.descriptors.len(), 5);
        assert_eq!(
            c.descriptors[0], dims[0].descriptor,
            "not renamed: copied whole"
        );
        let name = |d: &[u8; EXTRA_BYTES_DESCRIPTOR_LEN]| las_string(&d[4..36]);
        // `sigma_up_input` is taken too: numbered.
        assert_eq!(name(&c.descriptors[1]), "sigma_up_input2");
        assert_eq!(
            &c.descriptors[1][36..],
            &dims[1].descriptor[36..],
            "only the name changes"
        );
        assert_eq!(name(&c.descriptors[2]), "a_name_of_exactly_thirty_t_input");
        assert_eq!(
            c.renamed,
            [
                ("sigma_up".to_string(), "sigma_up_input2".to_string()),
                (
                    long.to_string(),
                    "a_name_of_exactly_thirty_t_input".to_string()
                ),
            ]
        );
        assert_eq!((c.descriptors[3][2], c.descriptors[3][3]), (0, 255));
        assert_eq!((c.descriptors[4][2], c.descriptors[4][3]), (0, 1));
        assert_eq!(name(&c.descriptors[3]), "input_extra_bytes");
        assert_eq!(name(&c.descriptors[4]), "input_extra_bytes2");
        assert!(CarriedExtraBytes::new(&[], 0, &[]).is_empty());
    }
}
