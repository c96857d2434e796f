#!/usr/bin/env python3
"""Compare two `lidarqa demo` product trees: byte for byte, except dates/times and the LAS
creation date; overlap_*.json compared numerically (rel. 1e-9): its per-cell sums vary run to run on
main too. Usage: python3 docs/compare-demo.py BEFORE_DIR AFTER_DIR"""
import json, math, os, re, sys
a, b = sys.argv[1], sys.argv[2]
DATE = re.compile(rb"\d{4}-\d{2}-\d{2}([T ]\d{2}:\d{2}(:\d{2}(\.\d+)?)?Z?)?")
def close(x, y, path, out):
    if isinstance(x, float) or isinstance(y, float):
        if isinstance(x, (int, float)) and isinstance(y, (int, float)) and math.isclose(x, y, rel_tol=1e-9, abs_tol=1e-12):
            return
        out.append(f"{path}: {x!r} != {y!r}"); return
    if type(x) != type(y): out.append(f"{path}: type {type(x)} vs {type(y)}"); return
    if isinstance(x, dict):
        if x.keys() != y.keys(): out.append(f"{path}: keys {sorted(set(x)^set(y))}"); return
        for k in x: close(x[k], y[k], f"{path}.{k}", out)
    elif isinstance(x, list):
        if len(x) != len(y): out.append(f"{path}: len {len(x)} vs {len(y)}"); return
        for i, (p, q) in enumerate(zip(x, y)): close(p, q, f"{path}[{i}]", out)
    elif x != y:
        if isinstance(x, str) and DATE.sub(b"D", x.encode()) == DATE.sub(b"D", y.encode()): return
        out.append(f"{path}: {x!r} != {y!r}")
bad = 0
fa = sorted(os.path.relpath(os.path.join(r, f), a) for r, _, fs in os.walk(a) for f in fs)
fb = sorted(os.path.relpath(os.path.join(r, f), b) for r, _, fs in os.walk(b) for f in fs)
if fa != fb:
    print("file lists differ:", sorted(set(fa) ^ set(fb))); bad += 1
for f in sorted(set(fa) & set(fb)):
    x = open(os.path.join(a, f), "rb").read(); y = open(os.path.join(b, f), "rb").read()
    if x == y: continue
    if DATE.sub(b"D", x) == DATE.sub(b"D", y): continue
    if f.endswith((".las", ".laz")) and len(x) == len(y) and x[:90] == y[:90] and x[94:] == y[94:]: continue
    if f.endswith(".json"):
        out = []; close(json.loads(x), json.loads(y), f, out)
        if not out:
            if "overlap" not in f: print(f"{f}: equal only within 1e-9"); bad += 1
            continue
        print(f"{f}: {len(out)} differences, e.g. {out[:3]}"); bad += 1; continue
    print(f"{f}: differs"); bad += 1
print("SAME" if not bad else f"{bad} DIFFERENT", f"({len(fa)} files)")
sys.exit(1 if bad else 0)
