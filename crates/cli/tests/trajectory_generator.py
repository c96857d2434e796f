#!/usr/bin/env python3
"""An independent witness for `lidarqa trajectory`: multi-return pulses written from
the format's description alone, with numpy + laspy, not with lidarqa's simulator.

A scanner flies a straight line at 300 m, 55 m/s, on a grid bearing of 30 degrees, nose up 1.5
degrees, rolling 2 degrees (which the method cannot see). A sine scan of +-25 degrees at 35 Hz fires
40 kHz; 40 % of the pulses hit a crown 8-25 m above a flat ground and give two returns (first on the
crown, last on the ground, same GPS time, LAS return numbers set). Coordinates are stored at 1 mm;
every return gets 2 cm of range noise along its beam and 1 cm of isotropic noise (by default). Then
it writes a LAS 1.4 file, runs `lidarqa trajectory`, and checks the written trajectory against the
flight it made: position RMS, heading and pitch, and that the reported sigma match the errors
(RMS(error/sigma) of x, y, z, heading and pitch within 0.5-2: neither hiding nor overstating them).
One 6 s flight has 14 epochs, too few for a stable ratio: the flight is flown with SEEDS different
noise draws and the ratios are taken over all of them.

The truth of the attitude: the body's forward axis is fixed in the tangent-plane frame, so the
pitch and azimuth it has where the scanner is are that axis in the local east-north-up frame
there (`level_at`): the local vertical turns by d/R over d metres from the tangent point
(0.0005 deg at 55 m), and lidarqa re-levels its own plane at each epoch in the same way.

What limits the pitch (measured with this generator): from the returns alone, with the
true scanner positions as the beams' apex, the scan plane gives the pitch to 0.04 arcsec; the
apex the method has is the fitted scanner position, and an error of d along the plane's normal
(nearly the flight direction) tilts every beam by d / range: 3 mm gives 2.1 arcsec. The block
fits' position errors of 2-3 mm are therefore the pitch's error (about 2 arcsec, far above the
returns' noise), and lidarqa's pitch sigma must carry them.

Usage:  python3 trajectory_generator.py LIDARQA_BINARY WORKDIR
Optional environment: TRAJ_GEN_SEEDS (comma-separated noise draws, default 24,25,26,27) and
TRAJ_GEN_NOISE_M (the isotropic noise of every return, default 0.01), e.g. for the height bias
that noise on the lines causes (errors in variables): TRAJ_GEN_NOISE_M=0.03
TRAJ_GEN_SEEDS=100,101,102,103,104,105,106,107.
Prints one line per check and a closing "N passed, 0 failed"; exits non-zero on a failure.
Requires: pip install laspy lazrs numpy pyproj
"""
import csv
import math
import os
import subprocess
import sys

import laspy
import numpy as np
import pyproj

lidarqa, work = sys.argv[1], sys.argv[2]
SEEDS = tuple(int(x) for x in os.environ.get("TRAJ_GEN_SEEDS", "24,25,26,27").split(","))
ISO_NOISE_M = float(os.environ.get("TRAJ_GEN_NOISE_M", "0.01"))

# The flight, in a local east-north-up Cartesian frame tangent to the WGS 84 ellipsoid at the
# point (500000, 4000000) of UTM 33N (coordinates below are written as easting/northing
# offsets of that point, but the geometry is Cartesian: straight beams, a flat tangent-plane
# ground). Points and the flight are then put into UTM 33N + ellipsoidal height with pyproj,
# as a real delivery stores them (there, easting and northing shrink with height).
T0, DURATION, RATE = 500000.0, 6.0, 40000.0
SPEED, HEIGHT, BEARING, PITCH, ROLL = 55.0, 300.0, math.radians(30.0), math.radians(1.5), math.radians(2.0)
START = np.array([500000.0, 4000000.0, 100.0 + HEIGHT])
fwd = np.array([math.sin(BEARING), math.cos(BEARING), 0.0])
right = np.array([math.cos(BEARING), -math.sin(BEARING), 0.0])
up = np.array([0.0, 0.0, 1.0])
# Body axes: x forward pitched up, y right, z down.
bx = math.cos(PITCH) * fwd + math.sin(PITCH) * up
bz = math.sin(PITCH) * fwd - math.cos(PITCH) * up


