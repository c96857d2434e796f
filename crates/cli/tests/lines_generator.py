#!/usr/bin/env python3
"""Two files holding four flight lines, for `calibrate` and `correct` reading lines, not files.
numpy + laspy only, on the independent calibration cross of
crates/calib/tests/independent/cross.py (none of lidarqa's code).

    python3 lines_generator.py make OUT_DIR [--seed N] [--thin K]
    python3 lines_generator.py check OUT_DIR CORRECTED_DIR

`make` runs cross.py (four strips, each line's navigation off by its own GNSS offset and drift and
attitude offset, an injected mounting, 2 cm range noise; floor/ holds the same points without any
error) and re-delivers its four strips as two files (every K-th point kept):

- `ab_w.las`, `ab_e.las`: strips 1 and 2 with one point source id, 1: two passes ~95 s apart (a
  GPS-time gap), cut into two tiles west and east of the centre, each holding part of both;
- `cd.las`: strips 3 and 4 with one point source id, 3, strip 4 moved ~94.5 s earlier in time
  (its points and its trajectory records alike), so it starts 1.0 s after strip 3 ends: no time
  gap beyond 5 s, but the sensor jumps 200 m (from 300 m to 500 m above the ground) in that
  second, twice what a platform at 100 m/s could move;
- `sbet.out`: the trajectory with strip 4's records moved alike (strip 3's records end 0.05 s
  after its last point, strip 4's begin 0.05 s before its first: a trajectory pieced together
  from two flights); `floor_ab_w.las`, `floor_ab_e.las`, `floor_cd.las` the same points without
  any error;
- `ties.csv` with the lines named as lidarqa names them (1-1, 1-2, 3-1, 3-2), `control.csv`,
  `sensor.toml`, `truth.json` (each line's true error, under its new name).

`check` prints one JSON object: for each line (the original strip), the RMS 3-D distance of the
delivered and of the corrected points to the floor, and the mean difference (north-ish x,
east-ish y, z) of each, metres.
"""
import json
import os
import subprocess
import sys

import laspy
import numpy as np

GAP_S = 1.0  # strip 4 moved earlier to start this long after strip 3 ends
NAMES = {1: "1-1", 2: "1-2", 3: "3-1", 4: "3-2"}


def read(path, thin):
    las = laspy.read(path)
    keep = np.arange(len(las.points)) % thin == 0
    return las, keep


def merge(paths, shifts, psid, thin, out, tiles=None):
    xs, ys, zs, ts, inten, ang, strip = [], [], [], [], [], [], []
    for k, (p, sh) in enumerate(zip(paths, shifts)):
        las, keep = read(p, thin)
        xs.append(np.asarray(las.x)[keep])
        ys.append(np.asarray(las.y)[keep])
        zs.append(np.asarray(las.z)[keep])
        ts.append(np.asarray(las.gps_time)[keep] - sh)
        inten.append(np.asarray(las.intensity)[keep])
        ang.append(np.asarray(las.scan_angle_rank)[keep])
        strip.append(np.full(keep.sum(), k))
    x, y = np.concatenate(xs), np.concatenate(ys)
    z, t = np.concatenate(zs), np.concatenate(ts)
    inten, ang = np.concatenate(inten), np.concatenate(ang)
    # Tiles: (path, which points), cut at an easting (`west`: the delivered points' side, which
    # the floor's points keep, so that both hold the same points in the same order).
    parts = [(out, np.ones(len(x), bool))]
    if tiles is not None:
        cut, (west_path, east_path), west = tiles
        if west is None:
            west = x < cut
        parts = [(west_path, west), (east_path, ~west)]
    for path, m in parts:
        hdr = laspy.LasHeader(point_format=1, version="1.2")
        hdr.scales = np.array([0.001, 0.001, 0.001])
        hdr.offsets = np.array([np.floor(x.min()), np.floor(y.min()), 0.0])
        las = laspy.LasData(hdr)
        las.x, las.y, las.z = x[m], y[m], z[m]
        las.gps_time = t[m]
        las.intensity = inten[m]
        las.scan_angle_rank = ang[m]
        las.point_source_id = np.full(int(m.sum()), psid, np.uint16)
        las.write(path)
    return parts[0][1]


