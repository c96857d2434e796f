"""Scaling of the Dask path on this machine (SPEC §9), printed as a Markdown table:

- tiles/s with 1 and 2 worker processes (1 thread each; each tile's points use every core
  through rayon inside the worker), over the 16-tile survey, cluster start excluded;
- the per-tile overhead of the Dask path against the CLI on the same tile, in one run:
  `lidarqa run manifest.json --index I --force` as a subprocess vs the same entry as a Dask
  task (`run_manifest_entry(..., force=True)` submitted and awaited), median of interleaved
  repeats, and the in-process Python call without Dask.

Usage: python3 crates/py/tests/scaling.py [PULSE_HZ] [REPEATS]   (defaults 50000, 7)
"""

import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402

import lidarqa  # noqa: E402
from lidarqa.dask import run_manifest  # noqa: E402


def main():
    from dask.distributed import Client

    pulse = float(sys.argv[1]) if len(sys.argv) > 1 else 50000.0
    repeats = int(sys.argv[2]) if len(sys.argv) > 2 else 7
    work = Path(tempfile.mkdtemp(prefix="lidarqa-scaling-"))
    shared = common.survey(work, pulse)
    points = json_points(work)
    t0 = time.perf_counter()
    common.cli("tpu", work / "tiles", *shared, "-o", work / "cli2")
    t_cli_all = time.perf_counter() - t0
    rows = []
    for n in (1, 2):
        manifest = common.plan(work, shared, f"w{n}")
        with common.local_cluster(n) as cluster, Client(cluster) as client:
            client.run(lambda: __import__("lidarqa"))  # warm: import on every worker
            t0 = time.perf_counter()
            _, results = run_manifest(manifest, client)
            dt = time.perf_counter() - t0
            assert not any(r["skipped"] for r in results)
            rows.append((n, dt))
            if n == 1:
                overhead = per_tile(work, manifest, client, repeats)
    print(f"survey: 16 tiles, {points} points (demo scenario at {pulse:.0f} Hz); "
          f"`lidarqa tpu DIR` over all 16: {t_cli_all:.2f} s ({16 / t_cli_all:.2f} tiles/s)\n")
    print("| workers | wall s | tiles/s | speed-up |")
    print("|---:|---:|---:|---:|")
    for n, dt in rows:
        print(f"| {n} | {dt:.2f} | {16 / dt:.2f} | {rows[0][1] / dt:.2f} |")
    name, t_cli, t_dask, t_py = overhead
    print(f"\nper-tile overhead on {name} (median of {repeats}):")
    print("| path | s | ratio to CLI |")
    print("|---|---:|---:|")
    print(f"| `lidarqa run --index I --force` (subprocess) | {t_cli:.3f} | 1.00 |")
    print(f"| Dask task (submit + result, 1 worker) | {t_dask:.3f} | {t_dask / t_cli:.2f} |")
    print(f"| `lidarqa.run_manifest_entry` in-process | {t_py:.3f} | {t_py / t_cli:.2f} |")


def json_points(work):
    import json

    return json.loads((work / "cli.json").read_text())["points_read"]


def per_tile(work, manifest, client, repeats):
    """The largest tile, by CLI subprocess, Dask task and in-process call, interleaved."""
    m = __import__("json").loads(Path(manifest).read_text())
    sizes = [(e["input"]["size"], e["index"]) for e in m["entries"]]
    _, i = max(sizes)
    t_cli, t_dask, t_py = [], [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        subprocess.run([common.lidarqa_bin(), "run", str(manifest), "--index", str(i), "--force"],
                       check=True, capture_output=True)
        t_cli.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        client.submit(lidarqa.run_manifest_entry, str(manifest), i, True, pure=False).result()
        t_dask.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        lidarqa.run_manifest_entry(manifest, i, True)
        t_py.append(time.perf_counter() - t0)
    name = Path(m["entries"][i]["input"]["path"]).name
    return name, statistics.median(t_cli), statistics.median(t_dask), statistics.median(t_py)


if __name__ == "__main__":
    main()
