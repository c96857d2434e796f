#!/usr/bin/env python3
"""Surfaces sampled as an airborne scanner samples them, for the incidence term's judging.

Independent of lidarqa's simulator: numpy only, no scanner model. Each scene is drawn in its
own place, 300 m from the next, so no neighbourhood (bounded by lidarqa at a few tens of metres
here) reaches another scene. Usage:

    python3 anisotropic_surfaces.py OUT.csv

writes one row per point: `x,y,z,scene,kind,nx,ny,nz` (metres; `kind` is plane, vegetation,
line or wire; `nx, ny, nz` the true unit normal of a plane, zeros otherwise).

- **plane**: a tilted plane of known slope (0–40°) and aspect, sampled on parallel lines that
  are horizontal in plan (the scan lines of a flight), the points `along` metres apart on a line
  and the lines `across` metres apart (0.1–0.3 m along, 0.5–3 m across: the k = 10 nearest
  neighbours of most points then lie on one line), each point moved along the plane's normal by
  Gaussian noise of σ `noise` (mm–cm) and jittered along its line by a tenth of the spacing.
- **vegetation**: a 12 × 12 × 8 m block of points spread through the volume (scan lines 1 m
  apart in plan, 0.3 m along them, heights uniform): no surface.
- **line**: one scan line, 0.1 m spacing, 1 cm noise, nothing beside it for 300 m: a line.
- **wire**: a horizontal wire 10 m above a flat, level plane (sampled 0.3 m × 1.5 m); the wire's
  points 0.3 m apart across the plane's lines: the wire's points are on a line, not a plane.
"""

import sys

import numpy as np

RNG = np.random.default_rng(20260128)

# slope deg, aspect deg (downhill azimuth, clockwise from +y), along m, across m, noise m,
# azimuth of the lines deg
PLANES = [
    (0.0, 0.0, 0.10, 0.5, 0.002, 0.0),
    (5.0, 30.0, 0.10, 3.0, 0.005, 20.0),
    (10.0, 120.0, 0.20, 2.0, 0.010, 75.0),
    (20.0, 200.0, 0.30, 3.0, 0.020, 0.0),
    (25.0, 45.0, 0.10, 1.5, 0.010, 90.0),
    (30.0, 300.0, 0.15, 2.5, 0.005, 140.0),
    (35.0, 90.0, 0.10, 3.0, 0.010, 0.0),
    (40.0, 0.0, 0.10, 3.0, 0.010, 0.0),
    (40.0, 250.0, 0.30, 3.0, 0.030, 60.0),
]
SIDE_M = 40.0
SPACING_M = 300.0


def unit(v):
    return v / np.linalg.norm(v)


def plane(cx, cy, slope_deg, aspect_deg, along, across, noise, azimuth_deg):
    """Points on a plane through (cx, cy, 100) with the given slope and downhill aspect, and its
    upward unit normal."""
    s, a = np.radians(slope_deg), np.radians(aspect_deg)
    # Downhill direction in plan (east, north) = (sin a, cos a); height falls tan(s) per metre.
    grad = -np.tan(s) * np.array([np.sin(a), np.cos(a)])
    normal = unit(np.array([-grad[0], -grad[1], 1.0]))
    az = np.radians(azimuth_deg)
    u = np.array([np.sin(az), np.cos(az)])  # along the lines, in plan
    w = np.array([u[1], -u[0]])  # across
    rows = []
    for j in np.arange(-SIDE_M / 2, SIDE_M / 2 + 1e-9, across):
        t = np.arange(-SIDE_M / 2, SIDE_M / 2 + 1e-9, along)
        t = t + RNG.uniform(-0.05, 0.05, t.size) * along
        xy = t[:, None] * u + j * w
        z = 100.0 + xy @ grad
        p = np.column_stack([xy[:, 0] + cx, xy[:, 1] + cy, z])
        p += RNG.normal(0.0, noise, t.size)[:, None] * normal
        rows.append(p)
    return np.vstack(rows), normal


def main(out):
    blocks = []  # (points, scene, kind, normal)
    for i, spec in enumerate(PLANES):
        p, n = plane(i * SPACING_M, 0.0, *spec)
        blocks.append((p, i, "plane", n))
    scene = len(PLANES)
    # Vegetation: heights spread through 8 m, on lines 1 m apart, 0.3 m along them.
    g = np.arange(0.0, 12.0, 0.3)
    veg = [
        np.column_stack([g + RNG.uniform(-0.1, 0.1, g.size), np.full(g.size, y),
                         RNG.uniform(0.0, 8.0, g.size)])
        for y in np.arange(0.0, 12.0, 1.0)
    ]
    veg = np.vstack(veg)
    veg[:, :2] += RNG.normal(0.0, 0.05, (len(veg), 2))
    veg[:, 0] += scene * SPACING_M
    blocks.append((veg, scene, "vegetation", np.zeros(3)))
    scene += 1
    t = np.arange(0.0, 100.0, 0.1)
    line = np.column_stack([t + scene * SPACING_M, np.zeros(t.size), np.full(t.size, 100.0)])
    line += RNG.normal(0.0, 0.01, line.shape)
    blocks.append((line, scene, "line", np.zeros(3)))
    scene += 1
    # A level plane sampled 0.3 m along lines 1.5 m apart, and a wire 10 m above it, across
    # the lines.
    ground = []
    for y in np.arange(-20.0, 20.0 + 1e-9, 1.5):
        x = np.arange(-20.0, 20.0 + 1e-9, 0.3)
        ground.append(np.column_stack([x, np.full(x.size, y), np.full(x.size, 100.0)]))
    ground = np.vstack(ground)
    ground[:, 2] += RNG.normal(0.0, 0.01, len(ground))
    ground[:, 0] += scene * SPACING_M
    blocks.append((ground, scene, "plane", np.array([0.0, 0.0, 1.0])))
    y = np.arange(-20.0, 20.0 + 1e-9, 0.3)
    wire = np.column_stack([np.full(y.size, scene * SPACING_M + 0.7), y, np.full(y.size, 110.0)])
    wire += RNG.normal(0.0, 0.01, wire.shape)
    blocks.append((wire, scene, "wire", np.zeros(3)))

    with open(out, "w") as f:
        f.write("x,y,z,scene,kind,nx,ny,nz\n")
        for p, sc, kind, n in blocks:
            for x, y, z in p:
                f.write(f"{x:.4f},{y:.4f},{z:.4f},{sc},{kind},{n[0]:.9f},{n[1]:.9f},{n[2]:.9f}\n")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
