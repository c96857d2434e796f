//! Coordinate reference systems: what a LAS file declares ([`LasCrs`]: WKT VLR, GeoTIFF keys)
//! and the projected CRS lidarqa computes in ([`Crs`]: any projection with an EPSG code or a
//! PROJ string, in metres or feet).
//!
//! # Which library, and why
//! A [`Crs`] is built from its EPSG code through `crs-definitions` (the EPSG registry's PROJ
//! strings as a compiled-in table, no database or network at run time) and projected with
//! `proj4rs` (a pure-Rust port of PROJ.4: tmerc/etmerc, utm, laea, lcc, aea, stere, sterea,
//! somerc, merc, ...), so no C library has to be installed beside lidarqa. Two exceptions:
//! - transverse Mercator with its origin on the equator (UTM, ETRS89 UTM, NAD83(2011) UTM,
//!   Poland CS92 / CS2000, most national TM grids) goes through lidarqa's own Krüger series
//!   ([`TransverseMercator`], see the geodesy module): it is exact to nanometres, the tests pin
//!   it against PROJ, and it gives convergence and scale in closed form;
//! - proj4rs gives neither grid convergence nor point scale, so for its projections both come
//!   from central differences of the forward projection (the step is small enough that the
//!   truncation error is far below what a σ needs, large enough that rounding is too).
//!
//! No datum transformation is done: the trajectory must already be in the datum of the points'
//! CRS (as for UTM). All coordinates through [`Crs`] are metres: a CRS in US survey feet or
//! international feet has its [`LinearUnit`], and callers convert the file's X/Y/Z at the edge
//! (`metres = value × unit.metres()`). σ are always metres.
//!
//! The EPSG code of a file is read from the GeoKey directory with the `las` crate's
//! `get_geotiff_crs` (including a user-defined projected CRS that is a WGS 84 UTM zone by its
//! ProjectionGeoKey, as PDAL writes one from a PROJ string), and from a WKT VLR by taking the
//! last `AUTHORITY["EPSG","…"]` of the horizontal part (the crate has no WKT parser, and the
//! outermost authority is the last one of a WKT1 CRS).

use crate::error::{Error, Result};
use crate::geodesy::{
    Ellipsoid, Hemisphere, Projected, TransverseMercator, Unprojected, UtmDatum, UtmZone,
};
use std::sync::Arc;

/// The linear unit of a projected CRS's coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LinearUnit {
    /// Metre.
    Metre,
    /// US survey foot, 1200/3937 m.
    UsSurveyFoot,
    /// International foot, 0.3048 m.
    InternationalFoot,
    /// Another unit, by its length in metres.
    Other {
        /// One unit in metres.
        metres: f64,
    },
}

impl LinearUnit {
    /// One unit in metres.
    pub fn metres(self) -> f64 {
        match self {
            LinearUnit::Metre => 1.0,
            LinearUnit::UsSurveyFoot => 1200.0 / 3937.0,
            LinearUnit::InternationalFoot => 0.3048,
            LinearUnit::Other { metres } => metres,
        }
    }

    /// A short name for messages.
    pub fn name(self) -> String {
        match self {
            LinearUnit::Metre => "metre".into(),
            LinearUnit::UsSurveyFoot => "US survey foot".into(),
            LinearUnit::InternationalFoot => "international foot".into(),
            LinearUnit::Other { metres } => format!("unit of {metres} m"),
        }
    }

    /// From PROJ's `+units=` / `+to_meter=`.
    fn from_proj(units: Option<&str>, to_meter: Option<f64>) -> Option<LinearUnit> {
        Some(match (units, to_meter) {
            (Some("m") | None, None) => LinearUnit::Metre,
            (Some("us-ft"), _) => LinearUnit::UsSurveyFoot,
            (Some("ft"), _) => LinearUnit::InternationalFoot,
            (None, Some(f)) if (f - 1.0).abs() < 1e-12 => LinearUnit::Metre,
            (None, Some(f)) if (f - 1200.0 / 3937.0).abs() < 1e-12 => LinearUnit::UsSurveyFoot,
            (None, Some(f)) if (f - 0.3048).abs() < 1e-12 => LinearUnit::InternationalFoot,
            (None, Some(f)) if f.is_finite() && f > 0.0 => LinearUnit::Other { metres: f },
            _ => return None,
        })
    }
}

/// How a [`Crs`] projects.
#[derive(Clone)]
enum Method {
    /// lidarqa's exact transverse Mercator (any TM with its origin on the equator).
    Tm(TransverseMercator),
    /// proj4rs, with the geographic CRS on the same ellipsoid.
    Proj(Arc<ProjPair>),
}

struct ProjPair {
    projected: proj4rs::Proj,
    geographic: proj4rs::Proj,
}

/// A projected CRS: its EPSG code when it has one, its name, linear unit, ellipsoid and the
/// projection between geodetic coordinates and grid metres, with grid convergence and point
/// scale anywhere.
#[derive(Clone)]
pub struct Crs {
    epsg: Option<u32>,
    name: String,
    /// The PROJ string it was built from (units as declared).
    definition: String,
    unit: LinearUnit,
    ellipsoid: Ellipsoid,
    utm: Option<UtmZone>,
    method: Method,
}

impl std::fmt::Debug for Crs {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Crs")
            .field("epsg", &self.epsg)
            .field("name", &self.name)
            .field("definition", &self.definition)
            .finish()
    }
}

impl PartialEq for Crs {
    fn eq(&self, other: &Self) -> bool {
        self.epsg == other.epsg && self.definition == other.definition
    }
}