def sensor(t):
    return START + np.outer(t - T0, fwd * SPEED)


ORIGIN_EN = np.array([500000.0, 4000000.0])
_lon0, _lat0 = pyproj.Transformer.from_crs(32633, 4326, always_xy=True).transform(*ORIGIN_EN)
_to_ecef = pyproj.Transformer.from_crs(4979, 4978, always_xy=True)
_from_ecef = pyproj.Transformer.from_crs(4978, 4979, always_xy=True)
_to_utm = pyproj.Transformer.from_crs(4326, 32633, always_xy=True)
X0 = np.array(_to_ecef.transform(_lon0, _lat0, 0.0))
_la, _lo = math.radians(_lat0), math.radians(_lon0)
ENU_TO_ECEF = np.array([
    [-math.sin(_lo), -math.sin(_la) * math.cos(_lo), math.cos(_la) * math.cos(_lo)],
    [math.cos(_lo), -math.sin(_la) * math.sin(_lo), math.cos(_la) * math.sin(_lo)],
    [0.0, math.cos(_la), math.sin(_la)],
])


def to_delivery(p):
    """Local frame (written as easting/northing offsets of ORIGIN_EN, z up) -> UTM 33N + h."""
    enu = np.asarray(p, float) - np.array([ORIGIN_EN[0], ORIGIN_EN[1], 0.0])
    ecef = X0 + enu @ ENU_TO_ECEF.T
    lon, lat, h = _from_ecef.transform(ecef[:, 0], ecef[:, 1], ecef[:, 2])
    e, n = _to_utm.transform(lon, lat)
    return np.c_[e, n, h], lon, lat


def level_at(lon, lat, v):
    """The tangent-frame direction v in the local east, north, up at (lon, lat), degrees."""
    la, lo = np.radians(lat), np.radians(lon)
    east = np.c_[-np.sin(lo), np.cos(lo), np.zeros_like(lo)]
    north = np.c_[-np.sin(la) * np.cos(lo), -np.sin(la) * np.sin(lo), np.cos(la)]
    up_ = np.c_[np.cos(la) * np.cos(lo), np.cos(la) * np.sin(lo), np.sin(la)]
    w = ENU_TO_ECEF @ v
    return np.sum(east * w, 1), np.sum(north * w, 1), np.sum(up_ * w, 1)


