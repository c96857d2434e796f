#!/usr/bin/env python3
"""Read `lidarqa simulate`'s outputs with independent readers: laspy + lazrs for the strips, a
numpy structured read of the SBET / SMRMSG layout of SPEC §7 for the trajectory, Python's csv and
json for the rest, and check them against truth.json.

Usage:  python3 simulate_check.py DIR
Prints one line per check and a closing "N passed, 0 failed"; exits non-zero on the first failure.
Requires: pip install laspy lazrs numpy
"""
import csv
import json
import math
import os
import sys

import laspy
import numpy as np

GPS_WEEK_S = 604800.0
ADJUSTED_OFFSET_S = 1.0e9


def main(d):
    passed = 0

    def ok(cond, what):
        nonlocal passed
        if not cond:
            print(f"FAIL {what}")
            sys.exit(1)
        passed += 1
        print(f"ok   {what}")

    with open(os.path.join(d, "truth.json")) as f:
        truth = json.load(f)
    week = truth["gps_week"]

    # The trajectory: 17 little-endian f64 per SBET record, 10 per SMRMSG record.
    sbet_path = os.path.join(d, "sbet.out")
    size = os.path.getsize(sbet_path)
    ok(size % 136 == 0 and size > 0, f"sbet.out holds whole 136-byte records ({size} bytes)")
    sbet = np.fromfile(sbet_path, dtype="<f8").reshape(-1, 17)
    t, lat, lon, h = sbet[:, 0], sbet[:, 1], sbet[:, 2], sbet[:, 3]
    ok(bool(np.all(np.diff(t) > 0)), f"sbet.out: {len(t)} records, time strictly increasing")
    ok(bool(np.all(np.abs(lat) < math.pi / 2)) and bool(np.all(np.abs(lon) <= math.pi)),
       "sbet.out: latitude and longitude in radians")
    # The zone's central meridian from the EPSG code (326zz north / 327zz south).
    zone = truth["epsg"] % 100
    lon0 = math.radians(-183.0 + 6.0 * zone)
    ok(bool(np.all(np.abs(lon - lon0) < math.radians(4.0))),
       f"sbet.out: longitudes within the UTM zone {zone} of EPSG:{truth['epsg']}")
    heights = [s["height_m"] for s in truth["strips"]]
    ok(bool(np.all((h > min(heights) - 50.0) & (h < max(heights) + 50.0))),
       f"sbet.out: ellipsoidal heights {h.min():.1f}–{h.max():.1f} m near the flying heights")
    for s in truth["strips"]:
        a, b = s["time_span_s"]
        inside = np.count_nonzero((t >= a - 1e-6) & (t <= b + 1e-6))
        ok(inside > 0, f"sbet.out: strip {s['id']} span {a:.1f}–{b:.1f} s has {inside} records")

    smr_path = os.path.join(d, "smrmsg.out")
    ok(os.path.getsize(smr_path) % 80 == 0, "smrmsg.out holds whole 80-byte records")
    smr = np.fromfile(smr_path, dtype="<f8").reshape(-1, 10)
    ok(len(smr) == len(sbet) and bool(np.all(smr[:, 0] == t)),
       f"smrmsg.out: {len(smr)} records at the SBET's times")
    ok(bool(np.all(smr[:, 1:] >= 0.0)), "smrmsg.out: every sigma >= 0")

    # The strips.
    strips = {s["id"]: s for s in truth["strips"]}
    files = sorted(f for f in os.listdir(d) if f.startswith("strip_") and f[-4:] in (".las", ".laz"))
    ok(len(files) == len(strips), f"{len(files)} strip files for {len(strips)} strips")
    for name in files:
        las = laspy.read(os.path.join(d, name))
        sid = int(name[6:9])
        s = strips[sid]
        hdr = las.header
        ok(hdr.point_count == s["points"], f"{name}: {hdr.point_count} points as truth.json says")
        ok(hdr.point_format.id in (1, 3, 6, 7, 8), f"{name}: point format {hdr.point_format.id} has GPS time")
        wkt = [bytes(v.record_data if hasattr(v, "record_data") else v.string.encode())
               for v in hdr.vlrs if v.record_id == 2112]
        ok(len(wkt) == 1 and f'AUTHORITY["EPSG","{truth["epsg"]}"]]'.encode() in wkt[0].rstrip(b"\0"),
           f"{name}: OGC WKT VLR names EPSG:{truth['epsg']}")
        ok(bool(np.all(np.asarray(las.point_source_id) == sid)), f"{name}: point source ID {sid}")
        # Adjusted standard GPS time → seconds of the truth's GPS week.
        sow = np.asarray(las.gps_time) + ADJUSTED_OFFSET_S - week * GPS_WEEK_S
        a, b = s["time_span_s"]
        ok(bool(np.all((sow >= a - 1e-3) & (sow <= b + 1e-3))),
           f"{name}: GPS times inside the strip's trajectory span")
        classes = set(np.unique(np.asarray(las.classification)).tolist())
        ok(len(classes) > 0 and classes <= {2, 6, 40, 41, 64},
           f"{name}: ASPRS classes {sorted(classes)}")
        ok(int(np.asarray(las.intensity).max()) > 0, f"{name}: intensity present")
        x, y = np.asarray(las.x), np.asarray(las.y)
        ox, oy = truth["origin_m"]
        lo, hi = truth["scene"]["min_m"], truth["scene"]["max_m"]
        ok(bool(np.all((x >= ox + lo[0] - 1) & (x <= ox + hi[0] + 1)
                       & (y >= oy + lo[1] - 1) & (y <= oy + hi[1] + 1))),
           f"{name}: every point inside the scene")
        ok(bool(np.all(np.abs(np.asarray(las.scan_angle) * (0.006 if hdr.point_format.id >= 6 else 1.0)) <= 90.0)),
           f"{name}: scan angles within ±90°")

    with open(os.path.join(d, "control.csv")) as f:
        rows = list(csv.DictReader(f))
    ok(len(rows) == len(truth["targets"]), f"control.csv: {len(rows)} targets")
    by_id = {t["id"]: t for t in truth["targets"]}
    for r in rows:
        t = by_id[r["id"]]
        dx = float(r["x"]) - t["easting_m"]
        dy = float(r["y"]) - t["northing_m"]
        ok(math.hypot(dx, dy) < 0.05, f"control.csv {r['id']}: within 5 cm of the true centre")
    print(f"{passed} passed, 0 failed")


if __name__ == "__main__":
    main(sys.argv[1])
