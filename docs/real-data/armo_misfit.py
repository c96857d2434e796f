#!/usr/bin/env python3
"""How far apart the two passes of an ARMO UAV file lie: an independent point-to-plane misfit.

Written with numpy, laspy and scipy only, apart from lidarqa (none of its code or output is used
except the LAZ files given).

Usage:
    python3 armo_misfit.py ORIGINAL.laz [CORRECTED.laz ...] [--json] [--rigid]

For the original and each corrected file it prints the misfit between the two passes and the
floor (the same measure between the alternate frames of one pass). With --json it prints one JSON
object per file instead. A corrected file (`lidarqa correct`'s output) need not keep the extra
bytes (`frameNo`, `SensorX/Y/Z`): its points are matched to the original's by their order, which
`correct` keeps, and the match is checked (same count, same GPS time and intensity point by
point, no point moved by more than 5 m).

Definitions:

- **Lines.** The points are ordered by their frame counter (`frameNo`, a stable sort keeping the
  file order within a frame) and cut where the stored sensor position (`SensorX/Y/Z`) steps by more
  than 5 m between consecutive points. The platform moves well under 1 m between two points of one
  pass, and the two passes of ARMO's Car and Tent are 20 m and 23 m apart where they join, so
  each file gives exactly two lines; any other count is an error.
- **The object.** ARMO's files are already cut to a box around the object (a car, a tent and their
  surroundings, about 5 m × 5 m), and both passes cover the whole box, so the overlap is the file.
  A point counts when the 12 nearest points of the other line (3-D, scipy's cKDTree) all lie
  within 0.5 m of it, so that the box's edges, where one pass sees less, do not count.
- **Misfit.** Each counted point's distance to the least-squares plane (numpy's eigen-decomposition
  of the 12 neighbours' covariance, the normal the smallest eigenvector) of its 12 nearest
  neighbours in the other line. The RMS is taken over the points of both lines, each line measured
  against the other.
- **Floor.** The same measure within one line, between its even and its odd frames (10 Hz
  revolutions of the head): what the noise of the scanner and the roughness of the object leave when
  the mounting cannot matter. Reported per line.
- **Per ring.** The misfit of each line's points per laser ring (`user_data`), in the JSON
  output (`by_ring_m`: two lists of 32, null for a ring with fewer than 50 counted points).
- **Rigid** (`--rigid`, about a minute a file): the smallest misfit any rigid motion of the second
  line onto the first gives (three rotations about its centroid and a shift, Nelder–Mead from
  zero, three restarts, the misfit evaluated on 5 000 sample points of each line while searching):
  what no mounting and no constant trajectory error of one line can beat.
- **Blocks.** The same measure within one line, between the points of its even laser rings
  (`user_data` 0, 2, …, 30: the 16 channels 10°–31° off the spin plane) and its odd rings (the 16
  channels within 11° of it). They fire in the same revolutions from the same pose, so a
  disagreement above the floor is the scanner's own (its channels' angles or ranges), not the
  trajectory's; a boresight moves both alike only where they look alike.
"""

import json
import sys

import laspy
import numpy as np
from scipy.spatial import cKDTree

K = 12
MAX_NEIGHBOUR_M = 0.5
JUMP_M = 5.0


def lines_of(path, coordinates=None, with_rings=False):
    las = laspy.read(path)
    frame = np.asarray(las["frameNo"], dtype=float)
    order = np.argsort(frame, kind="stable")
    xyz = np.c_[np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)]
    if coordinates is not None:
        other = laspy.read(coordinates)
        if len(other.points) != len(las.points):
            raise SystemExit(f"{coordinates}: {len(other.points)} points, {path} has {len(las.points)}")
        same = np.array_equal(np.asarray(other.gps_time), np.asarray(las.gps_time)) and np.array_equal(
            np.asarray(other.intensity), np.asarray(las.intensity)
        )
        moved = np.c_[np.asarray(other.x), np.asarray(other.y), np.asarray(other.z)]
        if not same or np.max(np.linalg.norm(moved - xyz, axis=1)) > 5.0:
            raise SystemExit(f"{coordinates}: its points are not {path}'s in the same order")
        xyz = moved
    xyz = xyz[order]
    sensor = np.c_[
        np.asarray(las["SensorX"]), np.asarray(las["SensorY"]), np.asarray(las["SensorZ"])
    ][order]
    frame = frame[order]
    ring = np.asarray(las.user_data)[order]
    step = np.linalg.norm(np.diff(sensor, axis=0), axis=1)
    cuts = np.flatnonzero(step > JUMP_M) + 1
    if len(cuts) != 1:
        raise SystemExit(f"{path}: {len(cuts) + 1} lines at sensor steps over {JUMP_M} m, expected 2")
    bounds = [0, cuts[0], len(xyz)]
    if with_rings:
        return [(xyz[a:b], frame[a:b], ring[a:b]) for a, b in zip(bounds[:-1], bounds[1:])]
    return [(xyz[a:b], frame[a:b]) for a, b in zip(bounds[:-1], bounds[1:])]