def make(out, seed, thin):
    here = os.path.dirname(os.path.abspath(__file__))
    cross = os.path.join(here, "..", "..", "calib", "tests", "independent", "cross.py")
    gen = os.path.join(out, "cross")
    subprocess.run([sys.executable, cross, gen, "--seed", str(seed), "--strip-errors",
                    "--range-noise-m", "0.02"], check=True)
    t3 = laspy.read(os.path.join(gen, "strip_3.las")).gps_time
    t4 = laspy.read(os.path.join(gen, "strip_4.las")).gps_time
    end3 = float(np.max(t3))
    shift = float(np.min(t4)) - end3 - GAP_S
    start4 = end3 + GAP_S
    # The tiles' cut: the centre easting of the delivered strips 1 and 2.
    cut = float(np.median(laspy.read(os.path.join(gen, "strip_1.las")).x))
    west = None
    for folder, prefix in [(gen, ""), (os.path.join(gen, "floor"), "floor_")]:
        s = lambda k: os.path.join(folder, f"strip_{k}.las")
        tiles = (cut, [os.path.join(out, f"{prefix}ab_{side}.las") for side in "we"], west)
        west = merge([s(1), s(2)], [0.0, 0.0], 1, thin, None, tiles)
        merge([s(3), s(4)], [0.0, shift], 3, thin, os.path.join(out, f"{prefix}cd.las"))
    # The trajectory: strip 4's records moved alike, strip 3's ending 0.05 s after its last
    # point and strip 4's beginning 0.05 s before its first.
    rec = np.fromfile(os.path.join(gen, "sbet.out"), dtype="<f8").reshape(-1, 17)
    t = rec[:, 0]
    s3 = (t > 302590.0) & (t < 302690.0)
    s4 = t > 302690.0
    rec[s4, 0] -= shift
    keep = ~((s3 & (rec[:, 0] > end3 + 0.05)) | (s4 & (rec[:, 0] < start4 - 0.05)))
    rec = rec[keep]
    assert np.all(np.diff(rec[:, 0]) > 0)
    rec.astype("<f8").tofile(os.path.join(out, "sbet.out"))
    with open(os.path.join(gen, "ties.csv")) as f, open(os.path.join(out, "ties.csv"), "w") as g:
        g.write(f.readline())
        for line in f:
            tie, strip, x, y = line.strip().split(",")
            g.write(f"{tie},{NAMES[int(strip)]},{x},{y}\n")
    for name in ["control.csv", "sensor.toml"]:
        with open(os.path.join(gen, name)) as f, open(os.path.join(out, name), "w") as g:
            g.write(f.read())
    truth = json.load(open(os.path.join(gen, "truth.json")))
    for line in truth["lines"]:
        line["strip"] = NAMES[int(line["strip"])]
    json.dump(truth, open(os.path.join(out, "truth.json"), "w"), indent=1)


def check(out, corrected):
    result = {}
    for names, first in [(["ab_w", "ab_e"], 1), (["cd"], 3)]:
        xyz = lambda l: np.column_stack([l.x, l.y, l.z])
        read = lambda d, p: [laspy.read(os.path.join(d, f"{p}{n}.las")) for n in names]
        f = np.concatenate([xyz(l) for l in read(out, "floor_")])
        before = read(out, "")
        b = np.concatenate([xyz(l) for l in before])
        a = np.concatenate([xyz(l) for l in read(corrected, "")])
        t = np.concatenate([np.asarray(l.gps_time) for l in before])
        # The two lines of the files: split where the time jumps by over 0.5 s (as generated).
        ts = np.sort(t)
        k = int(np.argmax(np.diff(ts) > 0.5))
        second = t > 0.5 * (ts[k] + ts[k + 1])
        for k, part in enumerate([~second, second]):
            d_b, d_a = b[part] - f[part], a[part] - f[part]
            result[NAMES[first + k]] = {
                "points": int(len(d_b)),
                "rms_before_m": float(np.sqrt(np.mean(np.sum(d_b ** 2, axis=1)))),
                "rms_after_m": float(np.sqrt(np.mean(np.sum(d_a ** 2, axis=1)))),
                "mean_before_m": d_b.mean(axis=0).tolist(),
                "mean_after_m": d_a.mean(axis=0).tolist(),
            }
    print(json.dumps(result))


if __name__ == "__main__":
    if sys.argv[1] == "make":
        args = sys.argv[3:]
        seed = int(args[args.index("--seed") + 1]) if "--seed" in args else 3
        thin = int(args[args.index("--thin") + 1]) if "--thin" in args else 3
        make(sys.argv[2], seed, thin)
    else:
        check(sys.argv[2], sys.argv[3])
