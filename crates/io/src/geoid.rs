//! Geoid models: the undulation N (ellipsoidal − orthometric height, m) that turns heights in a
//! gravity-related vertical CRS into the ellipsoidal heights the georeferencing needs.
//!
//! - **EGM2008, built in**, from the `egm2008` crate (FlightAware, BSD-3-Clause): NGA's
//!   EGM2008 undulations on a 3° × 3° grid generated with NGA's own interpolation program,
//!   interpolated bilinearly. Exact at the grid nodes; between them the 3° grid smooths the
//!   geoid: 3.3 m off at NGA's published check points in the Sierra Nevada (see the tests),
//!   where the geoid is among the roughest. That is
//!   ample for a TPU — a metre in N moves the points and the trajectory's gap by a metre of
//!   range out of hundreds, which changes no σ at the millimetre — but not for turning heights
//!   to survey accuracy: give the national or EGM2008 1' grid with `--geoid` for that. It is
//!   used for vertical CRSs defined on EGM2008 ([`GeoidModel::for_vertical_crs`]).
//! - **A user grid** (`--geoid FILE`) as PROJ distributes them: NOAA/NGS **GTX** (40-byte
//!   big-endian header: south latitude, west longitude, latitude and longitude spacing in
//!   degrees, rows, columns; then rows × columns big-endian f32 from the south-west corner, row by
//!   row; −88.8888 means no value) and single-band **GeoTIFF** in degrees (ModelPixelScale and
//!   ModelTiepoint tags, pixel-is-area or pixel-is-point by the GTRasterTypeGeoKey, GDAL's
//!   no-data tag), read with the `tiff` crate. GEOID18, CGG2013 / HTv2.0, EGG2015 … come in
//!   these forms. Bilinear between the four nodes around a point; outside the grid or on a
//!   no-data node there is no value (the caller names the point).
//!
//! GTX is written by hand: a fixed header and an array, no crate reads it.

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// No-data value of NOAA's GTX grids.
const GTX_NODATA: f32 = -88.8888;

/// A regular latitude/longitude grid of undulations.
#[derive(Clone, Debug, PartialEq)]
pub struct GeoidGrid {
    path: PathBuf,
    /// Latitude and longitude of node (0, 0), the south-west one, degrees.
    south_deg: f64,
    west_deg: f64,
    /// Spacing, degrees (> 0).
    dlat_deg: f64,
    dlon_deg: f64,
    rows: usize,
    cols: usize,
    /// Row-major from the south: `values[row * cols + col]`, NaN where there is no value.
    values: Vec<f32>,
}

/// The geoid a survey's orthometric heights are turned into ellipsoidal ones with.
#[derive(Clone, Debug, PartialEq)]
pub enum GeoidModel {
    /// EGM2008, built in (see the module docs for its resolution).
    Egm2008,
    /// A grid read from a file.
    Grid(GeoidGrid),
}

impl GeoidModel {
    /// Reads a user grid: GeoTIFF when the file starts with a TIFF signature, else GTX.
    ///
    /// # Errors
    /// [`Error::Io`] and [`Error::Geoid`] naming the file and what is wrong with it.
    pub fn from_file(path: &Path) -> Result<GeoidModel> {
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        let grid = if bytes.starts_with(b"II*\0") || bytes.starts_with(b"MM\0*") {
            GeoidGrid::from_geotiff(path, &bytes)?
        } else {
            GeoidGrid::from_gtx(path, &bytes)?
        };
        Ok(GeoidModel::Grid(grid))
    }

    /// The built-in model of a vertical CRS defined on it: EGM2008 for "EGM2008 height"
    /// (EPSG:3855) and any vertical CRS whose name says EGM2008 / EGM08; `None` for the others
    /// (national datums need their own grid).
    pub fn for_vertical_crs(name: &str) -> Option<GeoidModel> {
        let n = name.to_ascii_uppercase().replace([' ', '_', '-'], "");
        (n.contains("EGM2008") || n.contains("EGM08") || n.contains("EPSG:3855"))
            .then_some(GeoidModel::Egm2008)
    }

    /// N at a geodetic position (radians), metres; `None` outside a grid or on no data.
    pub fn undulation_m(&self, latitude_rad: f64, longitude_rad: f64) -> Option<f64> {
        let (lat, lon) = (latitude_rad.to_degrees(), longitude_rad.to_degrees());
        if !(lat.is_finite() && lon.is_finite()) {
            return None;
        }
        match self {
            GeoidModel::Egm2008 => {
                let lon = (lon + 180.0).rem_euclid(360.0) - 180.0;
                egm2008::geoid_height(lat.clamp(-90.0, 90.0) as f32, lon as f32)
                    .ok()
                    .map(f64::from)
            }
            GeoidModel::Grid(g) => g.at(lat, lon),
        }
    }

