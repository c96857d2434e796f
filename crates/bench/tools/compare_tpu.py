"""Compare two `lidarqa tpu` outputs (files or directories of LAZ) point by point.

An optimisation of the TPU kernel must not change the products beyond rounding: this reads both
with laspy (independently of lidarqa's own reader), checks that the coordinates are identical
(to 0.1 mm), and reports the largest relative difference of every extra dimension (the σ,
depth and 95 % columns), failing when one exceeds 1e-6.

    python3 crates/bench/tools/compare_tpu.py BEFORE AFTER
"""

import sys
from pathlib import Path

import laspy
import numpy as np


def files(p: Path):
    return sorted(p.glob("*.la[sz]")) if p.is_dir() else [p]


def main(a: str, b: str) -> int:
    fa, fb = files(Path(a)), files(Path(b))
    if [f.name for f in fa] != [f.name for f in fb]:
        print(f"different files: {[f.name for f in fa]} vs {[f.name for f in fb]}")
        return 1
    worst = 0.0
    for x, y in zip(fa, fb):
        la, lb = laspy.read(x), laspy.read(y)
        if len(la.points) != len(lb.points):
            print(f"{x.name}: {len(la.points)} vs {len(lb.points)} points")
            return 1
        dxyz = max(np.max(np.abs(np.asarray(la[c]) - np.asarray(lb[c]))) for c in "xyz")
        print(f"{x.name}: {len(la.points)} points, largest coordinate difference {dxyz:.3e} m")
        if dxyz > 1e-4:
            return 1
        names = list(la.point_format.extra_dimension_names)
        if names != list(lb.point_format.extra_dimension_names):
            print(f"{x.name}: extra dimensions differ: {names} vs {lb.point_format.extra_dimension_names}")
            return 1
        for n in names:
            u, v = np.asarray(la[n], dtype=float), np.asarray(lb[n], dtype=float)
            both_nan = np.isnan(u) & np.isnan(v)
            scale = np.maximum(np.abs(u), 1e-12)
            rel = np.where(both_nan, 0.0, np.abs(u - v) / scale)
            r = float(np.nanmax(rel)) if rel.size else 0.0
            if np.any(np.isnan(u) != np.isnan(v)):
                r = float("inf")
            worst = max(worst, r)
            print(f"  {n}: largest relative difference {r:.3e}")
    print(f"worst relative difference {worst:.3e} (bar 1e-6)")
    return 0 if worst <= 1e-6 else 1


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:3]))
