#!/usr/bin/env python3
"""THU/TVU at 95 % per depth band: lidarqa's and cBLUE's predictions against the actual errors.

Reads three things for the same strips, point by point in file order:
  * the strips of ``lidarqa simulate --truth`` (extra bytes error_x/y/z = lidar − true, metres);
  * the strips of ``lidarqa tpu`` (total_thu = 1.7308 σ_H, total_tvu = 1.96 σ_V, depth of each
    sounding below its own surface return);
  * cBLUE's ``<strip>_TPU.csv`` (GPS Time, X, Y, Z, THU, TVU, Classification; −1 where cBLUE gave
    no TPU), written with its ``--csv`` option at "95% confidence".
It checks that the three hold the same points (GPS time and coordinates), then prints per depth band
(soundings, class 40, banded by lidarqa's depth) and for the ground (class 2) and water-surface
(class 41) returns: the median predicted THU and TVU of each tool and the actual 95th percentile of
the horizontal error radius √(error_x² + error_y²) and of |error_z|.

With ``--cblue-luts THU.csv TVU.csv RBU.csv --water-height H`` (the look-up tables of the sensor
profile cBLUE ran with, from its lookup_tables/ folder, and the water surface height it was given) it
also splits cBLUE's soundings into its two parts, at 95 %: the subaqueous part it takes from the
tables at its depth H − z (THU a + b·d; TVU √(a² + (b·d)²), at least 0.03 m; range bias a·d³ + b·d² +
c·d + d₀, added to the TVU in quadrature) and the subaerial part that remains of its total.

Usage (numpy, laspy with lazrs):

    python3 docs/cblue/compare.py --truth B/strip_001.laz B/strip_002.laz \
        --lidarqa LQ/strip_001.laz LQ/strip_002.laz \
        --cblue CB/strip_001_TPU.csv CB/strip_002_TPU.csv [--markdown] \
        [--cblue-luts THU.csv TVU.csv RBU.csv --lut-row 0 --water-height H]
"""

import argparse
import csv
import sys

import laspy
import numpy as np

BANDS_M = [(0.0, 5.0), (5.0, 10.0), (10.0, 20.0), (20.0, 50.0)]
SOUNDING, SURFACE, GROUND = 40, 41, 2
COORD_TOL_M = 0.0015  # cBLUE's CSV prints coordinates to the mm
TIME_TOL_S = 1e-6


def fail(msg):
    print(f"compare: {msg}", file=sys.stderr)
    sys.exit(1)


def read_las(path, fields):
    try:
        las = laspy.read(path)
    except Exception as e:  # laspy raises several types for bad files
        fail(f"{path}: not a readable LAS/LAZ file ({e})")
    names = set(las.point_format.dimension_names)
    missing = [f for f in fields if f not in names]
    if missing:
        fail(f"{path}: no {', '.join(missing)} dimension (wrong file for this argument?)")
    return {f: np.asarray(las[f], dtype=float) for f in fields} | {
        "x": np.asarray(las.x),
        "y": np.asarray(las.y),
        "z": np.asarray(las.z),
        "t": np.asarray(las.gps_time),
        "cls": np.asarray(las.classification, dtype=int),
    }


def read_cblue_csv(path):
    cols = {"GPS Time": [], "X": [], "Y": [], "Z": [], "THU": [], "TVU": [], "Classification": []}
    try:
        with open(path, newline="") as f:
            rows = csv.DictReader(f)
            if rows.fieldnames is None or not set(cols) <= set(rows.fieldnames):
                fail(f"{path}: header {rows.fieldnames} lacks {sorted(cols)} (not a cBLUE --csv output?)")
            for line, r in enumerate(rows, start=2):
                try:
                    for k in cols:
                        cols[k].append(float(r[k]))
                except ValueError:
                    fail(f"{path}:{line}: not a number in {r}")
    except OSError as e:
        fail(f"{path}: cannot read ({e.strerror})")
    return {k: np.asarray(v) for k, v in cols.items()}