    /// A name for summaries and messages: "EGM2008 (built in, 3° grid)" or the grid's file.
    pub fn describe(&self) -> String {
        match self {
            GeoidModel::Egm2008 => "EGM2008 (built in, 3° grid)".into(),
            GeoidModel::Grid(g) => format!("geoid grid {}", g.path.display()),
        }
    }
}

impl GeoidGrid {
    fn bad(path: &Path, message: impl Into<String>) -> Error {
        Error::Geoid {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }

    fn check(self) -> Result<GeoidGrid> {
        let ok = [self.south_deg, self.west_deg, self.dlat_deg, self.dlon_deg]
            .iter()
            .all(|v| v.is_finite())
            && self.dlat_deg > 0.0
            && self.dlon_deg > 0.0
            && self.rows >= 2
            && self.cols >= 2
            && self.south_deg >= -90.0 - 1e-9
            && self.south_deg + self.dlat_deg * (self.rows - 1) as f64 <= 90.0 + 1e-9;
        if !ok {
            return Err(Self::bad(
                &self.path,
                format!(
                    "not a latitude/longitude geoid grid (south {}°, west {}°, spacing {}° × \
                     {}°, {} × {} nodes)",
                    self.south_deg,
                    self.west_deg,
                    self.dlat_deg,
                    self.dlon_deg,
                    self.rows,
                    self.cols
                ),
            ));
        }
        Ok(self)
    }

    /// A NOAA GTX grid.
    fn from_gtx(path: &Path, b: &[u8]) -> Result<GeoidGrid> {
        if b.len() < 40 {
            return Err(Self::bad(
                path,
                format!("{} bytes: neither a GTX grid nor a GeoTIFF", b.len()),
            ));
        }
        let f = |i: usize| f64::from_be_bytes(b[i..i + 8].try_into().unwrap_or_default());
        let n = |i: usize| i32::from_be_bytes(b[i..i + 4].try_into().unwrap_or_default());
        let (rows, cols) = (n(32), n(36));
        let want = (rows.max(0) as usize) * (cols.max(0) as usize) * 4 + 40;
        if rows < 2 || cols < 2 || b.len() != want {
            return Err(Self::bad(
                path,
                format!(
                    "a GTX header of {rows} × {cols} nodes needs {want} bytes, the file has {}: \
                     not a GTX grid (nor a GeoTIFF)",
                    b.len()
                ),
            ));
        }
        let values = b[40..]
            .chunks_exact(4)
            .map(|c| {
                let v = f32::from_be_bytes([c[0], c[1], c[2], c[3]]);
                if (v - GTX_NODATA).abs() < 1e-3 || !v.is_finite() {
                    f32::NAN
                } else {
                    v
                }
            })
            .collect();
        GeoidGrid {
            path: path.to_path_buf(),
            south_deg: f(0),
            west_deg: f(8),
            dlat_deg: f(16),
            dlon_deg: f(24),
            rows: rows as usize,
            cols: cols as usize,
            values,
        }
        .check()
    }

    /// A single-band GeoTIFF in degrees.
    fn from_geotiff(path: &Path, b: &[u8]) -> Result<GeoidGrid> {
        use tiff::decoder::{Decoder, DecodingResult};
        use tiff::tags::Tag;
        let tiff_err = |e: tiff::TiffError| Self::bad(path, format!("GeoTIFF: {e}"));
        let mut d = Decoder::new(std::io::Cursor::new(b)).map_err(tiff_err)?;
        let (w, h) = d.dimensions().map_err(tiff_err)?;
        let scale = d
            .get_tag_f64_vec(Tag::ModelPixelScaleTag)
            .map_err(|_| Self::bad(path, "GeoTIFF without ModelPixelScale: not georeferenced"))?;
        let tie = d
            .get_tag_f64_vec(Tag::ModelTiepointTag)
            .map_err(|_| Self::bad(path, "GeoTIFF without ModelTiepoint: not georeferenced"))?;
        if scale.len() < 2 || tie.len() < 6 {
            return Err(Self::bad(
                path,
                "GeoTIFF with a short ModelPixelScale or ModelTiepoint",
            ));
        }
        // GTRasterTypeGeoKey (1025): 1 = pixel is area (values at cell centres), 2 = point.
        let keys = d
            .get_tag_u16_vec(Tag::GeoKeyDirectoryTag)
            .unwrap_or_default();
        let point = keys
            .chunks_exact(4)
            .skip(1)
            .any(|k| k[0] == 1025 && k[1] == 0 && k[3] == 2);
        let nodata = d
            .get_tag_ascii_string(Tag::GdalNodata)
            .ok()
            .and_then(|s| s.trim().trim_end_matches('\0').parse::<f64>().ok());
        let data: Vec<f64> = match d.read_image().map_err(tiff_err)? {
            DecodingResult::F32(v) => v.into_iter().map(f64::from).collect(),
            DecodingResult::F64(v) => v,
            DecodingResult::I16(v) => v.into_iter().map(f64::from).collect(),
            DecodingResult::I32(v) => v.into_iter().map(f64::from).collect(),
            _ => {
                return Err(Self::bad(
                    path,
                    "GeoTIFF samples are not floats or signed integers: not a geoid grid",
                ));
            }
        };
        let (w, h) = (w as usize, h as usize);
        if data.len() != w * h {
            return Err(Self::bad(
                path,
                format!(
                    "GeoTIFF of {w} × {h} pixels holds {} samples: one band expected",
                    data.len()
                ),
            ));
        }
        let (dlon, dlat) = (scale[0], scale[1]);
        // Tiepoint: raster (i, j) ↔ model (x, y); the first node's centre.
        let half = if point { 0.0 } else { 0.5 };
        let west = tie[3] + (half - tie[0]) * dlon;
        let north = tie[4] - (half - tie[1]) * dlat;
        let south = north - dlat * (h - 1) as f64;
        // TIFF rows run from the north: flip to rows from the south.
        let mut values = Vec::with_capacity(w * h);
        for r in (0..h).rev() {
            values.extend(data[r * w..(r + 1) * w].iter().map(|v| {
                if !v.is_finite() || nodata.is_some_and(|n| (*v - n).abs() < 1e-6) {
                    f32::NAN
                } else {
                    *v as f32
                }
            }));
        }
        GeoidGrid {
            path: path.to_path_buf(),
            south_deg: south,
            west_deg: west,
            dlat_deg: dlat,
            dlon_deg: dlon,
            rows: h,
            cols: w,
            values,
        }
        .check()
    }

    /// Bilinear N at (lat, lon) degrees.
    fn at(&self, lat: f64, lon: f64) -> Option<f64> {
        let fr = (lat - self.south_deg) / self.dlat_deg;
        // The grid's longitudes may run 0–360 or −180–180: the point's turn that falls inside.
        let span = self.dlon_deg * (self.cols - 1) as f64;
        let mut dl = lon - self.west_deg;
        dl = dl.rem_euclid(360.0);
        if dl > span + 1e-9 {
            return None;
        }
        let fc = dl / self.dlon_deg;
        let max_r = (self.rows - 1) as f64;
        let max_c = (self.cols - 1) as f64;
        if !(-1e-9..=max_r + 1e-9).contains(&fr) || !(-1e-9..=max_c + 1e-9).contains(&fc) {
            return None;
        }
        let (fr, fc) = (fr.clamp(0.0, max_r), fc.clamp(0.0, max_c));
        let r0 = (fr.floor() as usize).min(self.rows - 2);
        let c0 = (fc.floor() as usize).min(self.cols - 2);
        let (tr, tc) = (fr - r0 as f64, fc - c0 as f64);
        let v = |r: usize, c: usize| f64::from(self.values[r * self.cols + c]);
        let n = (1.0 - tr) * ((1.0 - tc) * v(r0, c0) + tc * v(r0, c0 + 1))
            + tr * ((1.0 - tc) * v(r0 + 1, c0) + tc * v(r0 + 1, c0 + 1));
        n.is_finite().then_some(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// NGA's published check values for EGM2008 (the `outintpt.dat` sample output that ships
    /// with NGA's interpolation program `interp_1min`/`interp_2p5min`, "Tide-Free" WGS 84
    /// undulations): latitude, longitude (degrees), N (m).
    const NGA_CHECK: [(f64, f64, f64); 6] = [
        (37.0, 241.0, -26.151),
        (37.0, -119.0, -26.151),
        (36.0, 242.983333, -29.171),
        (90.0, 0.0, 14.899),
        (-90.0, 359.983333, -30.150),
        (-90.0, 0.0, -30.150),
    ];

    #[test]
    fn egm2008_at_nga_check_points() {
        let m = GeoidModel::Egm2008;
        let mut worst: f64 = 0.0;
        for (lat, lon, want) in NGA_CHECK {
            let lon = if lon > 180.0 { lon - 360.0 } else { lon };
            let n = m.undulation_m(lat.to_radians(), lon.to_radians()).unwrap();
            let on_node = lat % 3.0 == 0.0 && lon % 3.0 == 0.0;
            if on_node {
                // On the 3° grid the value is NGA's own to the millimetre.
                assert!((n - want).abs() < 0.0015, "({lat}, {lon}): {n} vs {want}");
            }
            worst = worst.max((n - want).abs());
        }
        // Off the nodes, in the Sierra Nevada where the geoid is rough, the 3° grid's bilinear
        // value is 3.3 m off NGA's (the module docs say so and name --geoid for better).
        assert!(worst < 3.5, "worst {worst}");
        assert!(
            worst > 0.01,
            "the off-node points do not test the interpolation: {worst}"
        );
        // A node inside the crate's own test, then a vertical CRS on EGM2008.
        assert!((m.undulation_m(0.0, 0.0).unwrap() - 17.225).abs() < 1e-3);
        assert_eq!(
            GeoidModel::for_vertical_crs("EGM2008 height"),
            Some(GeoidModel::Egm2008)
        );
        assert_eq!(GeoidModel::for_vertical_crs("CGVD28 height"), None);
    }

    fn gtx(south: f64, west: f64, d: f64, rows: i32, cols: i32, v: &[f32]) -> Vec<u8> {
        let mut b = Vec::new();
        for x in [south, west, d, d] {
            b.extend_from_slice(&x.to_be_bytes());
        }
        b.extend_from_slice(&rows.to_be_bytes());
        b.extend_from_slice(&cols.to_be_bytes());
        for x in v {
            b.extend_from_slice(&x.to_be_bytes());
        }
        b
    }

    #[test]
    fn gtx_is_bilinear_inside_and_has_no_value_outside_or_on_no_data() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("g.gtx");
        // 2 × 3 nodes from (49°, 235°), 0.5°: N = 10 + lat offset + 2 × lon offset (linear, so
        // bilinear is exact).
        let v: Vec<f32> = (0..2)
            .flat_map(|r| (0..3).map(move |c| 10.0 + 0.5 * r as f32 + 1.0 * c as f32))
            .collect();
        std::fs::write(&p, gtx(49.0, 235.0, 0.5, 2, 3, &v)).unwrap();
        let m = GeoidModel::from_file(&p).unwrap();
        let n = |lat: f64, lon: f64| m.undulation_m(lat.to_radians(), lon.to_radians());
        // −124.75° is 235.25° east.
        let got = n(49.25, -124.75).unwrap();
        assert!((got - (10.0 + 0.25 + 0.5)).abs() < 1e-6, "{got}");
        assert!(n(48.9, -124.75).is_none());
        assert!(n(49.25, -123.0).is_none());
        let mut v2 = v.clone();
        v2[0] = GTX_NODATA;
        std::fs::write(&p, gtx(49.0, 235.0, 0.5, 2, 3, &v2)).unwrap();
        let m = GeoidModel::from_file(&p).unwrap();
        assert!(
            m.undulation_m(49.1f64.to_radians(), 235.1f64.to_radians())
                .is_none()
        );
        std::fs::write(&p, &gtx(49.0, 235.0, 0.5, 2, 3, &v)[..50]).unwrap();
        let e = GeoidModel::from_file(&p).unwrap_err().to_string();
        assert!(e.contains("not a GTX grid"), "{e}");
    }

    #[test]
    fn geotiff_pixel_is_area_reads_its_cell_centres() {
        use tiff::encoder::{TiffEncoder, colortype::Gray32Float};
        use tiff::tags::Tag;
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("g.tif");
        // 3 × 2 pixels of 0.5°, top-left corner (50°N, 10°E), pixel is area: centres at
        // 49.75 / 49.25 N and 10.25 / 10.75 / 11.25 E. N = 40 + lon − lat at the centres.
        let (w, h) = (3u32, 2u32);
        let mut data = Vec::new();
        for r in 0..h {
            let lat = 49.75 - 0.5 * f64::from(r);
            for c in 0..w {
                let lon = 10.25 + 0.5 * f64::from(c);
                data.push((40.0 + lon - lat) as f32);
            }
        }
        {
            let f = std::fs::File::create(&p).unwrap();
            let mut enc = TiffEncoder::new(f).unwrap();
            let mut img = enc.new_image::<Gray32Float>(w, h).unwrap();
            img.encoder()
                .write_tag(Tag::ModelPixelScaleTag, &[0.5f64, 0.5, 0.0][..])
                .unwrap();
            img.encoder()
                .write_tag(
                    Tag::ModelTiepointTag,
                    &[0.0f64, 0.0, 0.0, 10.0, 50.0, 0.0][..],
                )
                .unwrap();
            img.encoder()
                .write_tag(Tag::GeoKeyDirectoryTag, &[1u16, 1, 0, 1, 1025, 0, 1, 1][..])
                .unwrap();
            img.write_data(&data).unwrap();
        }
        let m = GeoidModel::from_file(&p).unwrap();
        let n = |lat: f64, lon: f64| m.undulation_m(lat.to_radians(), lon.to_radians());
        for (lat, lon) in [(49.5, 10.5), (49.25, 10.25), (49.75, 11.25)] {
            let got = n(lat, lon).unwrap();
            assert!(
                (got - (40.0 + lon - lat)).abs() < 1e-4,
                "({lat}, {lon}) {got}"
            );
        }
        assert!(n(49.9, 10.5).is_none());
    }
}
