#!/usr/bin/env python3
"""Cross-check lidarqa's LAS/LAZ output with laspy + lazrs, an independent reader.

Usage:  python3 laspy_check.py EXPECTATIONS.json

The JSON file is written by the Rust test `tests/laspy.rs` (set LIDARQA_PYTHON=python3 to make
that test run this script, and LIDARQA_LASPY_DIR=DIR to keep the files). Its layout:

    {"files": [{"path": "...", "version": "1.4", "point_format": 6, "compressed": true,
                "epsg": 32633,
                "x": [...], "y": [...], "z": [...], "gps_time": [...],
                "extra": {"sigma_north": [...], ...}}],
     "xyz_tolerance_m": 1e-6, "gps_time_tolerance_s": 1e-9}

Extra-bytes values are compared exactly: they are f32 in the file and in the JSON
(as the f64 nearest to each f32), or the type an optional `"extra_dtypes": {"name": "float64"}`
names. Exits non-zero on the first mismatch; prints one line per
check and a closing "N passed, 0 failed" line.

Requires: pip install laspy lazrs numpy
"""
import json
import re
import sys

import laspy
import numpy as np


def main(path):
    with open(path) as f:
        spec = json.load(f)
    tol_xyz = spec["xyz_tolerance_m"]
    tol_t = spec["gps_time_tolerance_s"]
    passed = 0
    for entry in spec["files"]:
        name = entry["path"]
        las = laspy.read(name)
        hdr = las.header
        def ok(cond, what):
            nonlocal passed
            if not cond:
                print(f"FAIL {name}: {what}")
                sys.exit(1)
            passed += 1
            print(f"ok   {name}: {what}")

        ok(f"{hdr.version.major}.{hdr.version.minor}" == entry["version"],
           f"version {hdr.version} == {entry['version']}")
        ok(hdr.point_format.id == entry["point_format"],
           f"point format {hdr.point_format.id} == {entry['point_format']}")
        ok(hdr.are_points_compressed == entry["compressed"],
           f"compressed == {entry['compressed']}")
        n = len(entry["x"])
        ok(len(las.points) == n, f"{len(las.points)} points == {n}")
        for axis in ("x", "y", "z"):
            got = np.asarray(getattr(las, axis), dtype=np.float64)
            want = np.asarray(entry[axis], dtype=np.float64)
            err = float(np.max(np.abs(got - want)))
            ok(err <= tol_xyz, f"{axis} max error {err:.3g} m <= {tol_xyz}")
        got = np.asarray(las.gps_time, dtype=np.float64)
        want = np.asarray(entry["gps_time"], dtype=np.float64)
        err = float(np.max(np.abs(got - want)))
        ok(err <= tol_t, f"gps_time max error {err:.3g} s <= {tol_t}")
        ok(bool(hdr.global_encoding.gps_time_type == laspy.header.GpsTimeType.STANDARD),
           "adjusted standard GPS time bit set")
        extra_names = list(las.point_format.extra_dimension_names)
        ok(extra_names == list(entry["extra"].keys()),
           f"extra dimensions {extra_names}")
        for dim, values in entry["extra"].items():
            dtype = las.point_format.dimension_by_name(dim).dtype
            want_dtype = np.dtype(entry.get("extra_dtypes", {}).get(dim, "float32"))
            ok(dtype == want_dtype, f"{dim} is {want_dtype} ({dtype})")
            got = np.asarray(las[dim], dtype=np.float64)
            want = np.asarray(values, dtype=want_dtype).astype(np.float64)
            ok(np.array_equal(got, want), f"{dim} values equal")
        if "epsg" in entry:
            # laspy parses the WKT VLR into WktCoordinateSystemVlr (text in `.string`).
            wkt = " ".join(
                v.string if hasattr(v, "string")
                else bytes(v.record_data).decode("ascii", "replace")
                for v in hdr.vlrs
                if v.user_id == "LASF_Projection" and v.record_id == 2112
            )
            codes = re.findall(r'AUTHORITY\["EPSG","(\d+)"\]', wkt)
            ok(codes and int(codes[-1]) == entry["epsg"],
               f"WKT CRS ends with EPSG {entry['epsg']} ({codes[-1:] or 'none'})")
    print(f"{passed} passed, 0 failed")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
