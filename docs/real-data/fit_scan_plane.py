"""Fit the scan plane of the leeward sample strip (docs/guide/real-data.md): numpy + pyproj.

Takes every LAS point into the body frame with the SBET pose at its GPS time (linear
interpolation; true heading = platform heading - wander angle, as lidarqa reads SBETs; the
N-frame vector rigorously through ECEF, as lidarqa does), fits a plane through the scanner
origin, and prints the boresight pitch / yaw that make it lidarqa's scan plane (the plane normal
is R_M e_x = [cos y cos p, sin y cos p, -sin p]), the out-of-plane RMS and the ranges, and compares
the LAS scan-angle field with the recovered in-plane angle and with its projection on the body's
Y-Z plane.

    python3 docs/real-data/fit_scan_plane.py data/real/leeward
"""

import math
import struct
import sys

import numpy as np
from pyproj import Transformer

A, F = 6378137.0, 1 / 298.257223563
E2 = F * (2 - F)


def ecef(lat, lon, h):
    n = A / np.sqrt(1 - E2 * np.sin(lat) ** 2)
    return np.stack(
        [(n + h) * np.cos(lat) * np.cos(lon), (n + h) * np.cos(lat) * np.sin(lon),
         (n * (1 - E2) + h) * np.sin(lat)], -1)


def rot(roll, pitch, yaw):
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch),
                              math.cos(yaw), math.sin(yaw))
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def main(d):
    sb = np.frombuffer(open(f"{d}/sbet.out", "rb").read(), dtype="<f8").reshape(-1, 17)
    las = open(f"{d}/points.las", "rb").read()
    offset, = struct.unpack("<I", las[96:100])
    count, = struct.unpack("<I", las[107:111])
    scale = struct.unpack("<3d", las[131:155])
    origin = struct.unpack("<3d", las[155:179])
    fmt = las[104]
    assert fmt == 3, "point format 3 expected"
    dt = np.dtype([("x", "<i4"), ("y", "<i4"), ("z", "<i4"), ("i", "<u2"), ("b", "u1"),
                   ("c", "u1"), ("sa", "i1"), ("u", "u1"), ("ps", "<u2"), ("t", "<f8"),
                   ("rgb", "<u2", 3)])
    p = np.frombuffer(las[offset:offset + count * dt.itemsize], dtype=dt)
    x, y, z = (p[k] * scale[i] + origin[i] for i, k in enumerate("xyz"))
    t, las_angle = p["t"], p["sa"].astype(float)
    lon, lat = Transformer.from_crs(32611, 4326, always_xy=True).transform(x, y)
    pts = ecef(np.radians(lat), np.radians(lon), z)
    at = {k: np.interp(t, sb[:, 0], np.unwrap(sb[:, i]) if i >= 7 else sb[:, i])
          for k, i in [("lat", 1), ("lon", 2), ("h", 3), ("roll", 7), ("pitch", 8)]}
    at["heading"] = np.interp(t, sb[:, 0], np.unwrap(sb[:, 9] - sb[:, 10]))
    p0 = ecef(at["lat"], at["lon"], at["h"])
    body = np.empty_like(pts)
    for k in range(count):
        la, lo = at["lat"][k], at["lon"][k]
        c_ne = np.array([[-math.sin(la) * math.cos(lo), -math.sin(la) * math.sin(lo), math.cos(la)],
                         [-math.sin(lo), math.cos(lo), 0.0],
                         [-math.cos(la) * math.cos(lo), -math.cos(la) * math.sin(lo), -math.sin(la)]])
        r_n = rot(at["roll"][k], at["pitch"][k], at["heading"][k])
        body[k] = r_n.T @ (c_ne @ (pts[k] - p0[k]))
    normal = np.linalg.svd(body, full_matrices=False)[2][2]
    normal *= np.sign(normal[0])
    pitch, yaw = -math.asin(normal[2]), math.atan2(normal[1], normal[0])
    out = body @ normal
    print(f"boresight pitch {math.degrees(pitch):.3f} deg, yaw {math.degrees(yaw):.3f} deg")
    print(f"out of plane: RMS {np.sqrt(np.mean(out ** 2)):.3f} m, max {abs(out).max():.3f} m")
    rng = np.linalg.norm(body, axis=1)
    print(f"range: min {rng.min():.0f} m, median {np.median(rng):.0f} m, max {rng.max():.0f} m")
    s = body @ rot(0.0, pitch, yaw)  # scanner frame with boresight roll 0
    in_plane = np.degrees(np.arctan2(s[:, 1], s[:, 2]))
    projected = np.degrees(np.arctan2(body[:, 1], body[:, 2]))
    for name, v in [("in-plane (lidarqa's check)", in_plane), ("body Y-Z projection", projected)]:
        dv = v - las_angle
        print(f"{name} - LAS field: mean {dv.mean():+.3f} deg, RMS {np.sqrt(np.mean(dv ** 2)):.3f}"
              f" deg, rounds to the field for {np.mean(np.round(v) == las_angle):.0%}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "data/real/leeward")
