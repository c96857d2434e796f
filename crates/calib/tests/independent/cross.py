#!/usr/bin/env python3
"""An independent generator of the calibration cross, written from its description with
numpy, laspy and pyproj only (none of lidarqa's simulator code).

Four strips in a cross (west->east at 300 m, east->west at 500 m, south->north at 300 m,
north->south at 500 m above flat ground), a sawtooth scanner with 1.36 m between scan lines and
0.13 m between points on a line (at nadir), 20 painted markings picked "by hand" in every strip
(the picker sees each marking where that strip's delivered points put it, plus 1 cm of noise),
6 control points, the site 2.6 deg east of UTM zone 33's central meridian, and an injected
mounting. The georeferencing convention is Zhang et al. (2018) eq. (2) as SPEC fixes it:
P = P0 + R_N (R_M S + lever), S = [0, rho sin(theta), rho cos(theta)], R = Rz(yaw) Ry(pitch) Rx(roll),
NED. Writes strip_1..4.las (LAS 1.2, format 1, GPS week time), sbet.out, sensor.toml, ties.csv,
control.csv and truth.json into the output directory.

    python3 cross.py OUT_DIR [--seed N] [--bad-pick] [--pick-sigma-m 0.01] [--trajectory-errors]
                     [--strip-errors] [--range-noise-m 0.02]

--bad-pick moves tie M01's pick in strip 2 a kilometre away, off every strip's points.
--trajectory-errors gives each strip's navigation (the SBET, and the points georeferenced with it)
a constant error drawn at the sensor file's [sigma] (GNSS north, east, up; roll, pitch, heading):
the data then hold every error the σ of the calibration models, so error/σ can be checked both
ways. Its draws come from their own generator, so the markings and picks of a seed are the same
with and without it.
--strip-errors gives each strip's navigation per-line errors larger than the sensor file admits:
GNSS offsets of 5 cm per axis (1-sigma), a linear drift of 5 cm per axis (the change from the
middle of the line to its end), attitude offsets of 0.005 deg per axis; the sensor file then
declares 2/2/3 cm and 0.002 deg. truth.json lists each line's error ("lines").
--range-noise-m adds Gaussian noise along each beam to the strips' points, and writes floor/ with
the same points georeferenced without any error (true trajectory and mounting, the same noise):
the overlap height differences there are the noise floor.
"""
import argparse
import json
import math
import os

import laspy
import numpy as np
import pyproj

LAT0, LON0, H0 = 48.0, 17.6, 250.0  # site; UTM 33N's central meridian is 15 deg
SPEED = 60.0  # m/s
LINE_SPACING = 1.36  # m between scan lines
POINT_SPACING = 0.13  # m between points on a line, at nadir
HALF_FOV = math.radians(20.0)
HALF_LENGTH = 135.0  # m of strip each side of the centre
INJECTED = {  # true mounting = nominal (zero) + these
    "lever_x_m": 0.12, "lever_y_m": -0.05, "lever_z_m": 0.07,
    "boresight_roll_deg": 0.05, "boresight_pitch_deg": -0.04, "boresight_yaw_deg": 0.06,
}
# (id, heading deg, height m, constant roll and pitch deg)
STRIPS = [(1, 90.0, 300.0, 0.3, 0.8), (2, 270.0, 500.0, -0.2, 1.1),
          (3, 0.0, 300.0, 0.4, 0.6), (4, 180.0, 500.0, -0.3, 0.9)]
GPS_T0 = 302400.0
# The sensor file's navigation 1-sigma: GNSS north, east, up (m); roll, pitch, heading (deg).
NAV_SIGMA_M = [0.003, 0.003, 0.005]
NAV_SIGMA_DEG = [0.0005, 0.0005, 0.001]
# --strip-errors: the true per-line errors (1-sigma) and what the sensor file declares instead.
STRIP_POS_M, STRIP_DRIFT_M, STRIP_ATT_DEG = 0.05, 0.05, 0.005
DECLARED_M = [0.02, 0.02, 0.03]
DECLARED_DEG = [0.002, 0.002, 0.002]


def rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def ry(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def rzyx(roll, pitch, yaw):
    return rz(yaw) @ ry(pitch) @ rx(roll)


def ecef_to_ned_matrix(lat, lon):
    """Rows: north, east, down unit vectors in ECEF."""
    sl, cl, so, co = math.sin(lat), math.cos(lat), math.sin(lon), math.cos(lon)
    return np.array([[-sl * co, -sl * so, cl], [-so, co, 0.0], [-cl * co, -cl * so, -sl]])


GEOD_TO_ECEF = pyproj.Transformer.from_crs("EPSG:4979", "EPSG:4978", always_xy=True)
ECEF_TO_GEOD = pyproj.Transformer.from_crs("EPSG:4978", "EPSG:4979", always_xy=True)
UTM = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:32633", always_xy=True)
ORIGIN = np.array(GEOD_TO_ECEF.transform(LON0, LAT0, H0))
C0 = ecef_to_ned_matrix(math.radians(LAT0), math.radians(LON0))  # ECEF -> NED0


def ned0_to_geodetic(p):
    """NED0 (n x 3) -> lon deg, lat deg, ellipsoidal height m."""
    e = ORIGIN + np.atleast_2d(p) @ C0
    return ECEF_TO_GEOD.transform(e[:, 0], e[:, 1], e[:, 2])


def ned0_to_utm(p):
    lon, lat, h = ned0_to_geodetic(p)
    x, y = UTM.transform(lon, lat)
    return np.asarray(x), np.asarray(y), np.asarray(h)


def mounting(values):
    d = math.radians
    return (rzyx(d(values["boresight_roll_deg"]), d(values["boresight_pitch_deg"]),
                 d(values["boresight_yaw_deg"])),
            np.array([values["lever_x_m"], values["lever_y_m"], values["lever_z_m"]]))


class Strip:
    def __init__(self, sid, heading_deg, height, roll_deg, pitch_deg, index, nav_error=None,
                 drift=None):
        self.id = sid
        self.height = height
        psi = math.radians(heading_deg)
        self.dir = np.array([math.cos(psi), math.sin(psi), 0.0])
        self.start = -HALF_LENGTH * self.dir + np.array([0.0, 0.0, -height])
        self.r_n = rzyx(math.radians(roll_deg), math.radians(pitch_deg), psi)
        # The navigation solution: the true trajectory plus a constant error (NED m, rad).
        e = np.zeros(6) if nav_error is None else np.asarray(nav_error)
        self.nav_offset = e[:3]
        self.attitude_error = e[3:]
        self.r_n_nav = rzyx(math.radians(roll_deg) + e[3], math.radians(pitch_deg) + e[4],
                            psi + e[5])
        self.t0 = GPS_T0 + 100.0 * index
        self.duration = 2 * HALF_LENGTH / SPEED
        self.line_rate = SPEED / LINE_SPACING
        # Linear drift of the position error: +drift at the end, -drift at the start (NED m).
        self.drift = np.zeros(3) if drift is None else np.asarray(drift)
        self.per_line = int(round(2 * HALF_FOV / (POINT_SPACING / height)))

    def position(self, t):
        return self.start + np.outer(t - self.t0, SPEED * self.dir)

    def nav_position(self, t):
        tau = (np.asarray(t) - (self.t0 + 0.5 * self.duration)) / (0.5 * self.duration)
        return self.position(t) + self.nav_offset + np.outer(np.atleast_1d(tau), self.drift)

    def pulses(self):
        n = int(self.duration * self.line_rate) * self.per_line
        k = np.arange(n)
        line, j = np.divmod(k, self.per_line)
        # Sawtooth: each line sweeps left to right, the time running on with every pulse.
        t = self.t0 + (line + j / self.per_line) / self.line_rate
        theta = -HALF_FOV + 2 * HALF_FOV * j / self.per_line
        return t, theta


def hit_ground(strip, t, theta, r_m, lever):
    """True ground points (NED0, down = 0) and ranges of pulses with the true mounting."""
    s = np.stack([np.zeros_like(theta), np.sin(theta), np.cos(theta)], axis=1)
    d = s @ (strip.r_n @ r_m).T
    o = strip.position(t) + strip.r_n @ lever
    rho = -o[:, 2] / d[:, 2]
    return o + rho[:, None] * d, rho


def true_points(strip, t, theta, rho, r_m, lever):
    """The points georeferenced with the true trajectory and mounting (no navigation error)."""
    s = np.stack([np.zeros_like(theta), rho * np.sin(theta), rho * np.cos(theta)], axis=1)
    return strip.position(t) + (s @ r_m.T + lever) @ strip.r_n.T


def delivered(strip, t, theta, rho, r_m, lever):
    """The points as delivered: georeferenced with the navigation solution (the SBET)."""
    s = np.stack([np.zeros_like(theta), rho * np.sin(theta), rho * np.cos(theta)], axis=1)
    return strip.nav_position(t) + (s @ r_m.T + lever) @ strip.r_n_nav.T


def apparent(strip, target, true_m, nominal_m):
    """Where strip puts the ground point `target` (NED0): solve for the pulse (t, theta) that hits
    it with the true mounting, then georeference that pulse with the nominal one."""
    along = float((target - strip.start) @ strip.dir) / SPEED + strip.t0
    off = float(target @ np.array([-strip.dir[1], strip.dir[0], 0.0]))
    x = np.array([along, math.atan2(off, strip.height)])
    for _ in range(30):
        g = hit_ground(strip, x[:1], x[1:], *true_m)[0][0, :2] - target[:2]
        jac = np.zeros((2, 2))
        for c, h in enumerate([1e-4, 1e-7]):
            xp, xm = x.copy(), x.copy()
            xp[c] += h
            xm[c] -= h
            gp = hit_ground(strip, xp[:1], xp[1:], *true_m)[0][0, :2]
            gm = hit_ground(strip, xm[:1], xm[1:], *true_m)[0][0, :2]
            jac[:, c] = (gp - gm) / (2 * h)
        step = np.linalg.solve(jac, g)
        x -= step
        if np.all(np.abs(step) < [1e-10, 1e-13]):
            break
    rho = hit_ground(strip, x[:1], x[1:], *true_m)[1]
    return delivered(strip, x[:1], x[1:], rho, *nominal_m)[0]


def write_sbet(path, strips):
    recs = []
    for s in strips:
        t = np.arange(s.t0 - 2.0, s.t0 + s.duration + 2.0, 0.005)
        p = s.nav_position(t)
        lon, lat, h = ned0_to_geodetic(p)
        for k in range(len(t)):
            la, lo = math.radians(lat[k]), math.radians(lon[k])
            # Attitude relative to the local NED at the aircraft: R = C_ned<-ecef C_ecef<-ned0 R_N0.
            r = ecef_to_ned_matrix(la, lo) @ C0.T @ s.r_n_nav
            roll = math.atan2(r[2, 1], r[2, 2])
            pitch = math.asin(-r[2, 0])
            yaw = math.atan2(r[1, 0], r[0, 0])
            v = SPEED * (ecef_to_ned_matrix(la, lo) @ C0.T @ s.dir)
            recs.append([t[k], la, lo, h[k], v[0], v[1], -v[2], roll, pitch, yaw]
                        + [0.0] * 7)
    np.asarray(recs, dtype="<f8").tofile(path)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--bad-pick", action="store_true")
    ap.add_argument("--pick-sigma-m", type=float, default=0.01,
                    help="pick noise (and the control heights' noise), 1-sigma; 0: noise-free")
    ap.add_argument("--trajectory-errors", action="store_true",
                    help="a constant navigation error per strip at the sensor file's [sigma]")
    ap.add_argument("--strip-errors", action="store_true",
                    help="per-line GNSS offsets and drifts of 5 cm, attitude offsets of 0.005 deg, "
                         "the sensor file declaring 2/2/3 cm and 0.002 deg")
    ap.add_argument("--range-noise-m", type=float, default=0.0,
                    help="noise along each beam, 1-sigma; writes floor/ (no errors, same noise)")
    a = ap.parse_args()
    rng = np.random.default_rng(a.seed)
    os.makedirs(a.out, exist_ok=True)
    true_m = mounting(INJECTED)
    nominal_m = mounting({k: 0.0 for k in INJECTED})
    nav_rng = np.random.default_rng([a.seed, 7])
    nav_sigma = np.array(NAV_SIGMA_M + [math.radians(v) for v in NAV_SIGMA_DEG])
    strip_rng = np.random.default_rng([a.seed, 11])
    strips = []
    for i, s in enumerate(STRIPS):
        nav_error, drift = (nav_rng.normal(0.0, nav_sigma) if a.trajectory_errors else None), None
        if a.strip_errors:
            nav_error = np.concatenate([strip_rng.normal(0.0, STRIP_POS_M, 3),
                                        strip_rng.normal(0.0, math.radians(STRIP_ATT_DEG), 3)])
            drift = strip_rng.normal(0.0, STRIP_DRIFT_M, 3)
        strips.append(Strip(*s, index=i, nav_error=nav_error, drift=drift))
    noise_rng = np.random.default_rng([a.seed, 13])
    # 20 markings (0.5 m x 1.5 m painted bars, picked at their centre) in the cross's centre,
    # where all four strips overlap; 6 control points on the open ground between them.
    marks = np.column_stack([rng.uniform(-98, 98, 20), rng.uniform(-98, 98, 20), np.zeros(20)])
    control = np.column_stack([rng.uniform(-80, 80, 6), rng.uniform(-80, 80, 6), np.zeros(6)])
    for s in strips:
        t, theta = s.pulses()
        g, rho = hit_ground(s, t, theta, *true_m)
        keep = (np.abs(g[:, 0]) < 140) & (np.abs(g[:, 1]) < 140)
        t, theta, g, rho = t[keep], theta[keep], g[keep], rho[keep]
        bright = np.zeros(len(t), bool)
        for m in marks:
            bright |= (np.abs(g[:, 0] - m[0]) < 0.25) & (np.abs(g[:, 1] - m[1]) < 0.75)
        if a.range_noise_m > 0:
            rho = rho + noise_rng.normal(0.0, a.range_noise_m, len(rho))
        outputs = [(a.out, delivered(s, t, theta, rho, *nominal_m))]
        if a.range_noise_m > 0:
            outputs.append((os.path.join(a.out, "floor"), true_points(s, t, theta, rho, *true_m)))
        for folder, q in outputs:
            os.makedirs(folder, exist_ok=True)
            x, y, h = ned0_to_utm(q)
            hdr = laspy.LasHeader(point_format=1, version="1.2")
            hdr.scales = np.array([0.001, 0.001, 0.001])
            hdr.offsets = np.array([np.floor(x.min()), np.floor(y.min()), 0.0])
            las = laspy.LasData(hdr)
            las.x, las.y, las.z = x, y, h
            las.gps_time = t
            las.intensity = np.where(bright, 220, 40).astype(np.uint16)
            las.point_source_id = np.full(len(t), s.id, np.uint16)
            las.scan_angle_rank = np.round(np.degrees(theta)).astype(np.int8)
            las.write(os.path.join(folder, f"strip_{s.id}.las"))
    write_sbet(os.path.join(a.out, "sbet.out"), strips)
    with open(os.path.join(a.out, "ties.csv"), "w") as f:
        f.write("tie,strip,x,y\n")
        for i, m in enumerate(marks):
            for s in strips:
                p = apparent(s, m, true_m, nominal_m) + np.append(rng.normal(0, a.pick_sigma_m, 2), 0.0)
                x, y, _ = ned0_to_utm(p)
                if a.bad_pick and i == 0 and s.id == 2:
                    x, y = x + 1000.0, y + 1000.0
                f.write(f"M{i + 1:02},{s.id},{float(x[0]):.4f},{float(y[0]):.4f}\n")
    with open(os.path.join(a.out, "control.csv"), "w") as f:
        f.write("id,x,y,z,sigma_h,sigma_v\n")
        for i, c in enumerate(control):
            x, y, h = ned0_to_utm(c)
            z = float(h[0]) + rng.normal(0, a.pick_sigma_m)
            f.write(f"C{i + 1},{float(x[0]):.4f},{float(y[0]):.4f},{z:.4f},0.005,0.01\n")
    sig_m, sig_deg = (DECLARED_M, DECLARED_DEG) if a.strip_errors else (NAV_SIGMA_M, NAV_SIGMA_DEG)
    with open(os.path.join(a.out, "sensor.toml"), "w") as f:
        f.write(f"""[scanner]
type = "linear"

[mounting]
boresight_roll_deg = 0.0
boresight_pitch_deg = 0.0
boresight_yaw_deg = 0.0
lever_arm_m = [0.0, 0.0, 0.0]

[sigma]
range_m = 0.01
scan_angle_deg = 0.001
roll_deg = {sig_deg[0]}
pitch_deg = {sig_deg[1]}
heading_deg = {sig_deg[2]}
gnss_north_m = {sig_m[0]}
gnss_east_m = {sig_m[1]}
gnss_up_m = {sig_m[2]}

[mounting_sigma]
lever_x_m = 0.2
lever_y_m = 0.2
lever_z_m = 0.2
boresight_roll_deg = 0.2
boresight_pitch_deg = 0.2
boresight_yaw_deg = 0.2
""")
    with open(os.path.join(a.out, "truth.json"), "w") as f:
        lines = [{
            "strip": s.id, "start_time_s": s.t0, "end_time_s": s.t0 + s.duration,
            # NED -> north, east, up; the drift as the change from the middle to the end.
            "offset_m": {"north": s.nav_offset[0], "east": s.nav_offset[1], "up": -s.nav_offset[2]},
            "drift_m": {"north": s.drift[0], "east": s.drift[1], "up": -s.drift[2]},
            "attitude_deg": dict(zip(["roll", "pitch", "heading"],
                                     [math.degrees(v) for v in
                                      (np.zeros(3) if not (a.strip_errors or a.trajectory_errors)
                                       else s.attitude_error)])),
        } for s in strips]
        json.dump({"mounting": INJECTED, "lines": lines}, f, indent=1)


if __name__ == "__main__":
    main()
