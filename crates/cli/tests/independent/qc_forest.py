"""A forested delivery made apart from lidarqa's simulator, and the independent interswath check.

    python3 qc_forest.py generate OUT_DIR [DZ_M]
        Three north-south flight lines over a 300 m x 300 m hilly forest (NAD83 / BC Albers,
        EPSG:3005, LAS 1.2 point format 1 with GeoTIFF keys, as the real survey it imitates), cut into
        four 150 m tiles, every point source id 0 (the lines are told apart by GPS time only: they
        were flown 200 s apart). Pulses at 4 per m^2 and line; under tree crowns a pulse returns
        from the canopy (class 5) and, two times in three, from the ground (class 2). Line 3 is
        DZ_M higher (default 0.15 m). Writes OUT_DIR/tile_*.las and OUT_DIR/expected.json: per
        overlapping line pair, the RMSDz and cell count computed here on the generated points by
        the rule the USGS Lidar Base Specification describes (ground class only, 2 m cells, a
        least-squares plane per line and cell with at least 4 points, slope <= 10 deg, plane-fit
        RMS <= 0.05 m, the points spread across the cell (the smallest standard deviation of
        their positions in any direction >= 0.1 cell), dz = plane height of line a - line b at the
        middle of the two lines' centroids), and each cell's dz.

    python3 qc_forest.py delivery OUT_DIR clean|faults
        The same survey with 1 cm ground noise and checkpoints (checkpoints.csv). `faults` plants
        three: line 2 is 12 cm high, north of y = 200 m only 3 % of the pulses remain, and there
        are 25 checkpoints (ASPRS 2023 asks for 30); `clean` has none of these and 40 checkpoints.

    python3 qc_forest.py raster TIF EXPECTED_JSON A B
        Reads a dz GeoTIFF with rasterio and checks its CRS (EPSG:3005) and geotransform: the
        value at each expected cell centre of pair (A, B) (1-based line numbers) equals the dz
        computed here to 1e-4 m. Prints a JSON summary.
"""

import json
import sys

import numpy as np

EPSG = 3005
E0, N0 = 1_200_000.0, 500_000.0
CELL = 2.0


def terrain(x, y):
    return 300.0 + 0.03 * x + 0.02 * y + 1.5 * np.sin(x / 40.0) * np.cos(y / 55.0)


