"""Shared setup of the Python tests and the scaling script: the lidarqa binary, a simulated
16-tile survey, and `lidarqa tpu` over it as the single-machine reference."""

import os
import shutil
import subprocess
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]
TILE_NAMES = [f"tile_{c}_{r}.laz" for c in range(4) for r in range(4)]


def lidarqa_bin():
    """$LIDARQA_BIN, else the workspace's release build."""
    b = os.environ.get("LIDARQA_BIN") or str(REPO / "target" / "release" / "lidarqa")
    if not Path(b).is_file():
        raise SystemExit(f"{b}: no lidarqa binary (cargo build --release -p lidarqa, or set LIDARQA_BIN)")
    return b


def cli(*args):
    r = subprocess.run([lidarqa_bin(), *map(str, args)], capture_output=True, text=True)
    if r.returncode != 0:
        raise AssertionError(f"lidarqa {' '.join(map(str, args))}: {r.stderr.strip()}")
    return r.stderr


def survey(work, pulse_rate_hz):
    """Simulates the demo survey at `pulse_rate_hz`, cuts it into 4 x 4 tiles and runs
    `lidarqa tpu` over the tiles into work/cli (+ work/cli.json). Returns the shared flags."""
    work = Path(work)
    text = subprocess.run([lidarqa_bin(), "simulate", "--scenario", "demo", "--print"],
                          capture_output=True, text=True, check=True).stdout
    small = text.replace("pulse_rate_hz = 50000.0", f"pulse_rate_hz = {float(pulse_rate_hz)}")
    assert small != text, "the demo scenario's pulse rate moved"
    (work / "scenario.toml").write_text(small)
    cli("simulate", "--scenario", work / "scenario.toml", "-o", work / "sim")
    cli("tile", *sorted((work / "sim").glob("strip_*.laz")), "--grid", "4x4", "-o", work / "tiles")
    # The point-cloud tiles (`tile` keeps its own record, `.lidarqa-tiles.json`, beside them).
    tiles = [p.name for p in (work / "tiles").iterdir() if not p.name.startswith(".")]
    assert sorted(tiles) == sorted(TILE_NAMES)
    shared = ["--trajectory", work / "sim" / "sbet.out", "--smrmsg", work / "sim" / "smrmsg.out",
              "--sensor", work / "sim" / "sensor.toml"]
    cli("tpu", work / "tiles", *shared, "-o", work / "cli", "--summary", work / "cli.json")
    return shared


def plan(work, shared, name):
    """`lidarqa plan tpu` into work/name/manifest.json (outputs in work/name/tpu)."""
    d = Path(work) / name
    if d.exists():
        shutil.rmtree(d)
    cli("plan", "tpu", "--tiles", Path(work) / "tiles", *shared, "--output-dir", d / "tpu",
        "-o", d / "manifest.json")
    return d / "manifest.json"


def local_cluster(n_workers):
    from dask.distributed import LocalCluster

    return LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                        host="127.0.0.1", dashboard_address=None, silence_logs=40)


def run_tests(namespace):
    """Runs every `test_*` function of `namespace` (a test module's globals) without pytest,
    printing "N passed, N failed"; returns the exit status."""
    import traceback

    passed = failed = 0
    for name, fn in list(namespace.items()):
        if name.startswith("test_") and callable(fn):
            t0 = time.time()
            try:
                fn()
                passed += 1
                print(f"{name}: ok ({time.time() - t0:.1f} s)")
            except Exception as e:  # noqa: BLE001
                failed += 1
                traceback.print_exc()
                print(f"{name}: FAILED: {e}")
    print(f"{passed} passed, {failed} failed")
    return 1 if failed else 0
