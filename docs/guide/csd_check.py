"""Independent check of `lidarqa tpu FILE.csd`: decode the Optech CSD records with numpy,
georeference every return rigorously with pyproj (WGS 84 geodetic -> ECEF -> UTM) and compare
with lidarqa's LAS/LAZ; then compare with PDAL's published value for return 0 (its unit test)
both as PDAL computes it (local level vector added in curvilinear coordinates at the sensor) and
rigorously.

usage: python3 csd_check.py SAMPLE.csd LIDARQA_OUTPUT.laz EPSG
Prints one JSON object; exit 1 when lidarqa and the rigorous computation differ by > 1 mm or
PDAL's own step does not give PDAL's value back to 1 mm.
"""
import json
import struct
import sys

import laspy
import numpy as np
from pyproj import Transformer

# PDAL's OptechReaderTest.cpp (PDAL/PDAL @ ccf0ab7): return 0, degrees and metres.
PDAL_0 = (-82.554028877408555, 36.534611447321907, 344.80889224602356)

csd, laz, epsg = sys.argv[1], sys.argv[2], int(sys.argv[3])
b = open(csd, "rb").read()
hsize = struct.unpack_from("<H", b, 104)[0]
nrec = struct.unpack_from("<I", b, 124)[0]
off = 4 + 64 + 32 + 4 + 2 + 2 + 8 + 8 + 4 + 2 + 1024
mis = np.array(struct.unpack_from("<3d", b, off))
imu = np.array(struct.unpack_from("<3d", b, off + 24))
dt = np.dtype([("t", "<f8"), ("n", "u1"), ("rng", "<f4", 4), ("inten", "<u2", 4),
               ("scan", "<f4"), ("roll", "<f4"), ("pitch", "<f4"), ("head", "<f4"),
               ("lat", "<f8"), ("lon", "<f8"), ("elev", "<f4")])
rec = np.frombuffer(b, dt, offset=hsize, count=nrec)


def rot(roll, pitch, yaw):
    """Rz(yaw) Ry(pitch) Rx(roll), body (forward, right, down) -> north, east, down."""
    c, s = np.cos, np.sin
    rx = np.array([[1, 0, 0], [0, c(roll), -s(roll)], [0, s(roll), c(roll)]])
    ry = np.array([[c(pitch), 0, s(pitch)], [0, 1, 0], [-s(pitch), 0, c(pitch)]])
    rz = np.array([[c(yaw), -s(yaw), 0], [s(yaw), c(yaw), 0], [0, 0, 1]])
    return rz @ ry @ rx


rm = rot(*(mis + imu))
to_ecef = Transformer.from_crs("EPSG:4979", "EPSG:4978", always_xy=True)
to_grid = Transformer.from_crs("EPSG:4979", f"EPSG:{epsg}", always_xy=True)
rows = []
for r in rec:
    lat = float(r["lat"])
    lon = float(r["lon"])
    lon -= 2 * np.pi * round(lon / (2 * np.pi))
    for k in range(min(int(r["n"]), 4)):
        rho, th = float(r["rng"][k]), float(r["scan"])
        s = np.array([0.0, rho * np.sin(th), rho * np.cos(th)])
        ned = rot(float(r["roll"]), float(r["pitch"]), float(r["head"])) @ rm @ s
        rows.append((lat, lon, float(r["elev"]), *ned))
rows = np.array(rows)
lat, lon, h, n, e, d = rows.T
x0, y0, z0 = to_ecef.transform(np.degrees(lon), np.degrees(lat), h)
sl, cl, sp, cp = np.sin(lon), np.cos(lon), np.sin(lat), np.cos(lat)
x = x0 - sp * cl * n - sl * e - cp * cl * d
y = y0 - sp * sl * n + cl * e - cp * sl * d
z = z0 + cp * n - sp * d
plon, plat, ph = to_ecef.transform(x, y, z, direction="INVERSE")
ge, gn, gh = to_grid.transform(plon, plat, ph)

las = laspy.read(laz)
dx = np.asarray(las.x) - ge
dy = np.asarray(las.y) - gn
dz = np.asarray(las.z) - gh
out = {"returns": len(rows), "lidarqa_points": len(las.points),
       "max_abs_diff_m": [float(np.abs(v).max()) for v in (dx, dy, dz)]}

# PDAL's step for return 0: the local level vector added in curvilinear coordinates with the
# radii of curvature at the sensor (no earth curvature).
a, f = 6378137.0, 1 / 298.257223563
e2 = 2 * f - f * f
w = np.sqrt(1 - e2 * np.sin(lat[0]) ** 2)
big_n, big_m = a / w, a * (1 - e2) / w**3
pdal_like = (np.degrees(lon[0] + e[0] / (big_n * np.cos(lat[0]))),
             np.degrees(lat[0] + n[0] / big_m), h[0] - d[0])
to_m = (np.radians(1) * big_n * np.cos(lat[0]), np.radians(1) * big_m, 1.0)
out["pdal_step_minus_pdal_m"] = [float((pdal_like[i] - PDAL_0[i]) * to_m[i]) for i in range(3)]
out["rigorous_minus_pdal_enu_m"] = [float((v - PDAL_0[i]) * to_m[i]) for i, v in
                                    enumerate((plon[0], plat[0], ph[0]))]
pe, pn, _ = to_grid.transform(*PDAL_0)
out["lidarqa_minus_pdal_grid_m"] = [float(las.x[0] - pe), float(las.y[0] - pn),
                                    float(las.z[0] - PDAL_0[2])]
print(json.dumps(out, indent=1))
ok = max(out["max_abs_diff_m"]) <= 0.001 and max(map(abs, out["pdal_step_minus_pdal_m"])) <= 0.001
sys.exit(0 if ok else 1)