def fly(seed):
    """One flight with its own noise: the lidarqa trajectory's errors and sigma per epoch."""
    rng = np.random.default_rng(seed)
    t = T0 + np.arange(int(DURATION * RATE)) / RATE
    theta = math.radians(25.0) * np.sin(2 * math.pi * 35.0 * (t - T0)) + ROLL
    # The beam is cos(theta) z + sin(theta) y.
    beam = np.outer(np.cos(theta), bz) + np.outer(np.sin(theta), right)
    s = sensor(t)
    rng_ground = (s[:, 2] - 100.0) / -beam[:, 2]
    multi = rng.random(len(t)) < 0.4
    crown = rng.uniform(8.0, 25.0, len(t))
    rng_crown = (s[:, 2] - 100.0 - crown) / -beam[:, 2]
    # Range noise along the beam, and isotropic coordinate noise (1 cm by default) on every
    # return (which tilts the first-last lines: the fit's sigma must cover what that does).
    noise = lambda n: rng.normal(0.0, 0.02, n)
    iso = lambda: rng.normal(0.0, ISO_NOISE_M, (len(t), 3))
    g = s + beam * (rng_ground + noise(len(t)))[:, None] + iso()
    c = s + beam * (rng_crown + noise(len(t)))[:, None] + iso()
    m = np.flatnonzero(multi)
    single = np.flatnonzero(~multi)
    pts = np.r_[c[m], g[m], g[single]]
    times = np.r_[t[m], t[m], t[single]]
    rn = np.r_[np.ones(len(m)), np.full(len(m), 2), np.ones(len(single))].astype(np.uint8)
    nr = np.r_[np.full(2 * len(m), 2), np.ones(len(single))].astype(np.uint8)
    # Time order, the first return before the last.
    order = np.lexsort((rn, times))
    pts, _, _ = to_delivery(pts)

    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales = [0.001, 0.001, 0.001]
    header.offsets = [500000.0, 4000000.0, 0.0]
    header.add_crs(pyproj.CRS.from_epsg(32633))
    las = laspy.LasData(header)
    las.x, las.y, las.z = pts[order, 0], pts[order, 1], pts[order, 2]
    las.gps_time = times[order]
    las.return_number = rn[order]
    las.number_of_returns = nr[order]
    las.point_source_id = np.full(len(order), 7)
    path = f"{work}/generated_{seed}.las"
    las.write(path)

    out = f"{work}/generated_{seed}_trajectory.csv"
    run = subprocess.run([lidarqa, "trajectory", path, "-o", out], capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(f"lidarqa trajectory failed: {run.stderr}")

    rows = list(csv.DictReader(l for l in open(out) if not l.startswith("#")))
    col = lambda k: np.array([float(r[k]) for r in rows])
    tt = col("time")
    xyz = np.c_[col("x"), col("y"), col("z")]
    truth, lon_t, lat_t = to_delivery(sensor(tt))
    # The body's forward axis, levelled where the scanner is: true azimuth and pitch there, and
    # the grid azimuth = true - convergence (pyproj's meridian convergence, positive east of the
    # central meridian, as lidarqa's).
    fe, fn, fu = level_at(lon_t, lat_t, bx)
    gamma = np.array(pyproj.Proj(32633).get_factors(lon_t, lat_t).meridian_convergence)
    daz = (col("azimuth") - (np.degrees(np.arctan2(fe, fn)) - gamma) + 180.0) % 360.0 - 180.0
    return {
        "epochs": len(rows),
        "err": xyz - truth,
        "sig": np.column_stack([col(f"reconstruction_sigma_{k}_m") for k in "xyz"]),
        "daz": daz,
        "s_az": col("reconstruction_sigma_azimuth_deg"),
        "dp": col("pitch") - np.degrees(np.arcsin(fu)),
        "s_p": col("reconstruction_sigma_pitch_deg"),
        "roll": col("roll"),
    }


passed = failed = 0


def check(name, ok, detail):
    global passed, failed
    print(("ok   " if ok else "FAIL ") + f"{name}: {detail}")
    if ok:
        passed += 1
    else:
        failed += 1


flights = [fly(seed) for seed in SEEDS]
cat = lambda k: np.concatenate([f[k] for f in flights])
rms = lambda x: math.sqrt(np.mean(np.square(x)))
err, sig, daz, dp = cat("err"), cat("sig"), cat("daz"), cat("dp")
n = len(daz)
pos_rms = math.sqrt(np.mean(np.sum(err**2, axis=1)))
check("position RMS", pos_rms <= 0.5, f"{pos_rms:.4f} m over {n} epochs of {len(SEEDS)} flights")
check("heading (grid azimuth)", rms(daz) <= 0.2, f"RMS {rms(daz):.5f} deg")
check("pitch", rms(dp) <= 0.2, f"RMS {rms(dp):.5f} deg")
# The reported sigma against the actual errors: on this steady flight they must be the
# errors' own size, neither hiding them (> 2) nor overstating them (< 0.5).
for name, z in [
    ("x", err[:, 0] / sig[:, 0]),
    ("y", err[:, 1] / sig[:, 1]),
    ("z", err[:, 2] / sig[:, 2]),
    ("heading", daz / cat("s_az")),
    ("pitch", dp / cat("s_p")),
]:
    ratio = rms(z)
    check(f"{name} sigma matches the errors", 0.5 <= ratio <= 2.0,
          f"RMS(error/sigma) {ratio:.2f}, max |error/sigma| {np.max(np.abs(z)):.2f}")
# The mean error of the inner epochs (the first and last are extrapolated) with its standard
# error: a bias, e.g. of the height, shows here.
inner = np.concatenate([f["err"][1:-1] for f in flights])
print("mean position error x, y, z (inner epochs): "
      + ", ".join(f"{1e3 * m:+.2f} +- {1e3 * e:.2f} mm"
                  for m, e in zip(inner.mean(0), inner.std(0, ddof=1) / math.sqrt(len(inner)))))
check("roll written as 0 (not determined)", np.all(cat("roll") == 0.0), "0 in every row")
print(f"{passed} passed, {failed} failed")
sys.exit(1 if failed else 0)
