#!/usr/bin/env python3
"""Which yaw convention ARMO's per-point pose follows, measured from the points alone.

Written with numpy, laspy and scipy only, apart from lidarqa.

Usage:
    python3 armo_yaw_convention.py Car.adc.laz [Tent.adc.laz ...]

A spinning multi-beam head on its side (the LidarPod's HDL-32E, rotation axis along the body's x)
puts each laser ring (`user_data`) on one cone about that axis: recovered with the right attitude,
every point of a ring has the same elevation from the spin plane, `asin(S_x / |S|)`, with
`S = R_Nᵀ (P − P0) − ΔP` (NED, the lever arm ΔP = 0.161 / 0 / −0.016 m of ARMO's
`*_fullframes.json`). For each candidate reading of `SensorRollRads`, `SensorPitchRads` and
`SensorYawRads` as the body → NED rotation `Rz(heading) Ry(pitch) Rx(roll)` it prints the RMS over
rings of the elevation's standard deviation within a ring: a wrong heading spreads each ring over
degrees, and so does a pitch of the wrong sign. The roll turns the cones about their own axis and
is not seen by this test.
"""

import sys

import laspy
import numpy as np
from scipy.spatial.transform import Rotation

LEVER_M = np.array([0.161, 0.0, -0.016])

CANDIDATES = {
    "heading = yaw (clockwise from grid north)": (1.0, 0.0, 1.0),
    "heading = 90° − yaw (counter-clockwise from east), pitch negated": (-1.0, np.pi / 2, -1.0),
    "heading = −yaw − 90°": (-1.0, -np.pi / 2, 1.0),
    "heading = −yaw − 90°, pitch negated": (-1.0, -np.pi / 2, -1.0),
}


def spread_deg(path, sign, offset, pitch_sign):
    las = laspy.read(path)
    d = np.c_[
        np.asarray(las.x) - np.asarray(las["SensorX"]),
        np.asarray(las.y) - np.asarray(las["SensorY"]),
        np.asarray(las.z) - np.asarray(las["SensorZ"]),
    ]
    ned = np.c_[d[:, 1], d[:, 0], -d[:, 2]]
    roll, pitch, yaw = (
        np.asarray(las[k], dtype=float) for k in ("SensorRollRads", "SensorPitchRads", "SensorYawRads")
    )
    r_n = Rotation.from_euler("ZYX", np.c_[sign * yaw + offset, pitch_sign * pitch, roll]).as_matrix()
    s = np.einsum("nji,nj->ni", r_n, ned) - LEVER_M
    elevation = np.degrees(np.arcsin(s[:, 0] / np.linalg.norm(s, axis=1)))
    ring = np.asarray(las.user_data)
    return float(np.sqrt(np.mean([elevation[ring == k].var() for k in np.unique(ring)])))


def main(paths):
    if not paths:
        raise SystemExit(__doc__)
    for p in paths:
        for name, (sign, offset, pitch_sign) in CANDIDATES.items():
            print(f"{p}: {name}: elevation spread within a ring {spread_deg(p, sign, offset, pitch_sign):.2f}°")


if __name__ == "__main__":
    main(sys.argv[1:])