impl From<UtmZone> for Crs {
    fn from(zone: UtmZone) -> Crs {
        let h = match zone.hemisphere() {
            Hemisphere::North => 'N',
            Hemisphere::South => 'S',
        };
        let (datum, ellps) = match zone.datum() {
            UtmDatum::Wgs84 => ("WGS 84", "+datum=WGS84"),
            UtmDatum::Nad83 => ("NAD83", "+datum=NAD83"),
        };
        let south = if h == 'S' { " +south" } else { "" };
        Crs {
            epsg: zone.epsg(),
            name: format!("{datum} / UTM zone {}{h}", zone.zone()),
            definition: format!("+proj=utm +zone={}{south} {ellps} +units=m", zone.zone()),
            unit: LinearUnit::Metre,
            ellipsoid: zone.datum().ellipsoid(),
            utm: Some(zone),
            method: Method::Tm(zone.projection()),
        }
    }
}

/// The PROJ parameters of a definition string: `+key=value` or `+flag`.
fn proj_params(definition: &str) -> Vec<(&str, Option<&str>)> {
    definition
        .split_whitespace()
        .filter_map(|t| t.strip_prefix('+'))
        .map(|t| match t.split_once('=') {
            Some((k, v)) => (k, Some(v)),
            None => (t, None),
        })
        .collect()
}

/// The ellipsoid of a PROJ string (`+ellps`, `+datum`, or `+a` with `+rf`/`+b`/`+f`).
fn proj_ellipsoid(params: &[(&str, Option<&str>)]) -> Option<Ellipsoid> {
    let get = |k: &str| params.iter().find(|(p, _)| *p == k).and_then(|(_, v)| *v);
    let num = |k: &str| get(k).and_then(|v| v.parse::<f64>().ok());
    let named = |a_m: f64, rf: f64| Ellipsoid { a_m, f: 1.0 / rf };
    if let Some(a_m) = num("a") {
        let f = num("rf")
            .map(|rf| 1.0 / rf)
            .or_else(|| num("b").map(|b| (a_m - b) / a_m))
            .or_else(|| num("f"))
            .unwrap_or(0.0);
        return Some(Ellipsoid { a_m, f });
    }
    let name = get("ellps").or(match get("datum") {
        Some("WGS84") => Some("WGS84"),
        Some("NAD83") => Some("GRS80"),
        Some("NAD27") => Some("clrk66"),
        Some("potsdam") => Some("bessel"),
        Some("OSGB36") => Some("airy"),
        _ => None,
    })?;
    Some(match name {
        "WGS84" => Ellipsoid::WGS84,
        "GRS80" => Ellipsoid::GRS80,
        "intl" => named(6_378_388.0, 297.0),
        "bessel" => named(6_377_397.155, 299.152_812_8),
        "krass" => named(6_378_245.0, 298.3),
        "airy" => named(6_377_563.396, 299.324_964_6),
        "clrk66" => Ellipsoid {
            a_m: 6_378_206.4,
            f: (6_378_206.4 - 6_356_583.8) / 6_378_206.4,
        },
        "WGS72" => named(6_378_135.0, 298.26),
        _ => return None,
    })
}

/// The PROJ string of a WKT1 `PROJCS` by its projection, parameters, spheroid and linear unit,
/// for a file whose CRS has no usable EPSG code. `None` for a projection not mapped here.
fn proj_from_wkt1(wkt: &str) -> Option<String> {
    let start = wkt.find("PROJCS[")?;
    // The horizontal part only: a compound CRS's vertical part has its own UNIT.
    let end = ["VERT_CS[", "VERTCRS["]
        .iter()
        .filter_map(|k| wkt.find(k))
        .min()
        .unwrap_or(wkt.len())
        .max(start);
    let w = &wkt[start..end];
    // `KEY["name",v1,v2,...]` → the name and the numbers (nested brackets are not needed here).
    let items = |key: &str| -> Vec<(String, Vec<f64>)> {
        let mut out = Vec::new();
        let mut rest = w;
        while let Some(i) = rest.find(key) {
            let body = &rest[i + key.len()..];
            let end = body.find(']').unwrap_or(body.len());
            let mut parts = body[..end].split(',');
            let name = parts
                .next()
                .unwrap_or("")
                .trim()
                .trim_matches('"')
                .to_string();
            let nums = parts.filter_map(|p| p.trim().parse::<f64>().ok()).collect();
            out.push((name, nums));
            rest = &body[end..];
        }
        out
    };
    let projection = items("PROJECTION[").first()?.0.to_ascii_lowercase();
    let params = items("PARAMETER[");
    let param = |names: &[&str]| {
        params
            .iter()
            .find(|(n, _)| names.iter().any(|k| n.eq_ignore_ascii_case(k)))
            .and_then(|(_, v)| v.first().copied())
    };
    let (_, spheroid) = items("SPHEROID[").into_iter().next()?;
    let (a_m, rf) = (*spheroid.first()?, *spheroid.get(1)?);
    // The linear unit is the PROJCS's own UNIT, the last one before any AXIS / AUTHORITY.
    let unit_m = items("UNIT[")
        .last()
        .and_then(|(_, v)| v.first().copied())
        .unwrap_or(1.0);
    let fe_m = param(&["false_easting"]).unwrap_or(0.0) * unit_m;
    let fn_m = param(&["false_northing"]).unwrap_or(0.0) * unit_m;
    let lat0 = param(&["latitude_of_origin", "latitude_of_center"]).unwrap_or(0.0);
    let lon0 = param(&["central_meridian", "longitude_of_center"]).unwrap_or(0.0);
    let k0 = param(&["scale_factor"]).unwrap_or(1.0);
    let body = match projection.as_str() {
        "transverse_mercator" => format!("+proj=tmerc +lat_0={lat0} +lon_0={lon0} +k_0={k0}"),
        "lambert_conformal_conic_2sp" | "lambert_conformal_conic" => format!(
            "+proj=lcc +lat_1={} +lat_2={} +lat_0={lat0} +lon_0={lon0}",
            param(&["standard_parallel_1"])?,
            param(&["standard_parallel_2"]).or(param(&["standard_parallel_1"]))?
        ),
        "lambert_conformal_conic_1sp" => {
            format!("+proj=lcc +lat_1={lat0} +lat_0={lat0} +lon_0={lon0} +k_0={k0}")
        }
        "lambert_azimuthal_equal_area" => format!("+proj=laea +lat_0={lat0} +lon_0={lon0}"),
        "albers_conic_equal_area" => format!(
            "+proj=aea +lat_1={} +lat_2={} +lat_0={lat0} +lon_0={lon0}",
            param(&["standard_parallel_1"])?,
            param(&["standard_parallel_2"])?
        ),
        "polar_stereographic" => format!(
            "+proj=stere +lat_0={} +lat_ts={lat0} +lon_0={lon0} +k_0={k0}",
            if lat0 < 0.0 { -90 } else { 90 }
        ),
        _ => return None,
    };
    Some(format!(
        "{body} +x_0={fe_m} +y_0={fn_m} +a={a_m} +rf={rf} +to_meter={unit_m}"
    ))
}

