#!/usr/bin/env python3
"""Reference values for crates/io/tests/geodesy.rs, computed with PROJ (through pyproj).

PROJ's `+proj=utm` uses the Poder/Engsager extended transverse Mercator (its `etmerc`,
accurate to about a millimetre 30 degrees from the central meridian and to nanometres
within a few degrees), an implementation independent of lidarqa's Krüger/Karney series.
Convergence and scale come from PROJ's `proj_factors` (Proj.get_factors).

Run:  pip install pyproj==3.7.2 && python3 crates/io/tests/data/geodesy_reference.py
and paste the printed Rust table into tests/geodesy.rs.
"""
import pyproj

# (EPSG, latitude deg, longitude deg): inside zones, on the zone edge, and 3 degrees beyond.
CASES = [
    (32632, 45.0, 9.0),            # zone 32 central meridian
    (32632, 48.8583, 8.2945),      # 0.7 deg west of CM
    (32632, 52.0, 12.0),           # zone edge (3 deg east)
    (32632, 60.0, 15.0),           # 3 deg beyond the zone edge (6 deg from CM)
    (32632, 10.0, 3.0),            # 3 deg beyond the west edge, low latitude
    (32717, -2.0, -78.5),          # southern hemisphere, zone 17S
    (32733, -33.9, 18.4),          # Cape Town, zone 33S west of CM
    (32760, -45.0, 176.0),         # zone 60S
    (32601, 71.0, -178.0),         # zone 1N, high latitude
    (26915, 44.9778, -93.2650),    # NAD83 / UTM 15N (GRS 80), Minneapolis
    (26910, 47.6062, -122.3321),   # NAD83 / UTM 10N, Seattle
    (32631, 0.0, 3.0),             # equator on the CM
]

print("// (epsg, lat_deg, lon_deg, easting_m, northing_m, convergence_deg, scale)")
for epsg, lat, lon in CASES:
    crs = pyproj.CRS.from_epsg(epsg)
    geog = crs.geodetic_crs
    t = pyproj.Transformer.from_crs(geog, crs, always_xy=True)
    e, n = t.transform(lon, lat)
    proj = pyproj.Proj(crs)
    f = proj.get_factors(lon, lat)
    print(
        f"    ({epsg}, {lat!r}, {lon!r}, {e:.6f}, {n:.6f}, "
        f"{f.meridian_convergence:.12f}, {f.meridional_scale:.12f}),"
    )

print("// ECEF (WGS 84, EPSG:4979 -> EPSG:4978): (lat_deg, lon_deg, h_m, x_m, y_m, z_m)")
t = pyproj.Transformer.from_crs("EPSG:4979", "EPSG:4978", always_xy=True)
for lat, lon, h in [(27.99, 86.93, 8820.0), (-33.9, 151.2, -30.0), (45.0, 9.0, 1200.5)]:
    x, y, z = t.transform(lon, lat, h)
    print(f"    ({lat!r}, {lon!r}, {h!r}, {x:.6f}, {y:.6f}, {z:.6f}),")
