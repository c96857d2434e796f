//! Single-band 32-bit float GeoTIFF rasters (dz per line pair, density, σ_up) that a GIS opens in
//! the delivery's CRS.
//!
//! The TIFF itself is written by the `tiff` crate (image-rs, well kept). The three GeoTIFF tags
//! are written by hand through its `write_tag`, because no maintained Rust crate writes GeoKeys:
//! - ModelPixelScaleTag (33550): `[cell, cell, 0]`;
//! - ModelTiepointTag (33922): raster point (0, 0, 0) at model point (west, north, 0), the
//!   upper-left corner of the upper-left pixel;
//! - GeoKeyDirectoryTag (34735), GeoTIFF 1.0 key directory: GTModelTypeGeoKey (1024) = 1
//!   (projected), GTRasterTypeGeoKey (1025) = 1 (PixelIsArea) and ProjectedCSTypeGeoKey (3072) =
//!   the EPSG code; without a code, only the first two (a GIS then asks for the CRS).
//!
//! No-data cells hold −999999 and GDAL_NODATA (42113) says so, as the USGS Lidar Base
//! Specification (version 2.1 onwards) requires of its GeoTIFF deliverables.

use crate::atomic::AtomicFile;
use crate::error::{Error, Result};
use std::io::{Cursor, Write as _};
use std::path::Path;
use tiff::encoder::{TiffEncoder, colortype::Gray32Float};
use tiff::tags::Tag;

/// The value of a cell without data, as GDAL_NODATA states it.
pub const GEOTIFF_NODATA: f32 = -999_999.0;

/// A north-up raster: row 0 is the northern edge; `values[row · width + col]`, `None` where
/// there is no data.
#[derive(Debug, Clone, PartialEq)]
pub struct GeoRaster {
    /// Columns (east).
    pub width: usize,
    /// Rows (south from the top).
    pub height: usize,
    /// West edge of the raster, CRS units (m).
    pub west: f64,
    /// North edge of the raster, CRS units (m).
    pub north: f64,
    /// Cell size, CRS units (m), square cells.
    pub cell: f64,
    /// Horizontal CRS (EPSG code of a projected CRS), when known.
    pub epsg: Option<u32>,
    /// Row-major values from the north-west corner.
    pub values: Vec<Option<f32>>,
}

impl GeoRaster {
    /// The GeoTIFF bytes (module docs).
    ///
    /// # Errors
    /// A raster whose `values` do not hold `width × height` cells, an empty raster, or an
    /// encoding error of the `tiff` crate, each as an I/O error naming `path`.
    pub fn to_bytes(&self, path: &Path) -> Result<Vec<u8>> {
        let fail = |m: String| Error::io(path, std::io::Error::other(m));
        if self.width == 0 || self.height == 0 || self.values.len() != self.width * self.height {
            return Err(fail(format!(
                "raster of {} × {} cells holds {} values",
                self.width,
                self.height,
                self.values.len()
            )));
        }
        let (w, h) = (
            u32::try_from(self.width).map_err(|e| fail(e.to_string()))?,
            u32::try_from(self.height).map_err(|e| fail(e.to_string()))?,
        );
        let data: Vec<f32> = self
            .values
            .iter()
            .map(|v| v.unwrap_or(GEOTIFF_NODATA))
            .collect();
        let mut bytes = Cursor::new(Vec::new());
        let tiff_err = |e: tiff::TiffError| fail(format!("writing the GeoTIFF: {e}"));
        {
            let mut enc = TiffEncoder::new(&mut bytes).map_err(tiff_err)?;
            let mut image = enc.new_image::<Gray32Float>(w, h).map_err(tiff_err)?;
            let d = image.encoder();
            d.write_tag(Tag::ModelPixelScaleTag, &[self.cell, self.cell, 0.0][..])
                .map_err(tiff_err)?;
            d.write_tag(
                Tag::ModelTiepointTag,
                &[0.0, 0.0, 0.0, self.west, self.north, 0.0][..],
            )
            .map_err(tiff_err)?;
            // Header: version 1, revision 1.0, number of keys; then (key, location 0, count 1,
            // value) for each key.
            let mut keys: Vec<u16> = vec![1024, 0, 1, 1, 1025, 0, 1, 1];
            if let Some(epsg) = self.epsg {
                let code = u16::try_from(epsg)
                    .map_err(|_| fail(format!("EPSG code {epsg} does not fit a GeoKey")))?;
                keys.extend([3072, 0, 1, code]);
            }
            let mut dir = vec![1u16, 1, 0, (keys.len() / 4) as u16];
            dir.extend(keys);
            d.write_tag(Tag::GeoKeyDirectoryTag, &dir[..])
                .map_err(tiff_err)?;
            d.write_tag(Tag::GdalNodata, &*format!("{GEOTIFF_NODATA}"))
                .map_err(tiff_err)?;
            image.write_data(&data).map_err(tiff_err)?;
        }
        Ok(bytes.into_inner())
    }

    /// Writes the GeoTIFF to `path` atomically, refusing a path that is one of `inputs`.
    ///
    /// # Errors
    /// As [`GeoRaster::to_bytes`]; I/O errors naming the file; [`Error::OutputIsInput`].
    pub fn write<P: AsRef<Path>>(&self, path: &Path, inputs: &[P]) -> Result<()> {
        let bytes = self.to_bytes(path)?;
        let mut f = AtomicFile::create(path, inputs)?;
        f.write_all(&bytes).map_err(|e| Error::io(path, e))?;
        f.commit()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_tags_read_back_with_the_tiff_decoder() {
        let r = GeoRaster {
            width: 3,
            height: 2,
            west: 500_000.0,
            north: 4_000_010.0,
            cell: 5.0,
            epsg: Some(32617),
            values: vec![Some(1.0), None, Some(3.0), Some(4.0), Some(5.0), Some(6.0)],
        };
        let bytes = r.to_bytes(Path::new("t.tif")).unwrap();
        let mut dec = tiff::decoder::Decoder::new(Cursor::new(bytes)).unwrap();
        assert_eq!(dec.dimensions().unwrap(), (3, 2));
        let scale = dec.get_tag_f64_vec(Tag::ModelPixelScaleTag).unwrap();
        assert_eq!(scale, vec![5.0, 5.0, 0.0]);
        let tie = dec.get_tag_f64_vec(Tag::ModelTiepointTag).unwrap();
        assert_eq!(tie[3..5], [500_000.0, 4_000_010.0]);
        let keys = dec.get_tag_u16_vec(Tag::GeoKeyDirectoryTag).unwrap();
        assert_eq!(keys[3], 3);
        assert_eq!(keys[12..16], [3072, 0, 1, 32617]);
        match dec.read_image().unwrap() {
            tiff::decoder::DecodingResult::F32(v) => {
                assert_eq!(v, vec![1.0, GEOTIFF_NODATA, 3.0, 4.0, 5.0, 6.0]);
            }
            _ => panic!("not f32"),
        }
    }

    #[test]
    fn a_raster_of_the_wrong_size_is_refused() {
        let r = GeoRaster {
            width: 3,
            height: 2,
            west: 0.0,
            north: 0.0,
            cell: 1.0,
            epsg: None,
            values: vec![None; 5],
        };
        let e = r.to_bytes(Path::new("dz.tif")).unwrap_err().to_string();
        assert!(
            e.starts_with("dz.tif: raster of 3 × 2 cells holds 5 values"),
            "{e}"
        );
    }
}
