#!/usr/bin/env python3
"""An independent witness for `lidarqa trajectory` (issue #24): multi-return pulses written from
the issue's description alone, with numpy + laspy, not with lidarqa's simulator.

A scanner flies a straight line at 300 m, 55 m/s, on a grid bearing of 30 degrees, nose up 1.5
degrees, rolling 2 degrees (which the method cannot see). A sine scan of +-25 degrees at 35 Hz fires
40 kHz; 40 % of the pulses hit a crown 8-25 m above a flat ground and give two returns (first on
the crown, last on the ground, same GPS time, LAS return numbers set). Coordinates are stored at
1 mm; every return gets 2 cm of range noise along its beam and 1 cm of isotropic noise. Then it writes a LAS 1.4 file, runs
`lidarqa trajectory`, and checks the written trajectory against the flight it made:
position RMS, heading and pitch, and that the reported sigma cover the errors.

Usage:  python3 trajectory_generator.py LIDARQA_BINARY WORKDIR
Prints one line per check and a closing "N passed, 0 failed"; exits non-zero on a failure.
Requires: pip install laspy lazrs numpy
"""
import csv
import math
import subprocess
import sys

import laspy
import numpy as np

lidarqa, work = sys.argv[1], sys.argv[2]
rng = np.random.default_rng(24)

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


def sensor(t):
    return START + np.outer(t - T0, fwd * SPEED)


t = T0 + np.arange(int(DURATION * RATE)) / RATE
theta = math.radians(25.0) * np.sin(2 * math.pi * 35.0 * (t - T0)) + ROLL
# Body axes: x forward pitched up, y right, z down; the beam is cos(theta) z + sin(theta) y.
bx = math.cos(PITCH) * fwd + math.sin(PITCH) * up
bz = math.sin(PITCH) * fwd - math.cos(PITCH) * up
beam = np.outer(np.cos(theta), bz) + np.outer(np.sin(theta), right)
s = sensor(t)
rng_ground = (s[:, 2] - 100.0) / -beam[:, 2]
multi = rng.random(len(t)) < 0.4
crown = rng.uniform(8.0, 25.0, len(t))
rng_crown = (s[:, 2] - 100.0 - crown) / -beam[:, 2]

pts, times, rn, nr = [], [], [], []
noise = lambda n: rng.normal(0.0, 0.02, n)
# Range noise along the beam, and 1 cm of isotropic coordinate noise on every return (which
# tilts the first-last lines: the fit's sigma must cover what that does).
iso = lambda: rng.normal(0.0, 0.01, (len(t), 3))
g = s + beam * (rng_ground + noise(len(t)))[:, None] + iso()
c = s + beam * (rng_crown + noise(len(t)))[:, None] + iso()
for i in np.flatnonzero(multi):
    pts.append(c[i]); times.append(t[i]); rn.append(1); nr.append(2)
    pts.append(g[i]); times.append(t[i]); rn.append(2); nr.append(2)
for i in np.flatnonzero(~multi):
    pts.append(g[i]); times.append(t[i]); rn.append(1); nr.append(1)
pts = np.array(pts)
order = np.argsort(np.array(times), kind="stable")

import pyproj  # noqa: E402

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


pts, _, _ = to_delivery(pts)

header = laspy.LasHeader(point_format=6, version="1.4")
header.scales = [0.001, 0.001, 0.001]
header.offsets = [500000.0, 4000000.0, 0.0]
header.add_crs(pyproj.CRS.from_epsg(32633))
las = laspy.LasData(header)
las.x, las.y, las.z = pts[order, 0], pts[order, 1], pts[order, 2]
las.gps_time = np.array(times)[order]
las.return_number = np.array(rn)[order]
las.number_of_returns = np.array(nr)[order]
las.point_source_id = np.full(len(order), 7)
path = f"{work}/generated.las"
las.write(path)

out = f"{work}/generated_trajectory.csv"
run = subprocess.run([lidarqa, "trajectory", path, "-o", out], capture_output=True, text=True)
if run.returncode != 0:
    sys.exit(f"lidarqa trajectory failed: {run.stderr}")

