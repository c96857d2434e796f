#!/usr/bin/env python3
"""lidarqa's judged neighbourhood normals against the file's own (PDAL filters.normal), on
NCALM's Titan sample. Usage:

    python3 titan_normals.py TITAN.laz WORK_DIR JUDGE_BIN

writes WORK_DIR/xyz.csv (the points, UTM metres) and WORK_DIR/nonormals.las (a laspy copy
without NormalX/Y/Z, for `lidarqa tpu` without the file's normals), runs JUDGE_BIN (the
`judge_surfaces` example of lidarqa-tpu) on the points with 10 neighbours, and prints the
fraction planar (at k, and after widening) and the angle between each judged normal and the
file's: median and p95 over the planar points.
"""

import subprocess
import sys
from pathlib import Path

import laspy
import numpy as np


def main(laz, work, judge):
    work = Path(work)
    work.mkdir(parents=True, exist_ok=True)
    las = laspy.read(laz)
    xyz = np.column_stack([las.x, las.y, las.z])
    file_n = np.column_stack([las["NormalX"], las["NormalY"], las["NormalZ"]]).astype(float)
    np.savetxt(work / "xyz.csv", xyz, delimiter=",", fmt="%.4f")
    # The same points without the extra bytes.
    header = laspy.LasHeader(point_format=las.header.point_format.id, version="1.4")
    header.offsets, header.scales = las.header.offsets, las.header.scales
    for vlr in las.header.vlrs:
        if vlr.record_id != 4:  # the extra-bytes VLR goes with the dimensions
            header.vlrs.append(vlr)
    out = laspy.LasData(header)
    for name in las.point_format.standard_dimension_names:
        out[name] = las[name]
    out.write(work / "nonormals.las")
    subprocess.run([judge, work / "xyz.csv", work / "judged.csv", "10"], check=True)
    kinds, normals = [], []
    for line in open(work / "judged.csv"):
        k, nx, ny, nz = line.strip().split(",")
        kinds.append(k)
        normals.append([float(nx), float(ny), float(nz)])
    kinds, normals = np.array(kinds), np.array(normals)
    n = len(kinds)
    fn = file_n / np.linalg.norm(file_n, axis=1)[:, None]
    cos = np.abs(np.sum(fn * normals, axis=1)).clip(0, 1)
    angle = np.degrees(np.arccos(cos))
    for label, sel in [
        ("planar at k", kinds == "planar"),
        ("planar only widened", kinds == "planar_widened"),
        ("planar in all", (kinds == "planar") | (kinds == "planar_widened")),
    ]:
        a = angle[sel]
        print(
            f"{label}: {sel.sum()} of {n} ({100 * sel.mean():.1f} %), angle to the file's "
            f"normal median {np.median(a):.2f}°, p95 {np.percentile(a, 95):.2f}°"
        )
    for k in ["linear", "scattered", "too_few"]:
        print(f"{k}: {(kinds == k).sum()} ({100 * (kinds == k).mean():.1f} %)")


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    main(*sys.argv[1:])
