#!/usr/bin/env python3
"""The same airborne strip written in several projected CRSs, for the CRS acceptance tests.

Independent of lidarqa's simulator and geodesy: numpy for the geometry, pyproj for every
projection (PROJ), laspy for the LAS files. Usage:

    python3 crs_scenes.py OUT_DIR [N_POINTS]
    python3 crs_scenes.py --compare OUT_DIR   # after `lidarqa tpu` wrote OUT_DIR/out_<name>.las
    python3 crs_scenes.py --compare-correct OUT_DIR  # after `lidarqa correct` wrote
                                                     # OUT_DIR/corr_<name>/<name>.las

writes into OUT_DIR, for each CRS in CRSS, `<name>.las` (LAS 1.4, point format 6, the CRS as a
WKT VLR with its EPSG code, GPS seconds of week) and `<name>.csv` (the trajectory: time,
X/Y/Z in that CRS and unit, roll, pitch, and the GRID azimuth of the heading, degrees), plus
`sensor.toml` (a linear scanner, zero mounting, σ of an ordinary survey) and `truth.csv`
(latitude, longitude, ellipsoidal height of every point).

The strip: a level flight 1000 m above gently rolling ground near 52.1° N 15.6° E (inside UTM
33, Poland CS2000 zone 5, CS92 and LAEA Europe), true heading 32°, roll 1.5°, pitch 2°, a linear
scanner sweeping ±30° in the body Y-Z plane. The same geodetic points and poses are projected
into each CRS, so lidarqa's per-point σ must not depend on the CRS. The US-feet state plane
(EPSG:2264, NAD83 / North Carolina, Lambert conformal conic, US survey feet; GRS 80 like
ETRS89, no datum shift applied) is used far outside its area of use: the projection is still
exact and conformal there, which is all this check needs (grid convergence about −55°, which
the grid azimuths carry). Its Z is in US survey feet too.
"""

import sys
from pathlib import Path

import laspy
import numpy as np
import pyproj

# name, EPSG code. All on the GRS 80 ellipsoid (ETRS89 / NAD83), so no datum shift is involved.
CRSS = [
    ("utm33", 25833),  # ETRS89 / UTM zone 33N
    ("cs92", 2180),  # ETRS89 / Poland CS92 (TM, k0 0.9993, lon0 19°, y0 −5 300 000 m)
    ("cs2000", 2176),  # ETRS89 / Poland CS2000 zone 5 (TM, k0 0.999923, lon0 15°)
    ("laea", 3035),  # ETRS89 / LAEA Europe
    ("ncft", 2264),  # NAD83 / North Carolina (ftUS), LCC
]

A = 6378137.0
F = 1.0 / 298.257222101
E2 = F * (2.0 - F)
GPS_WEEK_S0 = 300_000.0


_lla_to_ecef = pyproj.Transformer.from_crs(
    pyproj.CRS.from_proj4("+proj=longlat +ellps=GRS80"),
    pyproj.CRS.from_proj4("+proj=geocent +ellps=GRS80"),
    always_xy=True,
)


def geodetic_to_ecef(lat, lon, h):
    x, y, z = _lla_to_ecef.transform(lon, lat, h, radians=True)
    return np.stack([x, y, z], axis=-1)


_ecef_to_lla = pyproj.Transformer.from_crs(
    pyproj.CRS.from_proj4("+proj=geocent +ellps=GRS80"),
    pyproj.CRS.from_proj4("+proj=longlat +ellps=GRS80"),
    always_xy=True,
)


def ecef_to_geodetic(p):
    lon, lat, h = _ecef_to_lla.transform(p[:, 0], p[:, 1], p[:, 2], radians=True)
    return lat, lon, h


def ned_to_ecef(lat, lon):
    """Columns: north, east, down in ECEF, one 3×3 per point."""
    sp, cp, sl, cl = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    north = np.stack([-sp * cl, -sp * sl, cp], axis=-1)
    east = np.stack([-sl, cl, np.zeros_like(sl)], axis=-1)
    down = np.stack([-cp * cl, -cp * sl, -sp], axis=-1)
    return np.stack([north, east, down], axis=-1)


