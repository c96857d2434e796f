#!/usr/bin/env python3
"""NCALM's published per-point TPU model next to lidarqa's, on the Titan sample (docs/guide/real-data.md).

The model is the one written down in NCALM-UH/pdal-als-tpu @ 0305671, doc/model/model.py and
doc/details.md (re-derived here with numpy and central differences, not copied): the projected
frame (UTM 15N) is the local level frame (NED -> ENU by a change of basis, grid azimuth used as
heading, no convergence); the beam in the scanner frame is Rx(-RL) Ry(FB) [0, 0, rho]; roll,
boresight and lever arm are 0 with their sigma propagated; the observation covariance is the
diagonal of details.md: range sigma^2 + (rho tan(incidence) gamma/4)^2, scan angle RL
sigma^2 + (gamma/4)^2, FB (gamma/4)^2, the incidence from the file's NormalX/Y/Z and capped at 85
degrees, gamma the 1/e^2 beam divergence. Sigma values: test/uncertainty/Titan-C2-1064nm.json.

    python3 docs/real-data/titan_ncalm.py DATA_DIR LIDARQA_OUTPUT.laz

prints both models' sigma_x, sigma_y, sigma_z medians and p95 (cm), and their per-point ratio;
then again with the beam divergence treated as lidarqa does (range only, rho tan(incidence)
gamma/2; no angular term), which isolates the one modelling difference.
"""
import json
import sys
from pathlib import Path

import laspy
import numpy as np


def rx(a):
    c, s, z, o = np.cos(a), np.sin(a), np.zeros_like(a), np.ones_like(a)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], 1)


def ry(a):
    c, s, z, o = np.cos(a), np.sin(a), np.zeros_like(a), np.ones_like(a)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], 1)


def rz(a):
    c, s, z, o = np.cos(a), np.sin(a), np.zeros_like(a), np.ones_like(a)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], 1)


COB = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])  # NED <-> ENU


def ground(o):
    """o: (n, 15) = rho, RL, FB, X, Y, Z, roll, pitch, heading, bR, bP, bY, lx, ly, lz."""
    n = len(o)
    laser = rx(-o[:, 1]) @ ry(o[:, 2]) @ np.tile(np.array([0.0, 0.0, 1.0]), (n, 1))[:, :, None]
    laser = laser[:, :, 0] * o[:, :1]
    bore = rz(o[:, 11]) @ ry(o[:, 10]) @ rx(o[:, 9])
    imu = rz(o[:, 8]) @ ry(o[:, 7]) @ rx(o[:, 6])
    body = np.einsum("nij,nj->ni", bore, laser) + o[:, 12:15]
    return o[:, 3:6] + np.einsum("ij,nj->ni", COB, np.einsum("nij,nj->ni", imu, body))


def main():
    data, ours = Path(sys.argv[1]), Path(sys.argv[2])
    sig = {u["name"]: u["value"] for u in json.loads(
        (data.parent / "uncertainty" / "Titan-C2-1064nm.json").read_text())["uncertainties"]}
    las = laspy.read(data / "112-one-scan-cycle.laz")
    p = np.stack([np.asarray(v, dtype=float) for v in (las.x, las.y, las.z)], 1)
    t = np.asarray(las.gps_time, dtype=float)
    normal = np.stack([np.asarray(las[k], dtype=float) for k in ("NormalX", "NormalY", "NormalZ")], 1)
    tr = np.genfromtxt(data / "112-trajectory.txt", delimiter=",", names=True)
    p0 = np.stack([np.interp(t, tr["GpsTime"], tr[k]) for k in ("X", "Y", "Z")], 1)
    pitch = np.radians(np.interp(t, tr["GpsTime"], tr["Pitch"]))
    heading = np.interp(t, tr["GpsTime"], np.unwrap(np.radians(tr["Azimuth"])))
    d = p - p0
    rho = np.linalg.norm(d, axis=1)
    v = np.einsum("nji,nj->ni", rz(heading) @ ry(pitch), np.einsum("ij,nj->ni", COB, d))
    fb = np.arcsin(v[:, 0] / rho)
    rl = np.arcsin(v[:, 1] / (rho * np.cos(fb)))
    inc = np.minimum(np.arccos(np.clip(np.sum(d / rho[:, None] * -normal, 1), -1, 1)), np.radians(85.0))
    zero = np.zeros_like(rho)
    obs = np.stack([rho, rl, fb, p0[:, 0], p0[:, 1], p0[:, 2], zero, pitch, heading,
                    zero, zero, zero, zero, zero, zero], 1)
    assert np.abs(ground(obs) - p).max() < 1e-6, "the inversion reproduces the points"
    o = laspy.read(ours)
    mine = np.sqrt(np.stack([np.asarray(o[k], dtype=float)
                             for k in ("VarianceX", "VarianceY", "VarianceZ")], 1))
    print(f"{len(rho)} points; incidence from NormalX/Y/Z: median {np.degrees(np.median(inc)):.1f} deg, "
          f"{int((inc >= np.radians(85.0) - 1e-12).sum())} at the 85 deg cap")
    gamma = sig["beam_divergence"] / 1000.0
    for title, on_range, on_angles in (("NCALM's model as published", gamma / 4, gamma / 4),
                                       ("beam divergence as lidarqa (range, gamma/2)", gamma / 2, 0.0)):
        ncalm = model(sig, obs, rho, inc, on_range, on_angles)
        print(f"-- {title}")
        print("cm          NCALM median   p95   lidarqa median   p95   median ratio lidarqa/NCALM")
        for k, name in enumerate(("sigma_x", "sigma_y", "sigma_z")):
            a, b = ncalm[:, k] * 100, mine[:, k] * 100
            print(f"{name:<10} {np.median(a):10.2f} {np.percentile(a, 95):6.2f} {np.median(b):14.2f} "
                  f"{np.percentile(b, 95):6.2f} {np.median(b / a):12.3f}")
    return 0


def model(sig, obs, rho, inc, on_range, on_angles):
    deg = np.radians
    var = np.stack([
        sig["std_lidar_range"] ** 2 + (rho * np.tan(inc) * on_range) ** 2,
        np.full_like(rho, deg(sig["std_scan_angle"]) ** 2 + on_angles ** 2),
        np.full_like(rho, on_angles ** 2),
        *[np.full_like(rho, sig["std_sensor_xy"] ** 2)] * 2,
        np.full_like(rho, sig["std_sensor_z"] ** 2),
        *[np.full_like(rho, deg(sig["std_sensor_rollpitch"]) ** 2)] * 2,
        np.full_like(rho, deg(sig["std_sensor_yaw"]) ** 2),
        *[np.full_like(rho, deg(sig["std_bore_rollpitch"]) ** 2)] * 2,
        np.full_like(rho, deg(sig["std_bore_yaw"]) ** 2),
        *[np.full_like(rho, sig["std_lever_xyz"] ** 2)] * 3,
    ], 1)
    cov = np.zeros((len(rho), 3, 3))
    for k in range(15):
        e = 1e-3 if k in (0, 3, 4, 5, 12, 13, 14) else 1e-7
        hi, lo = obs.copy(), obs.copy()
        hi[:, k] += e
        lo[:, k] -= e
        j = (ground(hi) - ground(lo)) / (2 * e)
        cov += var[:, k, None, None] * np.einsum("ni,nj->nij", j, j)
    return np.sqrt(np.stack([cov[:, 0, 0], cov[:, 1, 1], cov[:, 2, 2]], 1))


if __name__ == "__main__":
    sys.exit(main())
