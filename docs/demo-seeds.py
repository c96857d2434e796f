#!/usr/bin/env python3
"""Run `lidarqa demo --seed S` (S from argv[2:], default 1..6) and print the validation page's seeds
table rows from each run's calibration.json (strip-adjusted) and truth.json (full precision), and
the worst pair's RMSDz before, after the mounting-only and after the strip-adjusted correction
from its stdout."""
import json, math, re, shutil, subprocess, sys
binary = sys.argv[1]
seeds = [int(x) for x in sys.argv[2:]] or list(range(1, 7))
keys = ["lever_x_m", "lever_y_m", "lever_z_m", "boresight_roll_deg", "boresight_pitch_deg", "boresight_yaw_deg"]
for seed in seeds:
    out_dir = f"/tmp/seeds-{seed}"
    shutil.rmtree(out_dir, ignore_errors=True)
    out = subprocess.run([binary, "demo", "--seed", str(seed), "-o", out_dir], capture_output=True, text=True).stdout
    cal = json.load(open(f"{out_dir}/calibration.json"))
    truth = json.load(open(f"{out_dir}/truth.json"))
    cells, zs = [], []
    for k in keys:
        e = cal["parameters"][k] - truth["mounting"][k]
        s = cal["sigma"][k]
        if s is None:  # not determined: held at its prior value, its σ null
            cells.append("not determined")
            continue
        zs.append(e / s)
        cells.append(f"{e*100:+.2f} ({s*100:.2f})" if k.endswith("_m") else f"{e:+.4f} ({s:.4f})")
    b = re.search(r"RMSDz before correction\s+worst pair\s+(\S+) cm", out).group(1)
    m = re.search(r"RMSDz after mounting-only correction\s+worst pair\s+(\S+) cm", out).group(1)
    a = re.search(r"RMSDz after strip-adjusted correction\s+worst pair\s+(\S+) cm", out).group(1)
    row = " | ".join(cells).replace("-", "−")
    print(f"| {seed} | {row} | {max(abs(z) for z in zs):.2f} | {b} → {m} → {a} |", flush=True)
    print("Z", seed, " ".join(f"{z:.4f}" for z in zs), flush=True)
    print("   ", re.search(r"plane RMSE.*", out).group(0), flush=True)
    shutil.rmtree(out_dir, ignore_errors=True)
