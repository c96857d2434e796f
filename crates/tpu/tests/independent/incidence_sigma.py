#!/usr/bin/env python3
"""An independent generator (numpy only, no scanner model of lidarqa's) of airborne returns on
slopes, gable roofs and tree crowns, sampled in one pass or two crossing passes, with a Monte
Carlo of each return's footprint error, for the honesty check of the incidence term's sigma
with lidarqa's judged surfaces (tests/incidence_sigma.rs).

Usage: incidence_sigma.py OUT.csv

Geometry (local east, north, up, metres). Each pass is a linear scanner 600 m above the ground
whose scan plane is vertical and across its track: pass A flies east along y = -100 m with its
scan lines 1.0 m apart and 0.3 m between pulses across, pass B flies north along x = +130 m.
Each pulse is cast as a ray and meets the first surface: a height field (a 25 deg plane; gable
roofs of 35 deg pitch 6 m above flat ground; flat ground) found by bisection on the ray, or a
tree crown (a sphere of 4 m radius whose centre is 8 m up), where 70 % of the rays through it
return from a leaf at an exponential depth (mean 1.5 m) along the chord. A leaf's normal is
drawn isotropically and kept with probability |cos a| (the beam meets a facet in proportion to
its projected area), so its incidence follows the density 2c of cos a.

The footprint error of a return is along the beam, Gaussian with sigma rho * gamma/2 * tan(a)
(a the true incidence, capped at 85 deg; gamma = 0.5 mrad), plus an independent vertical
2 cm; M = 64 draws per return. Written per return: x, y, z, the unit beam (east, north, up),
the range, the scene, the pass set (one: pass A alone; multi: A and B together), the class
(slope, roof, wall, ground, vegetation) and the mean over the draws of the squared vertical
error, m^2.
"""

import sys

import numpy as np

H = 600.0
GAMMA = 0.5e-3
SIGMA0 = 0.02
DRAWS = 64
CAP = np.radians(85.0)
EXTENT = 20.0  # scenes span -20..20 m in x and y
HOUSES = [(-8.0, -6.0, 7.0, 5.0, "x"), (9.0, 7.0, 5.0, 7.0, "y")]  # centre, half sizes, ridge
EAVE, PITCH = 6.0, np.radians(35.0)
TREES = [(-10.0, -10.0), (-10.0, 8.0), (0.0, 0.0), (11.0, -9.0), (10.0, 10.0), (-1.0, 13.0)]
CROWN_R, CROWN_Z = 4.0, 8.0
SLOPE, SLOPE_AZ = np.radians(25.0), np.radians(30.0)


def height(scene, x, y):
    """Height and class code (0 ground, 1 slope, 2 roof) of a height-field scene."""
    if scene == "slope":
        g = np.tan(SLOPE) * (x * np.cos(SLOPE_AZ) + y * np.sin(SLOPE_AZ))
        return g, np.ones_like(x, dtype=int)
    z = np.zeros_like(x)
    c = np.zeros_like(x, dtype=int)
    if scene == "roof":
        for cx, cy, hx, hy, ridge in HOUSES:
            inside = (np.abs(x - cx) < hx) & (np.abs(y - cy) < hy)
            d = hy - np.abs(y - cy) if ridge == "x" else hx - np.abs(x - cx)
            r = EAVE + np.tan(PITCH) * d
            z = np.where(inside, r, z)
            c = np.where(inside, 2, c)
    return z, c


def normal(scene, x, y):
    """The true unit normal of the height field at (x, y)."""
    n = np.zeros((len(x), 3))
    n[:, 2] = 1.0
    if scene == "slope":
        t = np.tan(SLOPE)
        n[:, 0], n[:, 1] = -t * np.cos(SLOPE_AZ), -t * np.sin(SLOPE_AZ)
    if scene == "roof":
        for cx, cy, hx, hy, ridge in HOUSES:
            inside = (np.abs(x - cx) < hx) & (np.abs(y - cy) < hy)
            t = np.tan(PITCH)
            if ridge == "x":
                n[inside, 1] = t * np.sign(y[inside] - cy)
            else:
                n[inside, 0] = t * np.sign(x[inside] - cx)
    return n / np.linalg.norm(n, axis=1)[:, None]


def pulses(pass_name):
    """Origins and unit directions of the pulses that can reach the scene."""
    lines = np.arange(-EXTENT - 2, EXTENT + 2, 1.0)
    if pass_name == "A":
        y0 = -100.0
        ys = np.arange(-EXTENT - 2, EXTENT + 2, 0.3)
        theta = np.arctan2(ys - y0, H)
        L, T = np.meshgrid(lines, theta, indexing="ij")
        o = np.column_stack([L.ravel(), np.full(L.size, y0), np.full(L.size, H)])
        u = np.column_stack([np.zeros(L.size), np.sin(T.ravel()), -np.cos(T.ravel())])
    else:
        x0 = 130.0
        xs = np.arange(-EXTENT - 2, EXTENT + 2, 0.3)
        theta = np.arctan2(x0 - xs, H)
        L, T = np.meshgrid(lines, theta, indexing="ij")
        o = np.column_stack([np.full(L.size, x0), L.ravel(), np.full(L.size, H)])
        u = np.column_stack([-np.sin(T.ravel()), np.zeros(L.size), -np.cos(T.ravel())])
    return o, u