/// The name of a WKT1 `PROJCS["name", ...]` or WKT2 `PROJCRS["name", ...]`.
fn wkt_name(wkt: &str) -> Option<&str> {
    let i = ["PROJCS[", "PROJCRS[", "PROJECTEDCRS["]
        .iter()
        .filter_map(|k| wkt.find(k).map(|i| i + k.len()))
        .min()?;
    let rest = wkt[i..].trim_start().strip_prefix('"')?;
    Some(&rest[..rest.find('"')?])
}

/// Central-difference step of the numerical convergence and scale, radians (about 6 m).
const DIFF_STEP_RAD: f64 = 1e-6;

impl Crs {
    /// The CRS of an EPSG code: a UTM zone (WGS 84 326zz/327zz, NAD83 269zz) directly, any
    /// other projected CRS from the EPSG table.
    ///
    /// # Errors
    /// [`Error::UnsupportedCrs`] for an unknown code, a geographic or geocentric CRS, or a
    /// projection neither lidarqa nor proj4rs implements.
    ///
    /// ```
    /// use lidarqa_io::{Crs, LinearUnit};
    /// let pl = Crs::from_epsg(2180).unwrap();
    /// assert_eq!(pl.unit(), LinearUnit::Metre);
    /// assert_eq!(Crs::from_epsg(2264).unwrap().unit(), LinearUnit::UsSurveyFoot);
    /// assert!(Crs::from_epsg(4326).is_err());
    /// ```
    pub fn from_epsg(epsg: u32) -> Result<Crs> {
        if let Ok(zone) = UtmZone::from_epsg(epsg) {
            return Ok(Crs::from(zone));
        }
        let def = u16::try_from(epsg)
            .ok()
            .and_then(crs_definitions::from_code)
            .ok_or_else(|| Error::UnsupportedCrs {
                crs: format!("EPSG:{epsg}"),
                message: "not in the EPSG table lidarqa carries (crs-definitions); pass a \
                          projected CRS lidarqa knows with --epsg"
                    .into(),
            })?;
        let name = wkt_name(def.wkt).unwrap_or("unnamed");
        Crs::from_proj_string(def.proj4, Some(epsg), name)
    }

    /// The CRS of a WKT VLR: its EPSG code when that names a projected CRS lidarqa knows, else
    /// the WKT1 `PROJCS` itself (transverse Mercator, Lambert conformal conic 1SP/2SP, LAEA,
    /// Albers, polar stereographic; spheroid and linear unit from the WKT).
    ///
    /// # Errors
    /// [`Error::UnsupportedCrs`] naming the CRS when neither works.
    pub fn from_wkt(wkt: &str) -> Result<Crs> {
        let name = wkt_name(wkt).unwrap_or("unnamed");
        let by_code = epsg_from_wkt(wkt).map(Crs::from_epsg);
        if let Some(Ok(crs)) = by_code {
            return Ok(crs);
        }
        match proj_from_wkt1(wkt) {
            Some(def) => Crs::from_proj_string(&def, None, name),
            None => Err(match by_code {
                Some(Err(e)) => e,
                _ => Error::UnsupportedCrs {
                    crs: format!("WKT \"{name}\""),
                    message: "no EPSG code and a projection lidarqa does not read from WKT".into(),
                },
            }),
        }
    }