def body_to_ned(roll, pitch, heading):
    """R = Rz(heading) Ry(pitch) Rx(roll), body x forward, y right, z down."""
    cr, sr = np.cos(roll), np.sin(roll)
    cpi, spi = np.cos(pitch), np.sin(pitch)
    ch, sh = np.cos(heading), np.sin(heading)
    rz = np.array([[ch, -sh, 0], [sh, ch, 0], [0, 0, 1.0]])
    ry = np.array([[cpi, 0, spi], [0, 1.0, 0], [-spi, 0, cpi]])
    rx = np.array([[1.0, 0, 0], [0, cr, -sr], [0, sr, cr]])
    return rz @ ry @ rx


def ground_height(lat, lon):
    """Rolling ground, ellipsoidal metres."""
    dn = (lat - LAT0) * 6.37e6
    de = (lon - LON0) * 6.37e6 * np.cos(LAT0)
    return 120.0 + 6.0 * np.sin(dn / 90.0) + 4.0 * np.cos(de / 70.0)


LAT0 = np.radians(52.1)
LON0 = np.radians(15.6)
HEADING = np.radians(32.0)
ROLL = np.radians(1.5)
PITCH = np.radians(2.0)


def poses(t):
    """Aircraft geodetic position along a geodesic-ish straight line at 60 m/s, 1120 m."""
    s = 60.0 * t
    m = A * (1 - E2) / (1 - E2 * np.sin(LAT0) ** 2) ** 1.5
    n = A / np.sqrt(1 - E2 * np.sin(LAT0) ** 2)
    lat = LAT0 + s * np.cos(HEADING) / m
    lon = LON0 + s * np.sin(HEADING) / (n * np.cos(LAT0))
    h = np.full_like(t, 1120.0)
    return lat, lon, h


def grid_azimuth(proj, lat, lon, heading):
    """True heading → grid azimuth: true north's grid bearing is −γ (central differences)."""
    d = 1e-6
    e1, n1 = proj.transform(lon, lat + d, radians=True)
    e0, n0 = proj.transform(lon, lat - d, radians=True)
    gamma = -np.arctan2(np.asarray(e1) - e0, np.asarray(n1) - n0)
    return heading - gamma