def cast(scene, o, u, rng):
    """The first return of each ray: point, true normal, class name per ray."""
    # Height field: bisection on f(t) = z_ray(t) - h(x(t), y(t)) between the heights +40 m
    # and -40 m (every scene lies within).
    lo = (H - 40.0) / -u[:, 2]
    hi = (H + 40.0) / -u[:, 2]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        p = o + mid[:, None] * u
        f = p[:, 2] - height(scene, p[:, 0], p[:, 1])[0]
        above = f > 0
        lo = np.where(above, mid, lo)
        hi = np.where(above, hi, mid)
    t = 0.5 * (lo + hi)
    p = o + t[:, None] * u
    z, c = height(scene, p[:, 0], p[:, 1])
    n = normal(scene, p[:, 0], p[:, 1])
    kind = np.array(["ground", "slope", "roof"])[c]
    if scene == "roof":
        # A ray that ends below the eave inside a house met its wall.
        wall = (c == 2) & (p[:, 2] < EAVE - 1e-3)
        kind = np.where(wall, "wall", kind)
    if scene == "vegetation":
        for cx, cy in TREES:
            ctr = np.array([cx, cy, CROWN_Z])
            oc = o - ctr
            b = np.sum(oc * u, axis=1)
            disc = b * b - (np.sum(oc * oc, axis=1) - CROWN_R**2)
            hit = disc > 0
            t0 = -b - np.sqrt(np.where(hit, disc, 0.0))
            t1 = -b + np.sqrt(np.where(hit, disc, 0.0))
            depth = rng.exponential(1.5, len(o))
            leaf = hit & (rng.random(len(o)) < 0.7) & (depth < t1 - t0) & (t0 + depth < t)
            t = np.where(leaf, t0 + depth, t)
            kind = np.where(leaf, "vegetation", kind)
            n = np.where(leaf[:, None], leaf_normals(u, rng), n)
        p = o + t[:, None] * u
    # 2 cm of range noise on every return, as a real scanner has.
    p = p + rng.normal(0.0, 0.02, len(p))[:, None] * u
    inside = (np.abs(p[:, 0]) <= EXTENT) & (np.abs(p[:, 1]) <= EXTENT)
    return p[inside], n[inside], kind[inside], t[inside], u[inside]


def leaf_normals(u, rng):
    """Isotropic normals kept with probability |cos a| against the beams `u`."""
    out = np.zeros_like(u)
    todo = np.ones(len(u), dtype=bool)
    while todo.any():
        v = rng.normal(size=(todo.sum(), 3))
        v /= np.linalg.norm(v, axis=1)[:, None]
        c = np.abs(np.sum(v * u[todo], axis=1))
        keep = rng.random(len(c)) < c
        idx = np.flatnonzero(todo)[keep]
        out[idx] = v[keep]
        todo[idx] = False
    return out


def main(out_path):
    rng = np.random.default_rng(20261206)
    rows = []
    for scene in ["slope", "roof", "vegetation"]:
        passes = {}
        for pn in ["A", "B"]:
            o, u = pulses(pn)
            passes[pn] = cast(scene, o, u, rng)
        for mode, names in [("one", ["A"]), ("multi", ["A", "B"])]:
            p, n, kind, rho, u = (np.concatenate(x) for x in zip(*(passes[k] for k in names)))
            c = np.abs(np.sum(n * u, axis=1)).clip(0, 1)
            a = np.minimum(np.arccos(c), CAP)
            s_inc = rho * GAMMA / 2 * np.tan(a)
            e = (
                rng.normal(size=(len(p), DRAWS)) * (s_inc * np.abs(u[:, 2]))[:, None]
                + rng.normal(size=(len(p), DRAWS)) * SIGMA0
            )
            mse = np.mean(e * e, axis=1)
            for i in range(len(p)):
                rows.append(
                    f"{p[i,0]:.4f},{p[i,1]:.4f},{p[i,2]:.4f},{u[i,0]:.9f},{u[i,1]:.9f},"
                    f"{u[i,2]:.9f},{rho[i]:.4f},{scene},{mode},{kind[i]},{mse[i]:.9e}"
                )
    with open(out_path, "w") as f:
        f.write("x,y,z,ue,un,uu,range,scene,mode,kind,mse_up\n")
        f.write("\n".join(rows) + "\n")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