    /// The CRS of a PROJ string (`+proj=... +ellps=... +units=...`), with its EPSG code when
    /// known and a name for messages.
    ///
    /// # Errors
    /// [`Error::UnsupportedCrs`] naming the CRS for a geographic or geocentric CRS, an unknown
    /// ellipsoid or unit, or a definition proj4rs refuses.
    pub fn from_proj_string(definition: &str, epsg: Option<u32>, name: &str) -> Result<Crs> {
        let label = match epsg {
            Some(c) => format!("EPSG:{c} ({name})"),
            None => format!("{name} ('{definition}')"),
        };
        let refuse = |message: String| Error::UnsupportedCrs {
            crs: label.clone(),
            message,
        };
        let params = proj_params(definition);
        let get = |k: &str| params.iter().find(|(p, _)| *p == k).map(|(_, v)| *v);
        let value = |k: &str| get(k).flatten();
        let num = |k: &str| value(k).and_then(|v| v.parse::<f64>().ok());
        let proj = value("proj").unwrap_or("");
        if matches!(
            proj,
            "longlat" | "latlong" | "lonlat" | "latlon" | "geocent"
        ) {
            return Err(refuse(format!(
                "a {} CRS, not a projected one: the points need easting/northing",
                if proj == "geocent" {
                    "geocentric"
                } else {
                    "geographic"
                }
            )));
        }
        let unit = LinearUnit::from_proj(value("units"), num("to_meter"))
            .ok_or_else(|| refuse("unknown linear unit".into()))?;
        let ellipsoid = proj_ellipsoid(&params)
            .ok_or_else(|| refuse("unknown ellipsoid (no +ellps, +datum or +a)".into()))?;
        if get("pm").is_some_and(|v| v != Some("greenwich")) {
            return Err(refuse("a prime meridian other than Greenwich".into()));
        }
        let deg = |k: &str| num(k).unwrap_or(0.0).to_radians();
        let (method, utm) = match proj {
            "utm" => {
                let zone = num("zone")
                    .filter(|z| z.fract() == 0.0 && (1.0..=60.0).contains(z))
                    .ok_or_else(|| refuse("+proj=utm without a zone 1–60".into()))?;
                let south = get("south").is_some();
                let central = (6.0 * zone - 183.0).to_radians();
                let tm = TransverseMercator::new(
                    ellipsoid,
                    central,
                    0.9996,
                    500_000.0,
                    if south { 10_000_000.0 } else { 0.0 },
                );
                let datum = if ellipsoid == Ellipsoid::WGS84 {
                    Some(UtmDatum::Wgs84)
                } else if ellipsoid == Ellipsoid::GRS80 {
                    Some(UtmDatum::Nad83)
                } else {
                    None
                };
                let hemisphere = if south {
                    Hemisphere::South
                } else {
                    Hemisphere::North
                };
                let zone = datum.and_then(|d| UtmZone::with_datum(zone as u32, hemisphere, d).ok());
                (Method::Tm(tm), zone)
            }
            "tmerc" | "etmerc" if deg("lat_0") == 0.0 => {
                let k0 = num("k_0").or_else(|| num("k")).unwrap_or(1.0);
                let tm = TransverseMercator::new(
                    ellipsoid,
                    deg("lon_0"),
                    k0,
                    num("x_0").unwrap_or(0.0),
                    num("y_0").unwrap_or(0.0),
                );
                (Method::Tm(tm), None)
            }
            _ => {
                // proj4rs in metres: our callers convert feet at the edge.
                let metric: Vec<String> = definition
                    .split_whitespace()
                    .filter(|t| !(t.starts_with("+units=") || t.starts_with("+to_meter=")))
                    .map(str::to_string)
                    .collect();
                let projected = proj4rs::Proj::from_proj_string(&metric.join(" "))
                    .map_err(|e| refuse(format!("proj4rs: {e}")))?;
                let shape: Vec<&str> = definition
                    .split_whitespace()
                    .filter(|t| {
                        [
                            "+ellps=",
                            "+datum=",
                            "+a=",
                            "+b=",
                            "+rf=",
                            "+f=",
                            "+towgs84=",
                        ]
                        .iter()
                        .any(|k| t.starts_with(k))
                    })
                    .collect();
                let geographic =
                    proj4rs::Proj::from_proj_string(&format!("+proj=longlat {}", shape.join(" ")))
                        .map_err(|e| refuse(format!("proj4rs: {e}")))?;
                (
                    Method::Proj(Arc::new(ProjPair {
                        projected,
                        geographic,
                    })),
                    None,
                )
            }
        };
        let crs = Crs {
            epsg,
            name: name.to_string(),
            definition: definition.to_string(),
            unit,
            ellipsoid,
            utm,
            method,
        };
        // A definition proj4rs accepts but cannot invert at its own origin is no use.
        let (lat0, lon0) = (deg("lat_0"), deg("lon_0"));
        let p = crs.forward(lat0, lon0);
        if !(p.easting_m.is_finite() && p.northing_m.is_finite()) {
            return Err(refuse("the projection fails at its own origin".into()));
        }
        Ok(crs)
    }

    /// The EPSG code, when the CRS has one.
    pub fn epsg(&self) -> Option<u32> {
        self.epsg
    }

    /// The CRS's name for messages, e.g. `ETRS89 / Poland CS92`.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The PROJ string it was built from.
    pub fn definition(&self) -> &str {
        &self.definition
    }

    /// The linear unit of the CRS's coordinates (X/Y, and Z unless a vertical CRS says
    /// otherwise).
    pub fn unit(&self) -> LinearUnit {
        self.unit
    }

    /// The ellipsoid of the CRS's datum.
    pub fn ellipsoid(&self) -> Ellipsoid {
        self.ellipsoid
    }

    /// The UTM zone, when the CRS is one (WGS 84 or GRS 80 ellipsoid).
    pub fn utm_zone(&self) -> Option<UtmZone> {
        self.utm
    }

    /// The central meridian of a transverse Mercator CRS, radians; `None` for other projections.
    pub fn central_meridian_rad(&self) -> Option<f64> {
        match &self.method {
            Method::Tm(tm) => Some(tm.central_meridian_rad()),
            Method::Proj(_) => None,
        }
    }