def generate(out, dz_m, noise_m=0.02, shifted_line=2, thin=False, checkpoints=0):
    import laspy
    import pyproj
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(7)
    # Trees: centres on a jittered 9 m grid, 60 % of the sites, crown radius 3-4.5 m.
    gx, gy = np.meshgrid(np.arange(4.5, 300, 9.0), np.arange(4.5, 300, 9.0))
    keep = rng.random(gx.size) < 0.6
    tx = gx.ravel()[keep] + rng.uniform(-2, 2, keep.sum())
    ty = gy.ravel()[keep] + rng.uniform(-2, 2, keep.sum())
    tr = rng.uniform(3.0, 4.5, keep.sum())
    th = rng.uniform(15.0, 25.0, keep.sum())
    lines = []
    for k, (xc, t0) in enumerate([(80.0, 1000.0), (150.0, 1200.0), (220.0, 1400.0)]):
        lo, hi = max(xc - 90.0, 0.0), min(xc + 90.0, 300.0)
        n = int(4.0 * (hi - lo) * 300.0)
        x = rng.uniform(lo, hi, n)
        y = rng.uniform(0.0, 300.0, n)
        t = t0 + y / 60.0 + rng.uniform(0, 1e-3, n)
        if thin:
            # An area under density: north of y = 200 m, 3 % of the pulses kept.
            keep = (y < 200.0) | (rng.random(n) < 0.03)
            x, y, t, n = x[keep], y[keep], t[keep], int(keep.sum())
        # The nearest tree; under it when within its crown.
        dist, j = cKDTree(np.c_[tx, ty]).query(np.c_[x, y])
        under = dist < tr[j]
        g = terrain(x, y) + rng.normal(0.0, noise_m, n)
        pts = []  # x, y, z, t, class, return number, number of returns
        # Open ground: one return.
        o = ~under
        pts.append(np.c_[x[o], y[o], g[o], t[o], np.full(o.sum(), 2), np.ones(o.sum()), np.ones(o.sum())])
        # Under a crown: canopy first; ground second two times in three, else a lower branch.
        u = under
        r = dist[u] / tr[j][u]
        canopy = terrain(x[u], y[u]) + th[j][u] * (1.0 - 0.3 * r**2)
        hit = rng.random(u.sum()) < 2.0 / 3.0
        pts.append(np.c_[x[u], y[u], canopy, t[u], np.full(u.sum(), 5), np.ones(u.sum()), np.full(u.sum(), 2)])
        second = np.where(hit, g[u], canopy - rng.uniform(2.0, 10.0, u.sum()))
        pts.append(np.c_[x[u], y[u], second, t[u], np.where(hit, 2, 5), np.full(u.sum(), 2), np.full(u.sum(), 2)])
        p = np.vstack(pts)
        if k == shifted_line:
            p[:, 2] += dz_m
        # As stored: millimetre steps (the files' scale; the offsets are whole metres).
        p[:, :3] = np.round(p[:, :3] * 1000.0) / 1000.0
        lines.append(p)

    # The independent interswath computation on the generated points.
    allxy = np.vstack([p[:, :2] for p in lines])
    origin = np.floor(allxy.min(axis=0) / CELL) * CELL
    fits = []
    for p in lines:
        gp = p[p[:, 4] == 2]
        ij = np.floor((gp[:, :2] - origin) / CELL).astype(int)
        cells = {}
        order = np.lexsort((ij[:, 1], ij[:, 0]))
        ij, gp = ij[order], gp[order]
        keys, starts = np.unique(ij, axis=0, return_index=True)
        bounds = list(starts[1:]) + [len(gp)]
        for key, s, e in zip(keys, starts, bounds):
            if e - s < 4:
                continue
            c = origin + (key + 0.5) * CELL
            q = gp[s:e]
            a = np.c_[np.ones(e - s), q[:, 0] - c[0], q[:, 1] - c[1]]
            sol, *_ = np.linalg.lstsq(a, q[:, 2], rcond=None)
            res = q[:, 2] - a @ sol
            rms = np.sqrt(np.mean(res**2))
            slope = np.degrees(np.arctan(np.hypot(sol[1], sol[2])))
            spread = np.sqrt(max(np.linalg.eigvalsh(np.cov(a[:, 1:].T, bias=True)).min(), 0.0))
            if slope <= 10.0 and rms <= 0.05 and spread >= 0.1 * CELL:
                cells[(int(key[0]), int(key[1]))] = (sol, a[:, 1:].mean(axis=0))
        fits.append(cells)
    pairs = []
    for a in range(3):
        for b in range(a + 1, 3):
            common = sorted(set(fits[a]) & set(fits[b]))
            if not common:
                continue
            def at(fit, e):
                sol, _ = fit
                return sol[0] + sol[1] * e[0] + sol[2] * e[1]

            mid = [0.5 * (fits[a][k][1] + fits[b][k][1]) for k in common]
            dz = np.array([at(fits[a][k], e) - at(fits[b][k], e) for k, e in zip(common, mid)])
            pairs.append({
                "lines": [a + 1, b + 1],
                "rmsdz_m": float(np.sqrt(np.mean(dz**2))),
                "max_abs_dz_m": float(np.abs(dz).max()),
                "cells": len(common),
                "cell_dz": [[k[0], k[1], float(d)] for k, d in zip(common, dz)],
            })

    # Tiles of 150 m, all lines in each, point source id 0, LAS 1.2 format 1 + GeoTIFF keys.
    allp = np.vstack(lines)
    files = []
    for ti in range(2):
        for tj in range(2):
            m = (np.floor(allp[:, 0] / 150.0) == ti) & (np.floor(allp[:, 1] / 150.0) == tj)
            q = allp[m]
            q = q[np.argsort(q[:, 3], kind="stable")]
            hdr = laspy.LasHeader(point_format=1, version="1.2")
            hdr.scales = np.array([0.001, 0.001, 0.001])
            hdr.offsets = np.array([E0, N0, 0.0])
            hdr.add_crs(pyproj.CRS.from_epsg(EPSG))
            las = laspy.LasData(hdr)
            las.x = q[:, 0] + E0
            las.y = q[:, 1] + N0
            las.z = q[:, 2]
            las.gps_time = q[:, 3]
            las.classification = q[:, 4].astype(np.uint8)
            las.return_number = q[:, 5].astype(np.uint8)
            las.number_of_returns = q[:, 6].astype(np.uint8)
            las.point_source_id = np.zeros(len(q), dtype=np.uint16)
            name = f"{out}/tile_{ti}_{tj}.las"
            las.write(name)
            files.append(name)
    if checkpoints:
        # Checkpoints on open ground (away from every crown), surveyed exactly.
        cx, cy = [], []
        tree = cKDTree(np.c_[tx, ty])
        while len(cx) < checkpoints:
            x, y = rng.uniform(20.0, 280.0, 2)
            d, j = tree.query([x, y])
            if d > tr[j] + 2.0:
                cx.append(x)
                cy.append(y)
        with open(f"{out}/checkpoints.csv", "w") as f:
            f.write("id,x,y,z\n")
            for k, (x, y) in enumerate(zip(cx, cy)):
                f.write(f"cp{k + 1},{x + E0:.3f},{y + N0:.3f},{terrain(x, y):.4f}\n")
    json.dump({
        "epsg": EPSG,
        "origin": [float(origin[0] + E0), float(origin[1] + N0)],
        "cell_m": CELL,
        "dz_m": dz_m,
        "files": files,
        "pairs": pairs,
    }, open(f"{out}/expected.json", "w"))
    print(json.dumps({"files": files, "pairs": [{k: v for k, v in p.items() if k != "cell_dz"} for p in pairs]}))


