//! Geodesy against independent values: PROJ through pyproj (`tests/data/geodesy_reference.py`,
//! pyproj 3.7.2), finite differences, and round trips.

use lidarqa_io::{Ellipsoid, Geodetic, UtmZone, ecef_to_geodetic, geodetic_to_ecef};
use lidarqa_model::ecef_from_ned;
use nalgebra::Vector3;

/// Printed by `tests/data/geodesy_reference.py`:
/// (epsg, lat_deg, lon_deg, easting_m, northing_m, convergence_deg, scale).
#[allow(clippy::type_complexity)]
const PROJ_UTM: &[(u32, f64, f64, f64, f64, f64, f64)] = &[
    (
        32632,
        45.0,
        9.0,
        500000.000000,
        4982950.400227,
        -0.000000000000,
        0.999600000000,
    ),
    (
        32632,
        48.8583,
        8.2945,
        448251.898291,
        5411943.793808,
        -0.531313018718,
        0.999632897291,
    ),
    (
        32632,
        52.0,
        12.0,
        705928.918947,
        5765288.254857,
        2.364857471206,
        1.000120623696,
    ),
    (
        32632,
        60.0,
        15.0,
        834359.667892,
        6666593.572147,
        5.200922216457,
        1.000970303506,
    ),
    (
        32632,
        10.0,
        3.0,
        -158712.847698,
        1111418.032884,
        -1.045671797803,
        1.004973869586,
    ),
    (
        32717,
        -2.0,
        -78.5,
        778107.715570,
        9778727.155921,
        -0.087305210133,
        1.000557554216,
    ),
    (
        32733,
        -33.9,
        18.4,
        814420.330951,
        6243724.840075,
        -1.897889446823,
        1.000818903018,
    ),
    (
        32760,
        -45.0,
        176.0,
        421184.697083,
        5016563.231651,
        0.707143045584,
        0.999676381334,
    ),
    (
        32601,
        71.0,
        -178.0,
        463664.972582,
        7877696.583721,
        -0.945528773236,
        0.999616147671,
    ),
    (
        26915,
        44.9778,
        -93.265,
        479105.882463,
        4980518.419835,
        -0.187311353966,
        0.999605367996,
    ),
    (
        26910,
        47.6062,
        -122.3321,
        550200.213359,
        5272748.591471,
        0.493273303574,
        0.999630967711,
    ),
    (
        32631,
        0.0,
        3.0,
        500000.000000,
        0.000000,
        -0.000000000000,
        0.999600000051,
    ),
];

#[test]
fn utm_matches_proj_to_a_tenth_of_a_millimetre() {
    for &(epsg, lat, lon, e, n, gamma_deg, k) in PROJ_UTM {
        let zone = UtmZone::from_epsg(epsg).unwrap();
        let p = zone.forward(lat.to_radians(), lon.to_radians());
        // PROJ's values are printed to 1 µm; both series are good to nanometres here.
        assert!(
            (p.easting_m - e).abs() < 1e-4,
            "{epsg} {lat} {lon}: E {} vs {e}",
            p.easting_m
        );
        assert!(
            (p.northing_m - n).abs() < 1e-4,
            "{epsg} {lat} {lon}: N {} vs {n}",
            p.northing_m
        );
        // Convergence printed to 1e-12°, scale to 1e-12; PROJ computes both by numerical
        // differentiation, good to about 1e-9.
        assert!(
            (p.convergence_rad.to_degrees() - gamma_deg).abs() < 1e-8,
            "{epsg} γ"
        );
        assert!((p.scale - k).abs() < 1e-9, "{epsg} k {} vs {k}", p.scale);
    }
}

#[test]
fn ecef_matches_proj() {
    for &(lat, lon, h, x, y, z) in &[
        (
            27.99,
            86.93,
            8820.0,
            302271.432714,
            5635928.367499,
            2979666.134903,
        ),
        (
            -33.9,
            151.2,
            -30.0,
            -4643924.207058,
            2553018.937261,
            -3537228.615552,
        ),
        (
            45.0,
            9.0,
            1200.5,
            4462810.269167,
            706839.706757,
            4488197.290557,
        ),
    ] {
        let g = Geodetic {
            latitude_rad: f64::to_radians(lat),
            longitude_rad: f64::to_radians(lon),
            height_m: h,
        };
        let p = geodetic_to_ecef(&g);
        assert!(
            (p.vector() - Vector3::new(x, y, z)).norm() < 2e-6,
            "{lat} {lon}"
        );
    }
}