    /// Latitude/longitude (radians) → easting/northing (metres), convergence and scale.
    pub fn forward(&self, latitude_rad: f64, longitude_rad: f64) -> Projected {
        match &self.method {
            Method::Tm(tm) => tm.forward(latitude_rad, longitude_rad),
            Method::Proj(p) => {
                let (easting_m, northing_m) = p.forward(latitude_rad, longitude_rad);
                let (convergence_rad, scale) =
                    self.numerical_convergence_scale(p, latitude_rad, longitude_rad);
                Projected {
                    easting_m,
                    northing_m,
                    convergence_rad,
                    scale,
                }
            }
        }
    }

    /// Easting/northing (metres) → latitude/longitude (radians).
    pub fn inverse(&self, easting_m: f64, northing_m: f64) -> (f64, f64) {
        match &self.method {
            Method::Tm(tm) => tm.inverse(easting_m, northing_m),
            Method::Proj(p) => p.inverse(easting_m, northing_m),
        }
    }

    /// Easting/northing (metres) → the point on the ellipsoid with the convergence and scale
    /// there (see [`Unprojected`]).
    pub fn unproject(&self, easting_m: f64, northing_m: f64) -> Unprojected {
        match &self.method {
            Method::Tm(tm) => tm.inverse_series(easting_m, northing_m),
            Method::Proj(p) => {
                let (lat, lon) = p.inverse(easting_m, northing_m);
                let (gamma, scale) = self.numerical_convergence_scale(p, lat, lon);
                let (sin_latitude, cos_latitude) = lat.sin_cos();
                let (sin_longitude, cos_longitude) = lon.sin_cos();
                let (sin_convergence, cos_convergence) = gamma.sin_cos();
                Unprojected {
                    sin_latitude,
                    cos_latitude,
                    sin_longitude,
                    cos_longitude,
                    sin_convergence,
                    cos_convergence,
                    scale,
                }
            }
        }
    }

    /// Grid convergence at (φ, λ), radians; see [`Projected::convergence_rad`].
    pub fn grid_convergence(&self, latitude_rad: f64, longitude_rad: f64) -> f64 {
        match &self.method {
            Method::Tm(tm) => tm.grid_convergence(latitude_rad, longitude_rad),
            Method::Proj(p) => {
                self.numerical_convergence_scale(p, latitude_rad, longitude_rad)
                    .0
            }
        }
    }

    /// Point scale factor at (φ, λ); see [`Projected::scale`]. For a projection that is not
    /// conformal (e.g. LAEA) the scale depends on direction: this is the geometric mean of the
    /// meridian and parallel scales.
    pub fn point_scale_factor(&self, latitude_rad: f64, longitude_rad: f64) -> f64 {
        match &self.method {
            Method::Tm(tm) => tm.point_scale_factor(latitude_rad, longitude_rad),
            Method::Proj(p) => {
                self.numerical_convergence_scale(p, latitude_rad, longitude_rad)
                    .1
            }
        }
    }

    /// Convergence γ (bearing of grid north from true north) and scale from central
    /// differences of the forward projection along the meridian and the parallel.
    fn numerical_convergence_scale(&self, p: &ProjPair, lat: f64, lon: f64) -> (f64, f64) {
        let h = DIFF_STEP_RAD;
        let (e_n, n_n) = p.forward(lat + h, lon);
        let (e_s, n_s) = p.forward(lat - h, lon);
        let (e_e, n_e) = p.forward(lat, lon + h);
        let (e_w, n_w) = p.forward(lat, lon - h);
        let (de_dphi, dn_dphi) = ((e_n - e_s) / (2.0 * h), (n_n - n_s) / (2.0 * h));
        let (de_dlam, dn_dlam) = ((e_e - e_w) / (2.0 * h), (n_e - n_w) / (2.0 * h));
        // True north has grid bearing −γ.
        let gamma = -de_dphi.atan2(dn_dphi);
        let meridian = de_dphi.hypot(dn_dphi) / self.ellipsoid.meridian_radius_m(lat);
        let parallel =
            de_dlam.hypot(dn_dlam) / (self.ellipsoid.prime_vertical_radius_m(lat) * lat.cos());
        (gamma, (meridian * parallel).sqrt())
    }
}

impl ProjPair {
    fn forward(&self, lat: f64, lon: f64) -> (f64, f64) {
        let mut p = (lon, lat, 0.0);
        match proj4rs::transform::transform(&self.geographic, &self.projected, &mut p) {
            Ok(()) => (p.0, p.1),
            Err(_) => (f64::NAN, f64::NAN),
        }
    }

    fn inverse(&self, easting_m: f64, northing_m: f64) -> (f64, f64) {
        let mut p = (easting_m, northing_m, 0.0);
        match proj4rs::transform::transform(&self.projected, &self.geographic, &mut p) {
            Ok(()) => (p.1, p.0),
            Err(_) => (f64::NAN, f64::NAN),
        }
    }
}

/// The CRS of a LAS file.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LasCrs {
    /// The CRS VLRs/EVLRs as found (`LASF_Projection` 2112, 34735, 34736, 34737), to copy into
    /// outputs unchanged.
    pub vlrs: Vec<RawVlr>,
    /// The horizontal CRS's EPSG code, from ProjectedCSTypeGeoKey (3072), a user-defined WGS 84
    /// UTM zone (ProjectionGeoKey 3074 = 160zz / 161zz), or the WKT's last
    /// `AUTHORITY["EPSG","…"]`; `None` when the file has no CRS or a CRS without a code.
    pub epsg: Option<u32>,
    /// The WKT text (record 2112), when present.
    pub wkt: Option<String>,
    /// The name of an orthometric (gravity-related) vertical CRS the file declares: a WKT
    /// `VERT_CS` / `VERTCRS` that is not an ellipsoidal height, or a GeoTIFF
    /// VerticalCSTypeGeoKey (4096) outside the ellipsoid codes 5001–5033; `None` when the file
    /// declares none or ellipsoidal heights.
    pub orthometric: Option<String>,
}