def same_points(a, b, what):
    n = len(a["t"])
    if len(b["t"]) != n:
        fail(f"{what}: {len(b['t'])} points against the truth's {n} (not the same strip?)")
    for k, tol in (("t", TIME_TOL_S), ("x", COORD_TOL_M), ("y", COORD_TOL_M), ("z", COORD_TOL_M)):
        bad = np.flatnonzero(np.abs(a[k] - b[k]) > tol)
        if bad.size:
            i = bad[0]
            fail(f"{what}: point {i} {k} = {b[k][i]} against the truth's {a[k][i]} (points reordered?)")
    if not np.array_equal(a["cls"], b["cls"]):
        fail(f"{what}: classes differ from the truth's")


def load(args):
    if not (len(args.truth) == len(args.lidarqa) == len(args.cblue)):
        fail("give as many --truth, --lidarqa and --cblue files, strip by strip in the same order")
    parts = []
    for tp, lp, cp in zip(args.truth, args.lidarqa, args.cblue):
        tr = read_las(tp, ["error_x", "error_y", "error_z"])
        lq = read_las(lp, ["total_thu", "total_tvu", "depth"])
        same_points(tr, lq, lp)
        cb = read_cblue_csv(cp)
        cbp = {"t": cb["GPS Time"], "x": cb["X"], "y": cb["Y"], "z": cb["Z"], "cls": cb["Classification"].astype(int)}
        same_points(tr, cbp, cp)
        parts.append(
            {
                "cls": tr["cls"],
                "eh": np.hypot(tr["error_x"], tr["error_y"]),
                "ev": np.abs(tr["error_z"]),
                "lq_thu": lq["total_thu"],
                "lq_tvu": lq["total_tvu"],
                "depth": lq["depth"],
                "cb_thu": cb["THU"],
                "cb_tvu": cb["TVU"],
                "z": tr["z"],
            }
        )
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def row(d, sel, label):
    has_cb = sel & (d["cb_thu"] >= 0)
    if not sel.any():
        return None
    r = {
        "label": label,
        "n": int(sel.sum()),
        "n_cblue": int(has_cb.sum()),
        "lq_thu": float(np.median(d["lq_thu"][sel])),
        "cb_thu": float(np.median(d["cb_thu"][has_cb])) if has_cb.any() else float("nan"),
        "act_thu": float(np.percentile(d["eh"][sel], 95)),
        "lq_tvu": float(np.median(d["lq_tvu"][sel])),
        "cb_tvu": float(np.median(d["cb_tvu"][has_cb])) if has_cb.any() else float("nan"),
        "act_tvu": float(np.percentile(d["ev"][sel], 95)),
    }
    return r


THU95, TVU95 = 1.7308, 1.96  # cBLUE's factors from 1 sigma to 95 % (Tpu.py)


def read_lut(path, row, names):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not 0 <= row < len(rows):
        fail(f"{path}: no row {row} ({len(rows)} rows)")
    try:
        return [float(rows[row][k]) for k in names]
    except (KeyError, ValueError):
        fail(f"{path}: row {row} lacks numeric {', '.join(names)} (not a cBLUE look-up table?)")