def plane_distances(points, reference):
    """Distance of each point to the plane of its K nearest reference points, and a mask of the
    points whose K neighbours all lie within MAX_NEIGHBOUR_M."""
    tree = cKDTree(reference)
    dist, idx = tree.query(points, k=K)
    keep = dist[:, -1] <= MAX_NEIGHBOUR_M
    nb = reference[idx[keep]]  # (n, K, 3)
    centre = nb.mean(axis=1)
    d = nb - centre[:, None, :]
    cov = np.einsum("nki,nkj->nij", d, d)
    _, vecs = np.linalg.eigh(cov)
    normal = vecs[:, :, 0]
    return np.abs(np.einsum("ni,ni->n", points[keep] - centre, normal)), keep


def rigid_best(a, b):
    """The misfit after the best rigid motion of line b onto line a (module docs)."""
    from scipy.optimize import minimize
    from scipy.spatial.transform import Rotation

    centre = b.mean(axis=0)
    rng = np.random.default_rng(1)
    sample_a = a[rng.choice(len(a), min(5000, len(a)), replace=False)]
    tree_a = cKDTree(a)

    def moved(x):
        r = Rotation.from_euler("xyz", np.radians(x[:3])).as_matrix()
        return (b - centre) @ r.T + centre + x[3:]

    def cost(x, full=False):
        bb = moved(x)
        d1, _ = plane_distances(a if full else sample_a, bb)
        step = 1 if full else max(1, len(bb) // 5000)
        d2 = plane_distances_tree(bb[::step], a, tree_a)
        return rms(np.concatenate([d1, d2]))

    x = np.zeros(6)
    for _ in range(3):
        simplex = np.vstack([x, x + np.diag([0.5, 0.5, 0.5, 0.1, 0.1, 0.1])])
        x = minimize(
            cost,
            x,
            method="Nelder-Mead",
            options=dict(initial_simplex=simplex, maxiter=2000, xatol=1e-3, fatol=1e-6),
        ).x
    return cost(x, full=True), x


def plane_distances_tree(points, reference, tree):
    dist, idx = tree.query(points, k=K)
    keep = dist[:, -1] <= MAX_NEIGHBOUR_M
    nb = reference[idx[keep]]
    centre = nb.mean(axis=1)
    d = nb - centre[:, None, :]
    _, vecs = np.linalg.eigh(np.einsum("nki,nkj->nij", d, d))
    return np.abs(np.einsum("ni,ni->n", points[keep] - centre, vecs[:, :, 0]))


def by_ring(d, keep, ring):
    r = ring[keep]
    return [rms(d[r == k]) if (r == k).sum() >= 50 else None for k in range(32)]


def rms(a):
    return float(np.sqrt(np.mean(a**2))) if len(a) else float("nan")


def misfit(path, coordinates=None, rigid=False):
    (a, fa, ra), (b, fb, rb) = lines_of(path, coordinates, with_rings=True)
    dab, ka = plane_distances(a, b)
    dba, kb = plane_distances(b, a)
    both = np.concatenate([dab, dba])
    floors, blocks = [], []
    for xyz, frame, ring in ((a, fa, ra), (b, fb, rb)):
        for split, out in (((frame.astype(np.int64) % 2) == 0, floors), ((ring % 2) == 0, blocks)):
            d1, _ = plane_distances(xyz[split], xyz[~split])
            d2, _ = plane_distances(xyz[~split], xyz[split])
            out.append(rms(np.concatenate([d1, d2])))
    r = {
        "file": coordinates or path,
        "line_points": [len(a), len(b)],
        "counted_points": int(ka.sum() + kb.sum()),
        "rms_m": rms(both),
        "median_abs_m": float(np.median(both)),
        "rms_a_to_b_m": rms(dab),
        "rms_b_to_a_m": rms(dba),
        "floor_m": floors,
        "blocks_m": blocks,
        "by_ring_m": [by_ring(dab, ka, ra), by_ring(dba, kb, rb)],
    }
    if rigid:
        r["rigid_best_m"], r["rigid_motion_deg_m"] = rigid_best(a, b)
        r["rigid_motion_deg_m"] = [float(v) for v in r["rigid_motion_deg_m"]]
    return r


def main(argv):
    as_json = "--json" in argv
    rigid = "--rigid" in argv
    paths = [a for a in argv if a not in ("--json", "--rigid")]
    if not paths:
        raise SystemExit(__doc__)
    original = paths[0]
    for p in paths:
        r = misfit(original, None if p == original else p, rigid)
        if as_json:
            print(json.dumps(r))
        else:
            print(
                f"{p}: lines of {r['line_points'][0]} and {r['line_points'][1]} points, "
                f"{r['counted_points']} counted; point-to-plane RMS {100 * r['rms_m']:.1f} cm "
                f"(median |d| {100 * r['median_abs_m']:.1f} cm); floor (alternate frames) "
                f"{100 * r['floor_m'][0]:.1f} / {100 * r['floor_m'][1]:.1f} cm; "
                f"the two laser blocks of one pass {100 * r['blocks_m'][0]:.1f} / "
                f"{100 * r['blocks_m'][1]:.1f} cm"
                + (f"; best rigid motion of line 2 {100 * r['rigid_best_m']:.1f} cm" if rigid else "")
            )


if __name__ == "__main__":
    main(sys.argv[1:])