passed = failed = 0


def check(name, ok, detail):
    global passed, failed
    print(("ok   " if ok else "FAIL ") + f"{name}: {detail}")
    if ok:
        passed += 1
    else:
        failed += 1


rows = list(csv.DictReader(open(out)))
tt = np.array([float(r["time"]) for r in rows])
xyz = np.array([[float(r[k]) for k in ("x", "y", "z")] for r in rows])
sig = np.array([[float(r[f"reconstruction_sigma_{k}_m"]) for k in "xyz"] for r in rows])
truth, lon_t, lat_t = to_delivery(sensor(tt))
err = xyz - truth
rms = math.sqrt(np.mean(np.sum(err**2, axis=1)))
check("position RMS", rms <= 0.5, f"{rms:.4f} m over {len(rows)} epochs")
inner = (tt > tt[0] + 0.5) & (tt < tt[-1] - 0.5)
z = err[inner] / sig[inner]
check("position sigma covers the errors", np.all(np.abs(z) < 4.0), f"max |error/sigma| {np.max(np.abs(z)):.2f}")
az = np.array([float(r["azimuth"]) for r in rows])
# The body's forward axis, levelled where the scanner is: true azimuth and pitch there, and
# the grid azimuth = true - convergence (pyproj's meridian convergence, positive east of the
# central meridian, as lidarqa's).
def level_at(lon, lat, v):
    la, lo = np.radians(lat), np.radians(lon)
    east = np.c_[-np.sin(lo), np.cos(lo), np.zeros_like(lo)]
    north = np.c_[-np.sin(la) * np.cos(lo), -np.sin(la) * np.sin(lo), np.cos(la)]
    up = np.c_[np.cos(la) * np.cos(lo), np.cos(la) * np.sin(lo), np.sin(la)]
    w = ENU_TO_ECEF @ v
    return np.sum(east * w, 1), np.sum(north * w, 1), np.sum(up * w, 1)


fe, fn, fu = level_at(lon_t, lat_t, bx)
gamma = np.array(pyproj.Proj(32633).get_factors(lon_t, lat_t).meridian_convergence)
true_pitch = np.degrees(np.arcsin(fu))
daz = (az - (np.degrees(np.arctan2(fe, fn)) - gamma) + 180.0) % 360.0 - 180.0
check("heading (grid azimuth)", np.sqrt(np.mean(daz**2)) <= 0.2, f"RMS {np.sqrt(np.mean(daz**2)):.4f} deg")
dp = np.array([float(r["pitch"]) for r in rows]) - true_pitch
check("pitch", np.sqrt(np.mean(dp**2)) <= 0.2, f"RMS {np.sqrt(np.mean(dp**2)):.4f} deg")
# The reported attitude σ against the actual errors (this flight holds its attitude: the σ
# must then be the noise's, neither claiming nor hiding it).
s_az = np.array([float(r["reconstruction_sigma_azimuth_deg"]) for r in rows])
s_p = np.array([float(r["reconstruction_sigma_pitch_deg"]) for r in rows])
z_az, z_p = np.sqrt(np.mean((daz / s_az) ** 2)), np.sqrt(np.mean((dp / s_p) ** 2))
# Asserted: the heading sigma does not understate the error. Not asserted (README, issue #24):
# on this steady flight it overstates it about 3x (the sub-blocks' noise counted as the
# attitude's wander), and a steady pitch error of about 0.0005 deg is many times its sigma.
check("heading sigma covers the errors", z_az <= 2.0, f"RMS(error/sigma) {z_az:.2f}")
print(f"info pitch: RMS(error/sigma) {z_p:.2f} (RMS error {np.sqrt(np.mean(dp**2)):.5f} deg)")
roll = np.array([float(r["roll"]) for r in rows])
check("roll written as 0 (not determined)", np.all(roll == 0.0), "0 in every row")
print(f"{passed} passed, {failed} failed")
sys.exit(1 if failed else 0)
