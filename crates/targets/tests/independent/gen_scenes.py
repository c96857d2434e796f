#!/usr/bin/env python3
"""Independent target scenes, written from the method's description with numpy and
laspy only (no lidarqa code path): raised plates, flat painted discs, and the flag scene.

    python3 gen_scenes.py OUTDIR [SEED]

writes, for each scene S in raised, flat, flags: OUTDIR/S.las (point format 1, intensity
uint16) and OUTDIR/S_control.csv (id,x,y,z,radius_m: the true plate centre, plate top for a
raised plate, ground for a painted disc), plus OUTDIR/S_truth.json (scene parameters).

Intensity model: ground level G with a slow range/incidence trend, plate level
P = G + C; every return's intensity is G + C * (fraction of its 15 cm footprint on the plate
or paint), plus Gaussian noise of a fraction of the contrast C. Heights: the return's height
is the surface under the footprint centre, plus 2 cm Gaussian noise.
"""
import json
import sys
from pathlib import Path

import laspy
import numpy as np

X0, Y0 = 512_000.0, 5_400_000.0
RADIUS = 0.8
FOOTPRINT_D = 0.15
GROUND_I, CONTRAST = 9000.0, 30000.0
Z_NOISE = 0.02


def ground_z(x, y):
    return 100.0 + 0.02 * (x - X0) - 0.01 * (y - Y0)


def footprint_offsets(n=64, seed=7):
    """Fixed sample points spread over the footprint disc (sunflower pattern)."""
    k = np.arange(n) + 0.5
    r = 0.5 * FOOTPRINT_D * np.sqrt(k / n)
    a = k * np.pi * (3.0 - np.sqrt(5.0))
    return np.stack([r * np.cos(a), r * np.sin(a)], axis=1)


FP = footprint_offsets()


def in_shapes(x, y, discs, lines):
    """Boolean: (x, y) on a disc or a painted line."""
    on = np.zeros_like(x, dtype=bool)
    for cx, cy, r in discs:
        on |= np.hypot(x - cx, y - cy) <= r
    for (ax, ay, bx, by, w) in lines:
        dx, dy = bx - ax, by - ay
        L = np.hypot(dx, dy)
        t = ((x - ax) * dx + (y - ay) * dy) / L
        d = np.abs((x - ax) * dy - (y - ay) * dx) / L
        on |= (t >= 0) & (t <= L) & (d <= 0.5 * w)
    return on


def isotropic(rng, xmin, xmax, ymin, ymax, density):
    n = rng.poisson(density * (xmax - xmin) * (ymax - ymin))
    return rng.uniform(xmin, xmax, n), rng.uniform(ymin, ymax, n)


def scan_lines(rng, xmin, xmax, ymin, ymax, across, along, angle_deg):
    """Points on parallel scan lines `across` apart, `along` apart on a line, lines at angle."""
    a = np.radians(angle_deg)
    ux, uy = np.cos(a), np.sin(a)  # along a line
    vx, vy = -uy, ux  # across lines
    cx, cy = 0.5 * (xmin + xmax), 0.5 * (ymin + ymax)
    half = 0.75 * np.hypot(xmax - xmin, ymax - ymin)
    xs, ys = [], []
    v = -half + rng.uniform(0, across)
    while v < half:
        s = np.arange(-half + rng.uniform(0, along), half, along)
        s = s + rng.normal(0, 0.01, s.size)
        vv = v + rng.normal(0, 0.01, s.size)
        xs.append(cx + s * ux + vv * vx)
        ys.append(cy + s * uy + vv * vy)
        v += across
    x, y = np.concatenate(xs), np.concatenate(ys)
    keep = (x >= xmin) & (x <= xmax) & (y >= ymin) & (y <= ymax)
    return x[keep], y[keep]


def returns(rng, x, y, discs, raised, lines, noise_frac, line_contrast=1.3):
    """Intensity and height of each return (x, y: footprint centres)."""
    frac_disc = np.zeros_like(x)
    frac_line = np.zeros_like(x)
    for ox, oy in FP:
        frac_disc += in_shapes(x + ox, y + oy, discs, [])
        frac_line += in_shapes(x + ox, y + oy, [], lines)
    frac_disc /= len(FP)
    frac_line /= len(FP)
    trend = 1.0 + 0.1 * np.sin((x - X0) / 25.0) + 0.05 * (y - Y0) / 20.0
    inten = GROUND_I * trend + CONTRAST * frac_disc + line_contrast * CONTRAST * frac_line
    inten += rng.normal(0.0, noise_frac * CONTRAST, x.size)
    z = ground_z(x, y)
    if raised:
        z = z + 0.5 * in_shapes(x, y, discs, [])
    z += rng.normal(0.0, Z_NOISE, x.size)
    return np.clip(inten, 0, 65535), z