def main():
    out = Path(sys.argv[1])
    n_points = int(sys.argv[2]) if len(sys.argv) > 2 else 200_000
    out.mkdir(parents=True, exist_ok=True)
    per_line = 500
    lines = max(1, n_points // per_line)
    line_s = 0.02
    # Scan: ±30° in the body Y-Z plane, one line every 20 ms.
    theta = np.radians(np.linspace(-30.0, 30.0, per_line))
    t_line = np.arange(lines) * line_s
    t = (t_line[:, None] + np.arange(per_line)[None, :] * (line_s / per_line)).ravel()
    th = np.tile(theta, lines)
    lat_a, lon_a, h_a = poses(t)
    p0 = geodetic_to_ecef(lat_a, lon_a, h_a)
    r_bn = body_to_ned(ROLL, PITCH, HEADING)
    beam_body = np.stack([np.zeros_like(th), np.sin(th), np.cos(th)], axis=-1)
    beam_ned = beam_body @ r_bn.T
    beam = np.einsum("kij,kj->ki", ned_to_ecef(lat_a, lon_a), beam_ned)
    rho = (h_a - 120.0) / beam_ned[:, 2]
    for _ in range(8):
        lat, lon, h = ecef_to_geodetic(p0 + rho[:, None] * beam)
        rho += (h - ground_height(lat, lon)) / beam_ned[:, 2]
    lat, lon, h = ecef_to_geodetic(p0 + rho[:, None] * beam)

    # Trajectory at 100 Hz with a 2 s margin either side.
    tt = np.arange(-2.0, t[-1] + 2.0, 0.01)
    lat_t, lon_t, h_t = poses(tt)

    for name, epsg in CRSS:
        crs = pyproj.CRS.from_epsg(epsg)
        proj = pyproj.Transformer.from_crs(crs.geodetic_crs, crs, always_xy=True)
        unit = crs.axis_info[0].unit_conversion_factor  # metres per unit
        x, y = proj.transform(lon, lat, radians=True)
        z = h / unit
        header = laspy.LasHeader(point_format=6, version="1.4")
        header.scales = np.array([0.001, 0.001, 0.001])
        header.offsets = np.array([np.floor(np.min(x)), np.floor(np.min(y)), 0.0])
        header.add_crs(crs)
        las = laspy.LasData(header)
        las.x, las.y, las.z = x, y, z
        las.gps_time = GPS_WEEK_S0 + t
        las.intensity = np.full(len(t), 100, dtype=np.uint16)
        las.classification = np.full(len(t), 2, dtype=np.uint8)
        las.scan_angle = np.round(np.degrees(th) / 0.006).astype(np.int16)
        las.write(out / f"{name}.las")

        xt, yt = proj.transform(lon_t, lat_t, radians=True)
        az = grid_azimuth(proj, lat_t, lon_t, np.full_like(tt, HEADING))
        rows = np.column_stack(
            [
                GPS_WEEK_S0 + tt,
                xt,
                yt,
                h_t / unit,
                np.full_like(tt, np.degrees(ROLL)),
                np.full_like(tt, np.degrees(PITCH)),
                np.degrees(az),
            ]
        )
        np.savetxt(
            out / f"{name}.csv",
            rows,
            delimiter=",",
            header="time,x,y,z,roll,pitch,azimuth",
            comments="",
            fmt="%.6f",
        )
    np.savetxt(
        out / "truth.csv",
        np.column_stack([np.degrees(lat), np.degrees(lon), h]),
        delimiter=",",
        header="latitude,longitude,height",
        comments="",
        fmt="%.10f",
    )
    (out / "sensor.toml").write_text(
        """# Written by crs_scenes.py: a linear scanner, zero mounting, the σ of an ordinary survey.
[scanner]
type = "linear"
beam_divergence_mrad = 0.3

[mounting]
lever_arm_m = [0.0, 0.0, 0.0]
boresight_roll_deg = 0.0
boresight_pitch_deg = 0.0
boresight_yaw_deg = 0.0

[sigma]
range_m = 0.02
scan_angle_deg = 0.001
roll_deg = 0.003
pitch_deg = 0.003
heading_deg = 0.005
gnss_north_m = 0.03
gnss_east_m = 0.03
gnss_up_m = 0.05
lever_x_m = 0.01
lever_y_m = 0.01
lever_z_m = 0.01
boresight_roll_deg = 0.001
boresight_pitch_deg = 0.001
boresight_yaw_deg = 0.001
"""
    )
    print(f"{len(t)} points, {len(tt)} poses, {len(CRSS)} CRSs in {out}")


def compare(out):
    """Largest relative difference of each σ from the first CRS's, per CRS; exit 1 beyond 0.5 %."""
    names = ["sigma_north", "sigma_east", "sigma_up", "sigma_horizontal"]
    ref = None
    worst = 0.0
    for name, _ in CRSS:
        o = laspy.read(out / f"out_{name}.las")
        s = np.column_stack([np.asarray(o[n], dtype=float) for n in names])
        if ref is None:
            ref = s
        rel = np.abs(s / ref - 1.0).max(axis=0)
        worst = max(worst, rel.max())
        med = np.median(s, axis=0) * 100
        print(
            f"{name:<7} {len(s)} points; median σ N/E/up/h "
            + " / ".join(f"{m:.3f}" for m in med)
            + " cm; max |rel diff| vs "
            + CRSS[0][0]
            + " "
            + " / ".join(f"{r * 100:.4f}" for r in rel)
            + " %"
        )
    print(f"largest relative difference {worst * 100:.4f} %")
    return 0 if worst <= 0.005 else 1


def compare_correct(out):
    """Corrected points of every CRS taken to ECEF with pyproj: largest distance from the first's."""
    ref = None
    worst = 0.0
    for name, epsg in CRSS:
        crs = pyproj.CRS.from_epsg(epsg)
        unit = crs.axis_info[0].unit_conversion_factor
        o = laspy.read(out / f"corr_{name}" / f"{name}.las")
        lon, lat = pyproj.Transformer.from_crs(crs, crs.geodetic_crs, always_xy=True).transform(
            np.asarray(o.x), np.asarray(o.y), radians=True
        )
        p = np.column_stack(_lla_to_ecef.transform(lon, lat, np.asarray(o.z) * unit, radians=True))
        if ref is None:
            ref = p
        d = np.linalg.norm(p - ref, axis=1).max()
        worst = max(worst, d)
        print(f"{name:<7} {len(p)} corrected points; largest distance from {CRSS[0][0]}'s {d * 1000:.2f} mm")
    return 0 if worst <= 0.005 else 1


if __name__ == "__main__":
    if sys.argv[1] == "--compare-correct":
        sys.exit(compare_correct(Path(sys.argv[2])))
    if sys.argv[1] == "--compare":
        sys.exit(compare(Path(sys.argv[2])))
    main()