#[test]
fn utm_round_trips() {
    for &(epsg, lat, lon, ..) in PROJ_UTM {
        let zone = UtmZone::from_epsg(epsg).unwrap();
        let (lat, lon) = (lat.to_radians(), lon.to_radians());
        let p = zone.forward(lat, lon);
        let (lat2, lon2) = zone.inverse(p.easting_m, p.northing_m);
        // Angles to metres on the ground: 1 rad of latitude ≈ 6.4e6 m.
        let m = Ellipsoid::WGS84.meridian_radius_m(lat);
        let nr = Ellipsoid::WGS84.prime_vertical_radius_m(lat);
        // 1e-9 m, except where the angle itself is coarser in f64: one ulp of a longitude
        // between 1 and 2 rad is 2.2e-16 rad, 1.4e-9 m at the equator; allow two ulp there.
        let tol_lat = 1e-9_f64.max(2.0 * f64::EPSILON * lat.abs() * m);
        let tol_lon = 1e-9_f64.max(2.0 * f64::EPSILON * lon.abs() * nr * lat.cos());
        let (dlat, dlon) = ((lat2 - lat).abs() * m, (lon2 - lon).abs() * nr * lat.cos());
        assert!(dlat < tol_lat, "{epsg}: {dlat} m");
        assert!(dlon < tol_lon, "{epsg}: {dlon} m");
        let p2 = zone.forward(lat2, lon2);
        // Easting ≤ 1e6 m is resolved to 1.2e-10 m; northing up to 1e7 m only to 1.9e-9 m
        // (one f64 ulp), so the grid round trip is checked to 1e-9 m and 4e-9 m.
        assert!((p2.easting_m - p.easting_m).abs() < 1e-9, "{epsg}");
        assert!((p2.northing_m - p.northing_m).abs() < 4e-9, "{epsg}");
    }
}

/// Convergence and scale against finite differences of the projection itself along the
/// meridian: the grid image of true north has grid bearing −γ, and its length per metre on the
/// ellipsoid is k.
#[test]
fn convergence_and_scale_match_finite_differences() {
    let zone = UtmZone::from_epsg(32632).unwrap();
    let tm = zone.projection();
    for &(lat_deg, lon_deg) in &[(45.0, 12.0), (30.0, 4.0), (-20.0, 14.5), (60.0, 9.1)] {
        let (lat, lon) = (f64::to_radians(lat_deg), f64::to_radians(lon_deg));
        // h = 1e-5 rad ≈ 64 m: the central difference errs by O(h²) ≈ 1e-10 and the rounding of
        // coordinates near 5e6 m (1e-9 m) adds 1e-9 / 64 ≈ 2e-11.
        let h = 1e-5;
        let a = tm.forward(lat - h, lon);
        let b = tm.forward(lat + h, lon);
        let (de, dn) = (b.easting_m - a.easting_m, b.northing_m - a.northing_m);
        let gamma_fd = (-de).atan2(dn);
        let k_fd = de.hypot(dn) / (2.0 * h * Ellipsoid::WGS84.meridian_radius_m(lat));
        let p = tm.forward(lat, lon);
        assert!(
            (p.convergence_rad - gamma_fd).abs() < 1e-9,
            "{lat_deg} {lon_deg}"
        );
        assert!((p.scale - k_fd).abs() < 1e-9, "{lat_deg} {lon_deg}");
        assert_eq!(zone.grid_convergence(lat, lon), p.convergence_rad);
        assert_eq!(zone.point_scale_factor(lat, lon), p.scale);
    }
}

/// SPEC §3: never add an NED vector to easting/northing. 1000 m due north in the local level
/// frame, 3° east of the central meridian at 45° N, moves the point on the grid by
/// k·1000 m along grid bearing −γ: ΔE = −k·1000·sin γ ≈ −37 m, ΔN = k·1000·cos γ.
/// γ and k are taken at the midpoint, which cancels their first-order change along the line;
/// what remains (the tangent-plane line rises 0.08 m above the ellipsoid and is 8 µm longer
/// than its footprint) is far below the 1 mm tolerance, while the naive ΔE = 0 is off by 37 m.
#[test]
fn north_in_ned_moves_east_on_the_grid_by_the_convergence() {
    let zone = UtmZone::from_epsg(32632).unwrap();
    let start = Geodetic {
        latitude_rad: 45f64.to_radians(),
        longitude_rad: 12f64.to_radians(),
        height_m: 0.0,
    };
    let x0 = geodetic_to_ecef(&start);
    let x1 = x0
        + ecef_from_ned(start.latitude_rad, start.longitude_rad) * Vector3::new(1000.0, 0.0, 0.0);
    let end = ecef_to_geodetic(&x1);
    assert!((end.height_m - 1000f64.powi(2) / (2.0 * 6.37e6)).abs() < 0.01);
    let p0 = zone.forward(start.latitude_rad, start.longitude_rad);
    let p1 = zone.forward(end.latitude_rad, end.longitude_rad);
    let mid = zone.forward(
        0.5 * (start.latitude_rad + end.latitude_rad),
        0.5 * (start.longitude_rad + end.longitude_rad),
    );
    let expected_de = -mid.scale * 1000.0 * mid.convergence_rad.sin();
    let expected_dn = mid.scale * 1000.0 * mid.convergence_rad.cos();
    let (de, dn) = (p1.easting_m - p0.easting_m, p1.northing_m - p0.northing_m);
    assert!(de < -36.0, "ΔE = {de}");
    assert!((de - expected_de).abs() < 1e-3, "ΔE {de} vs {expected_de}");
    assert!((dn - expected_dn).abs() < 1e-3, "ΔN {dn} vs {expected_dn}");
}