impl LasCrs {
    pub(crate) fn from_header(header: &las::Header) -> Self {
        let vlrs: Vec<RawVlr> = header
            .all_vlrs()
            .filter(|v| v.is_crs())
            .map(RawVlr::from)
            .collect();
        let wkt = header.get_wkt_crs_bytes().map(|b| {
            String::from_utf8_lossy(b)
                .trim_end_matches('\0')
                .to_string()
        });
        // A GeoKey directory that las cannot parse is no EPSG code, not an error: the VLRs are
        // still copied, and a caller that needs the code reports its absence.
        let geokey = header.get_geotiff_crs().ok().flatten().and_then(|g| {
            g.get_projected_crs_geo_key_value()
                .filter(|&c| c != 0 && c != 32767) // 32767 = user-defined
                .map(u32::from)
                .or_else(|| user_defined_utm_epsg(&g))
        });
        let epsg = geokey.or_else(|| wkt.as_deref().and_then(epsg_from_wkt));
        let geotiff_vertical = header.get_geotiff_crs().ok().flatten().and_then(|g| {
            g.entries
                .iter()
                .find(|e| e.id == 4096)
                .and_then(|e| match &e.data {
                    las::crs::GeoTiffData::U16(v) => Some(*v),
                    _ => None,
                })
                .and_then(|v| match v {
                    0 | 5001..=5033 => None,
                    32767 => Some("a user-defined vertical CRS (GeoKey 4096)".to_string()),
                    v => Some(format!("EPSG:{v} (GeoKey 4096)")),
                })
        });
        let orthometric = wkt
            .as_deref()
            .and_then(orthometric_from_wkt)
            .or(geotiff_vertical);
        LasCrs {
            vlrs,
            epsg,
            wkt,
            orthometric,
        }
    }
}

/// The EPSG code (326zz / 327zz) of a user-defined projected CRS that is plainly a WGS 84 UTM
/// zone, as PDAL and others write it from a PROJ string (`+proj=utm +zone=11 +datum=WGS84`):
/// ProjectedCSTypeGeoKey 32767 (user-defined) with ProjectionGeoKey (3074) = 16000 + zone (north)
/// or 16100 + zone (south), metres (ProjLinearUnitsGeoKey 3076 = 9001 or absent), Greenwich, and
/// a geographic CRS that is EPSG 4326 or user-defined with the WGS 84 datum (6326), ellipsoid
/// (7030) or ellipsoid parameters (a = 6378137 m, 1/f = 298.257223563), taken as WGS 84. Anything
/// else (another datum, other units, another projection) is `None`: the caller then asks for
/// `--utm-zone` / `--epsg` as before.
fn user_defined_utm_epsg(g: &las::crs::GeoTiffCrs) -> Option<u32> {
    use las::crs::GeoTiffData;
    let key = |id: u16| g.entries.iter().find(|e| e.id == id).map(|e| &e.data);
    let short = |id: u16| match key(id) {
        Some(GeoTiffData::U16(v)) => Some(*v),
        _ => None,
    };
    let double = |id: u16| match key(id) {
        Some(GeoTiffData::Doubles(v)) if v.len() == 1 => Some(v[0]),
        _ => None,
    };
    if !matches!(short(3072), None | Some(32767)) || !matches!(short(3076), None | Some(9001)) {
        return None;
    }
    // GeogPrimeMeridianGeoKey (2051) Greenwich, GeogPrimeMeridianLongGeoKey (2061) 0.
    if !matches!(short(2051), None | Some(8901)) || double(2061).is_some_and(|l| l != 0.0) {
        return None;
    }
    let (zone, north) = match short(3074)? {
        p @ 16001..=16060 => (u32::from(p - 16000), true),
        p @ 16101..=16160 => (u32::from(p - 16100), false),
        _ => return None,
    };
    let wgs84_ellipsoid = || {
        short(2056) == Some(7030)
            || (double(2057) == Some(6_378_137.0)
                && double(2059).is_some_and(|f| (f - 298.257_223_563).abs() < 1e-9))
    };
    match short(2048) {
        Some(4326) => {}
        Some(32767) | None if short(2050) == Some(6326) || wgs84_ellipsoid() => {}
        _ => return None,
    }
    Some(if north { 32600 } else { 32700 } + zone)
}

/// The EPSG code of a WKT1 or WKT2 horizontal CRS: the last `AUTHORITY["EPSG","n"]` (WKT1) or
/// `ID["EPSG",n]` (WKT2) before any vertical part of a compound CRS.
pub fn epsg_from_wkt(wkt: &str) -> Option<u32> {
    // In a COMPD_CS / COMPOUNDCRS the vertical CRS comes after the horizontal one.
    let horizontal = ["VERT_CS", "VERTCRS", "VERTICALCRS"]
        .iter()
        .filter_map(|k| wkt.find(k))
        .min()
        .map_or(wkt, |i| &wkt[..i]);
    let mut last = None;
    for key in ["AUTHORITY[", "ID["] {
        let mut rest = horizontal;
        while let Some(i) = rest.find(key) {
            let after = &rest[i + key.len()..];
            if let Some(code) = parse_epsg_authority(after) {
                let pos = horizontal.len() - rest.len() + i;
                if last.is_none_or(|(p, _)| pos > p) {
                    last = Some((pos, code));
                }
            }
            rest = after;
        }
    }
    last.map(|(_, c)| c)
}