def raster(tif, expected, a, b):
    import rasterio

    e = json.load(open(expected))
    pair = next(p for p in e["pairs"] if p["lines"] == [a, b])
    ox, oy = e["origin"]
    c = e["cell_m"]
    with rasterio.open(tif) as src:
        assert src.crs is not None and src.crs.to_epsg() == e["epsg"], src.crs
        band = src.read(1)
        nodata = src.nodata
        worst = 0.0
        for ix, iy, dz in pair["cell_dz"]:
            x, y = ox + (ix + 0.5) * c, oy + (iy + 0.5) * c
            row, col = src.index(x, y)
            v = float(band[row, col])
            assert v != nodata, (ix, iy)
            worst = max(worst, abs(v - dz))
        assert worst < 1e-4, worst
        t = src.transform
        print(json.dumps({"epsg": src.crs.to_epsg(), "cells_checked": len(pair["cell_dz"]),
                          "worst_abs_diff_m": worst, "pixel_m": [t.a, -t.e], "nodata": nodata}))


if __name__ == "__main__":
    if sys.argv[1] == "generate":
        generate(sys.argv[2], float(sys.argv[3]) if len(sys.argv) > 3 else 0.15)
    elif sys.argv[1] == "delivery":
        # The planted faults, or none: line 2 12 cm high, an area under density, 25 checkpoints;
        # clean: 40 checkpoints. Ground noise 1 cm (survey-grade ranging on open ground).
        faults = sys.argv[3] == "faults"
        generate(sys.argv[2], 0.12 if faults else 0.0, noise_m=0.01, shifted_line=1,
                 thin=faults, checkpoints=25 if faults else 40)
    elif sys.argv[1] == "raster":
        raster(sys.argv[2], sys.argv[3], int(sys.argv[4]), int(sys.argv[5]))
    else:
        sys.exit(__doc__)
