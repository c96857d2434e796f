//! The header facts of a LAS/LAZ file ([`LasInfo`]).

use super::extra_bytes::{ExtraDim, parse_extra_dims};
use crate::crs::{Crs, LasCrs};
use crate::error::{Error, Result};
use crate::gpstime::{CivilDate, LasTimeBase};
use std::path::{Path, PathBuf};

/// Header facts of a LAS/LAZ file.
#[derive(Clone, Debug, PartialEq)]
pub struct LasInfo {
    /// The file.
    pub path: PathBuf,
    /// LAS version (major, minor), e.g. (1, 4).
    pub version: (u8, u8),
    /// Point data record format, 0–10.
    pub point_format: u8,
    /// Whether the points are LAZ-compressed.
    pub compressed: bool,
    /// Number of point records the header claims.
    pub point_count: u64,
    /// Bounds minimum (x, y, z), CRS units.
    pub min: [f64; 3],
    /// Bounds maximum (x, y, z), CRS units.
    pub max: [f64; 3],
    /// Scale factors (x, y, z).
    pub scale: [f64; 3],
    /// Offsets (x, y, z), CRS units.
    pub offset: [f64; 3],
    /// Whether the point format has GPS time.
    pub has_gps_time: bool,
    /// Global encoding bit 0: GPS week time or adjusted standard GPS time.
    pub time_base: LasTimeBase,
    /// File creation date (header day of year and year), `None` when unset (0) or invalid.
    pub creation_date: Option<CivilDate>,
    /// The CRS.
    pub crs: LasCrs,
    /// The extra-bytes dimensions described by the extra-bytes VLR.
    pub extra_dims: Vec<ExtraDim>,
    /// Extra bytes per record, described by [`LasInfo::extra_dims`] or not.
    pub extra_bytes_len: usize,
}

impl LasInfo {
    /// The warning that the file's own extra bytes are not in `output` because `reason`; `None`
    /// when the file has none.
    #[must_use]
    pub fn extra_bytes_not_carried(
        &self,
        output: &Path,
        reason: &str,
    ) -> Option<lidarqa_model::Warning> {
        if self.extra_bytes_len == 0 {
            return None;
        }
        let names: Vec<&str> = self.extra_dims.iter().map(|d| d.name.as_str()).collect();
        let names = if names.is_empty() {
            format!("{} undescribed bytes a point", self.extra_bytes_len)
        } else {
            names.join(", ")
        };
        Some(lidarqa_model::Warning::new(
            "extra_bytes_not_carried",
            format!(
                "{}: its own extra-bytes dimensions ({names}) are not written to {} ({reason}): \
                 keep the input beside the output",
                self.path.display(),
                output.display()
            ),
        ))
    }

    pub(super) fn from_header(path: &Path, header: &las::Header) -> Result<Self> {
        let v = header.version();
        let t = header.transforms();
        let b = header.bounds();
        let format = header.point_format();
        let creation_date = header.date().and_then(|_| {
            let raw = header.clone().into_raw().ok()?;
            CivilDate::from_year_day(
                i32::from(raw.file_creation_year),
                u32::from(raw.file_creation_day_of_year),
            )
            .ok()
        });
        Ok(LasInfo {
            path: path.to_path_buf(),
            version: (v.major, v.minor),
            point_format: format.to_u8().map_err(|e| Error::las(path, e))?,
            compressed: format.is_compressed,
            point_count: header.number_of_points(),
            min: [b.min.x, b.min.y, b.min.z],
            max: [b.max.x, b.max.y, b.max.z],
            scale: [t.x.scale, t.y.scale, t.z.scale],
            offset: [t.x.offset, t.y.offset, t.z.offset],
            has_gps_time: format.has_gps_time,
            time_base: if header.gps_time_type().is_standard() {
                LasTimeBase::AdjustedStandard
            } else {
                LasTimeBase::GpsWeekSeconds
            },
            creation_date,
            crs: LasCrs::from_header(header),
            extra_dims: parse_extra_dims(path, header)?,
            extra_bytes_len: usize::from(format.extra_bytes),
        })
    }

    /// The projected CRS of the file: from its WKT ([`Crs::from_wkt`]) when it has one, else from
    /// the GeoKeys' EPSG code ([`Crs::from_epsg`]).
    ///
    /// # Errors
    /// [`Error::Crs`] naming the file when it has no CRS lidarqa can project with.
    pub fn projected_crs(&self) -> Result<Crs> {
        let crs = match (&self.crs.wkt, self.crs.epsg) {
            (Some(wkt), epsg) => {
                Crs::from_wkt(wkt).or_else(|e| epsg.map_or(Err(e), Crs::from_epsg))
            }
            (None, Some(epsg)) => Crs::from_epsg(epsg),
            (None, None) => {
                return Err(Error::Crs {
                    path: self.path.clone(),
                    message: "no EPSG code in the CRS VLRs (GeoKey 3072 or WKT AUTHORITY)".into(),
                });
            }
        };
        crs.map_err(|e| Error::Crs {
            path: self.path.clone(),
            message: e.to_string(),
        })
    }
}