def write(out, name, x, y, z, inten, control, truth):
    header = laspy.LasHeader(point_format=1, version="1.2")
    header.scales = [0.001, 0.001, 0.001]
    header.offsets = [X0, Y0, 0.0]
    las = laspy.LasData(header)
    las.x, las.y, las.z = x, y, z
    las.intensity = np.round(inten).astype(np.uint16)
    las.write(out / f"{name}.las")
    with open(out / f"{name}_control.csv", "w") as f:
        f.write("id,x,y,z,radius_m\n")
        for cid, cx, cy, cz in control:
            f.write(f"{cid},{cx:.4f},{cy:.4f},{cz:.4f},{RADIUS}\n")
    (out / f"{name}_truth.json").write_text(json.dumps(truth, indent=1))


def plates(rng, n):
    """n plate centres 12 m apart along x, each jittered, inside a 74 x 8 m strip."""
    return [(X0 + 6.0 + 12.0 * k + rng.uniform(-0.5, 0.5), Y0 + rng.uniform(-0.5, 0.5)) for k in range(n)]


def raised_scene(rng, out):
    centres = plates(rng, 6)
    discs = [(cx, cy, RADIUS) for cx, cy in centres]
    # A painted road line 15 cm wide, 1.7 m north of the plates' row.
    lines = [(X0 - 1.0, Y0 + 1.7, X0 + 75.0, Y0 + 1.7, 0.15)]
    x, y = isotropic(rng, X0 - 1.0, X0 + 74.0, Y0 - 4.0, Y0 + 4.0, 50.0)
    inten, z = returns(rng, x, y, discs, True, lines, 0.15)
    control = [(f"R{k + 1}", cx, cy, ground_z(cx, cy) + 0.5) for k, (cx, cy) in enumerate(centres)]
    write(out, "raised", x, y, z, inten, control,
          {"density": 50, "noise": 0.15, "raised": True, "line_north_m": 1.7})


def flat_scene(rng, out):
    centres = plates(rng, 6)
    discs = [(cx, cy, RADIUS) for cx, cy in centres]
    x, y = scan_lines(rng, X0 - 1.0, X0 + 74.0, Y0 - 4.0, Y0 + 4.0, 0.45, 0.22, 17.0)
    inten, z = returns(rng, x, y, discs, False, [], 0.25)
    control = [(f"F{k + 1}", cx, cy, ground_z(cx, cy)) for k, (cx, cy) in enumerate(centres)]
    write(out, "flat", x, y, z, inten, control,
          {"across_m": 0.45, "along_m": 0.22, "noise": 0.25, "raised": False})


def flags_scene(rng, out):
    """Two good discs; EMPTY: a control point with no target; LINE: a control point on a
    painted line; PAIR_A/PAIR_B: two discs 1.4 m apart, closer than their 1.6 m diameter."""
    good = [(X0 + 6.0, Y0), (X0 + 18.0, Y0)]
    pair = [(X0 + 42.0, Y0), (X0 + 43.4, Y0)]
    discs = [(cx, cy, RADIUS) for cx, cy in good + pair]
    lines = [(X0 + 54.0, Y0 - 4.0, X0 + 54.0, Y0 + 4.0, 0.15)]
    x, y = isotropic(rng, X0 - 1.0, X0 + 60.0, Y0 - 4.0, Y0 + 4.0, 50.0)
    inten, z = returns(rng, x, y, discs, False, lines, 0.15)
    gz = ground_z
    control = [("G1", *good[0], gz(*good[0])), ("G2", *good[1], gz(*good[1])),
               ("EMPTY", X0 + 30.0, Y0, gz(X0 + 30.0, Y0)),
               ("PAIR_A", *pair[0], gz(*pair[0])), ("PAIR_B", *pair[1], gz(*pair[1])),
               ("LINE", X0 + 54.0, Y0 + 0.3, gz(X0 + 54.0, Y0 + 0.3))]
    write(out, "flags", x, y, z, inten, control, {"density": 50, "noise": 0.15})


def main():
    out = Path(sys.argv[1])
    seed = int(sys.argv[2]) if len(sys.argv) > 2 else 18
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    raised_scene(rng, out)
    flat_scene(rng, out)
    flags_scene(rng, out)


if __name__ == "__main__":
    main()