/// The name of the vertical CRS of a WKT1 `COMPD_CS` / WKT2 `COMPOUNDCRS`, unless it is an
/// ellipsoidal height (a name with "ellipsoid").
pub fn orthometric_from_wkt(wkt: &str) -> Option<String> {
    let i = ["VERT_CS[", "VERTCRS[", "VERTICALCRS["]
        .iter()
        .filter_map(|k| wkt.find(k).map(|i| i + k.len()))
        .min()?;
    let rest = wkt[i..].trim_start().strip_prefix('"')?;
    let name = &rest[..rest.find('"')?];
    (!name.to_ascii_lowercase().contains("ellipsoid")).then(|| name.to_string())
}

/// Parses `"EPSG","32632"]` or `"EPSG",32632]`.
fn parse_epsg_authority(s: &str) -> Option<u32> {
    let s = s.trim_start();
    let s = s
        .strip_prefix("\"EPSG\"")?
        .trim_start()
        .strip_prefix(',')?
        .trim_start();
    let s = s.trim_start_matches('"');
    let end = s.find(|c: char| !c.is_ascii_digit())?;
    s[..end].parse().ok()
}

/// A VLR copied verbatim (CRS records).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RawVlr {
    /// User id, e.g. `LASF_Projection`.
    pub user_id: String,
    /// Record id, e.g. 2112 (WKT) or 34735 (GeoKey directory).
    pub record_id: u16,
    /// Description.
    pub description: String,
    /// Payload.
    pub data: Vec<u8>,
}

impl From<&las::Vlr> for RawVlr {
    fn from(v: &las::Vlr) -> Self {
        RawVlr {
            user_id: v.user_id.clone(),
            record_id: v.record_id,
            description: v.description.clone(),
            data: v.data.clone(),
        }
    }
}

