//! WKT1 text of the projected CRSs lidarqa writes into the LAS files it creates (the simulator's
//! strips, points georeferenced from raw sensor records).

use crate::geodesy::{Hemisphere, UtmDatum, UtmZone};

/// WKT1 of a UTM CRS (WGS 84 or NAD83) with its EPSG code, for a LAS 1.4 WKT VLR (point formats
/// 6–10 require WKT).
pub fn utm_wkt(zone: &UtmZone, epsg: u32) -> String {
    let (geogcs, datum, spheroid, a_inv_f, sph_code, datum_code, geog_code) = match zone.datum() {
        UtmDatum::Nad83 => (
            "NAD83",
            "North_American_Datum_1983",
            "GRS 1980",
            "298.257222101",
            7019,
            6269,
            4269,
        ),
        _ => (
            "WGS 84",
            "WGS_1984",
            "WGS 84",
            "298.257223563",
            7030,
            6326,
            4326,
        ),
    };
    let hemisphere = match zone.hemisphere() {
        Hemisphere::North => ("N", 0),
        Hemisphere::South => ("S", 10_000_000),
    };
    format!(
        "PROJCS[\"{geogcs} / UTM zone {z}{h}\",GEOGCS[\"{geogcs}\",DATUM[\"{datum}\",SPHEROID[\"{spheroid}\",6378137,{a_inv_f},AUTHORITY[\"EPSG\",\"{sph_code}\"]],AUTHORITY[\"EPSG\",\"{datum_code}\"]],PRIMEM[\"Greenwich\",0,AUTHORITY[\"EPSG\",\"8901\"]],UNIT[\"degree\",0.0174532925199433,AUTHORITY[\"EPSG\",\"9122\"]],AUTHORITY[\"EPSG\",\"{geog_code}\"]],PROJECTION[\"Transverse_Mercator\"],PARAMETER[\"latitude_of_origin\",0],PARAMETER[\"central_meridian\",{cm}],PARAMETER[\"scale_factor\",0.9996],PARAMETER[\"false_easting\",500000],PARAMETER[\"false_northing\",{fn_}],UNIT[\"metre\",1,AUTHORITY[\"EPSG\",\"9001\"]],AXIS[\"Easting\",EAST],AXIS[\"Northing\",NORTH],AUTHORITY[\"EPSG\",\"{epsg}\"]]",
        z = zone.zone(),
        h = hemisphere.0,
        cm = zone.central_meridian_rad().to_degrees().round(),
        fn_ = hemisphere.1,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wkt_names_the_epsg_code() {
        let zone = UtmZone::from_epsg(32649).unwrap();
        let wkt = utm_wkt(&zone, 32649);
        assert_eq!(crate::epsg_from_wkt(&wkt), Some(32649));
        assert!(wkt.contains("PARAMETER[\"central_meridian\",111]"));
    }
}