def lut_split(d, args):
    thu_a, thu_b = read_lut(args.cblue_luts[0], args.lut_row, ["a", "b"])
    tvu_a, tvu_b = read_lut(args.cblue_luts[1], args.lut_row, ["a", "b"])
    rb = read_lut(args.cblue_luts[2], args.lut_row, ["a", "b", "c", "d"])
    print(
        f"cBLUE look-up row {args.lut_row}: THU {thu_a:g} + {thu_b:g} d; TVU sqrt({tvu_a:g}^2 + ({tvu_b:g} d)^2); "
        f"range bias {rb[0]:g} d^3 + {rb[1]:g} d^2 + {rb[2]:g} d + {rb[3]:g}  (1 sigma, d = {args.water_height:g} - z)"
    )
    print(
        f"{'soundings':<22}{'cBLUE depth':>12} {'THU table':>10} {'THU aerial':>11}   "
        f"{'TVU table':>10} {'range bias':>11} {'TVU aerial':>11}   (medians, m at 95 %)"
    )
    snd = (d["cls"] == SOUNDING) & (d["cb_thu"] >= 0)
    for lo, hi in BANDS_M:
        sel = snd & (d["depth"] >= lo) & (d["depth"] < hi)
        if not sel.any():
            continue
        dep = args.water_height - d["z"][sel]
        thu_t = thu_a + thu_b * dep
        tvu_t = np.maximum(np.hypot(tvu_a, tvu_b * dep), 0.03)
        bias = rb[0] * dep**3 + rb[1] * dep**2 + rb[2] * dep + rb[3]
        thu_air = np.sqrt(np.maximum((d["cb_thu"][sel] / THU95) ** 2 - thu_t**2, 0.0))
        tvu_air = np.sqrt(np.maximum((d["cb_tvu"][sel] / TVU95) ** 2 - tvu_t**2 - bias**2, 0.0))
        print(
            f"{f'{lo:g}–{hi:g} m':<22}{np.median(dep):12.2f} {THU95 * np.median(thu_t):10.3f} "
            f"{THU95 * np.median(thu_air):11.3f}   {TVU95 * np.median(tvu_t):10.3f} "
            f"{TVU95 * np.median(np.abs(bias)):11.3f} {TVU95 * np.median(tvu_air):11.3f}"
        )


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--truth", nargs="+", required=True)
    ap.add_argument("--lidarqa", nargs="+", required=True)
    ap.add_argument("--cblue", nargs="+", required=True)
    ap.add_argument("--markdown", action="store_true", help="print a Markdown table")
    ap.add_argument("--cblue-luts", nargs=3, metavar=("THU", "TVU", "RBU"), help="cBLUE look-up tables")
    ap.add_argument("--lut-row", type=int, default=0, help="row of the tables cBLUE used (6·wind + turbidity)")
    ap.add_argument("--water-height", type=float, help="the water surface height cBLUE was given, m")
    args = ap.parse_args()
    if args.cblue_luts and args.water_height is None:
        fail("--cblue-luts needs --water-height (cBLUE's depth is that height − z)")
    d = load(args)

    rows = []
    snd = d["cls"] == SOUNDING
    for lo, hi in BANDS_M:
        rows.append(row(d, snd & (d["depth"] >= lo) & (d["depth"] < hi), f"soundings {lo:g}–{hi:g} m"))
    rows.append(row(d, d["cls"] == GROUND, "ground (class 2)"))
    rows.append(row(d, d["cls"] == SURFACE, "water surface (class 41)"))
    rows = [r for r in rows if r is not None]
    no_cb = int((d["cb_thu"] < 0).sum())

    if args.markdown:
        print(
            "| returns | points | THU lidarqa | THU cBLUE | THU actual | cBLUE / actual "
            "| TVU lidarqa | TVU cBLUE | TVU actual | cBLUE / actual |"
        )
        print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
        for r in rows:
            print(
                f"| {r['label']} | {r['n']} | {r['lq_thu']:.3f} | {r['cb_thu']:.3f} | {r['act_thu']:.3f} "
                f"| {r['cb_thu'] / r['act_thu']:.2f} | {r['lq_tvu']:.3f} | {r['cb_tvu']:.3f} "
                f"| {r['act_tvu']:.3f} | {r['cb_tvu'] / r['act_tvu']:.2f} |"
            )
    else:
        print(f"{'returns':<26}{'points':>8} {'THU lq':>7} {'cBLUE':>7} {'actual':>7}   {'TVU lq':>7} {'cBLUE':>7} {'actual':>7}")
        for r in rows:
            print(
                f"{r['label']:<26}{r['n']:>8} {r['lq_thu']:7.3f} {r['cb_thu']:7.3f} {r['act_thu']:7.3f}   "
                f"{r['lq_tvu']:7.3f} {r['cb_tvu']:7.3f} {r['act_tvu']:7.3f}"
            )
    print(
        f"(m at 95 %: median predicted per point; actual = 95th percentile of the error; "
        f"{no_cb} points without a cBLUE TPU are left out of its medians)"
    )
    if args.cblue_luts:
        lut_split(d, args)


if __name__ == "__main__":
    main()