impl From<&RawVlr> for las::Vlr {
    fn from(v: &RawVlr) -> Self {
        las::Vlr {
            user_id: v.user_id.clone(),
            record_id: v.record_id,
            description: v.description.clone(),
            data: v.data.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orthometric_vertical_crs_is_named_and_ellipsoidal_heights_are_not() {
        let compound = "COMPD_CS[\"NAD83(2011) / UTM 15N + NAVD88 height\",PROJCS[\"NAD83(2011) / \
                        UTM zone 15N\",AUTHORITY[\"EPSG\",\"6344\"]],VERT_CS[\"NAVD88 height\",\
                        AUTHORITY[\"EPSG\",\"5703\"]]]";
        assert_eq!(
            orthometric_from_wkt(compound).as_deref(),
            Some("NAVD88 height")
        );
        assert_eq!(epsg_from_wkt(compound), Some(6344));
        let wkt2 =
            "COMPOUNDCRS[\"x\",PROJCRS[\"y\"],VERTCRS[\"EGM2008 height\",ID[\"EPSG\",3855]]]";
        assert_eq!(
            orthometric_from_wkt(wkt2).as_deref(),
            Some("EGM2008 height")
        );
        let ellipsoidal = "COMPD_CS[\"a\",PROJCS[\"b\"],VERT_CS[\"WGS 84 ellipsoidal height\"]]";
        assert_eq!(orthometric_from_wkt(ellipsoidal), None);
        assert_eq!(
            orthometric_from_wkt("PROJCS[\"WGS 84 / UTM zone 15N\"]"),
            None
        );
    }

    #[test]
    fn feet_and_metres_from_the_epsg_table() {
        let ft = Crs::from_epsg(2264).unwrap();
        assert_eq!(ft.unit(), LinearUnit::UsSurveyFoot);
        assert_eq!(ft.name(), "NAD83 / North Carolina (ftUS)");
        assert_eq!(ft.ellipsoid(), Ellipsoid::GRS80);
        // Lambert conformal conic: origin 33.75° N, 79° W at (609 601.22 m, 0).
        let o = ft.forward(33.75f64.to_radians(), (-79f64).to_radians());
        assert!((o.easting_m - 609_601.219_202_438_4).abs() < 1e-6, "{o:?}");
        assert!(o.northing_m.abs() < 1e-6, "{o:?}");
        assert!(o.convergence_rad.abs() < 1e-9);
        let utm = Crs::from_epsg(25833).unwrap();
        assert_eq!(utm.utm_zone().map(|z| z.zone()), Some(33));
        assert!(Crs::from_epsg(4326).is_err());
        assert!(Crs::from_epsg(1).is_err());
    }

    /// proj4rs's transverse Mercator (etmerc, Poder/Engsager) and the numerical convergence and
    /// scale against lidarqa's Krüger series with its closed forms, over Poland in CS92.
    #[test]
    fn proj4rs_path_agrees_with_the_kruger_series() {
        let def = crs_definitions::EPSG_2180.proj4.replace("tmerc", "etmerc");
        let exact = Crs::from_epsg(2180).unwrap();
        assert!(
            exact.central_meridian_rad().is_some(),
            "CS92 takes the Krüger series"
        );
        // The same definition forced through proj4rs (a latitude of origin of 1e-12°).
        let forced = def.replace("+lat_0=0", "+lat_0=0.000000000001");
        let numeric = Crs::from_proj_string(&forced, None, "CS92 via proj4rs").unwrap();
        assert!(numeric.central_meridian_rad().is_none());
        let (mut d_xy, mut d_gamma, mut d_k, mut d_inv) = (0f64, 0f64, 0f64, 0f64);
        for i in 0..=20 {
            for j in 0..=20 {
                let lat = (49.0 + 6.0 * f64::from(i) / 20.0).to_radians();
                let lon = (14.0 + 10.0 * f64::from(j) / 20.0).to_radians();
                let a = exact.forward(lat, lon);
                let b = numeric.forward(lat, lon);
                d_xy = d_xy.max((a.easting_m - b.easting_m).hypot(a.northing_m - b.northing_m));
                d_gamma = d_gamma.max((a.convergence_rad - b.convergence_rad).abs());
                d_k = d_k.max((a.scale - b.scale).abs());
                let (la, lo) = numeric.inverse(a.easting_m, a.northing_m);
                d_inv = d_inv.max((la - lat).abs().max((lo - lon).abs()));
                let u = numeric.unproject(a.easting_m, a.northing_m);
                assert!((u.convergence_rad() - a.convergence_rad).abs() < 1e-8);
            }
        }
        assert!(d_xy < 1e-3, "position {d_xy} m");
        assert!(d_gamma < 1e-8, "convergence {d_gamma} rad");
        assert!(d_k < 1e-8, "scale {d_k}");
        assert!(d_inv < 1e-9, "inverse {d_inv} rad");
        eprintln!(
            "proj4rs etmerc vs Krüger: {d_xy:e} m, γ {d_gamma:e} rad, k {d_k:e}, inverse {d_inv:e} rad"
        );
    }

    /// LAEA Europe: the centre maps to the false origin, convergence is zero on the central
    /// meridian and grows east of it, and the geometric-mean scale is 1 at the centre.
    #[test]
    fn laea_through_proj4rs() {
        let c = Crs::from_epsg(3035).unwrap();
        let o = c.forward(52f64.to_radians(), 10f64.to_radians());
        assert!(
            (o.easting_m - 4_321_000.0).abs() < 1e-6 && (o.northing_m - 3_210_000.0).abs() < 1e-6
        );
        assert!(
            o.convergence_rad.abs() < 1e-9 && (o.scale - 1.0).abs() < 1e-9,
            "{o:?}"
        );
        let p = c.forward(52f64.to_radians(), 16f64.to_radians());
        assert!(p.convergence_rad > 0.0, "{p:?}");
        let (lat, lon) = c.inverse(p.easting_m, p.northing_m);
        let d = (lat - 52f64.to_radians())
            .abs()
            .max((lon - 16f64.to_radians()).abs());
        eprintln!("LAEA round trip {d:e} rad");
        assert!(d < 1e-10, "{d}");
    }

    /// A WKT1 PROJCS without EPSG codes: the state plane's own definition, in US feet, gives the
    /// same projection as its EPSG code.
    #[test]
    fn wkt1_without_a_code_is_read_from_its_parameters() {
        let by_code = Crs::from_epsg(2264).unwrap();
        let wkt = "PROJCS[\"NC ftUS\",GEOGCS[\"NAD83\",DATUM[\"North_American_Datum_1983\",\
                   SPHEROID[\"GRS 1980\",6378137,298.257222101]],PRIMEM[\"Greenwich\",0],\
                   UNIT[\"degree\",0.0174532925199433]],PROJECTION[\"Lambert_Conformal_Conic_2SP\"],\
                   PARAMETER[\"standard_parallel_1\",36.16666666666666],\
                   PARAMETER[\"standard_parallel_2\",34.33333333333334],\
                   PARAMETER[\"latitude_of_origin\",33.75],PARAMETER[\"central_meridian\",-79],\
                   PARAMETER[\"false_easting\",2000000],PARAMETER[\"false_northing\",0],\
                   UNIT[\"US survey foot\",0.3048006096012192]]";
        let by_wkt = Crs::from_wkt(wkt).unwrap();
        assert_eq!(by_wkt.unit(), LinearUnit::UsSurveyFoot);
        assert_eq!(by_wkt.epsg(), None);
        let (lat, lon) = (35.5f64.to_radians(), (-80.2f64).to_radians());
        let (a, b) = (by_code.forward(lat, lon), by_wkt.forward(lat, lon));
        assert!((a.easting_m - b.easting_m).abs() < 1e-6, "{a:?} {b:?}");
        assert!((a.northing_m - b.northing_m).abs() < 1e-6, "{a:?} {b:?}");
        assert!((a.convergence_rad - b.convergence_rad).abs() < 1e-12);
        // CS92 as WKT1 TM without codes takes the Krüger series.
        let tm = "PROJCS[\"x\",GEOGCS[\"ETRS89\",DATUM[\"d\",SPHEROID[\"GRS 1980\",6378137,\
                  298.257222101]]],PROJECTION[\"Transverse_Mercator\"],\
                  PARAMETER[\"latitude_of_origin\",0],PARAMETER[\"central_meridian\",19],\
                  PARAMETER[\"scale_factor\",0.9993],PARAMETER[\"false_easting\",500000],\
                  PARAMETER[\"false_northing\",-5300000],UNIT[\"metre\",1]]";
        let tm = Crs::from_wkt(tm).unwrap();
        assert!(tm.central_meridian_rad().is_some());
        let c92 = Crs::from_epsg(2180).unwrap();
        let (p, q) = (tm.forward(lat + 0.3, 0.3), c92.forward(lat + 0.3, 0.3));
        assert!(
            (p.easting_m - q.easting_m).abs() < 1e-9 && (p.northing_m - q.northing_m).abs() < 1e-9
        );
        assert!(Crs::from_wkt("PROJCS[\"y\",PROJECTION[\"Cassini\"]]").is_err());
    }
}
