"""The SPEC §9 must-show on a dask.distributed LocalCluster (2 worker processes, loopback):
a 16-tile simulated survey run through `lidarqa.dask.run_manifest` gives every tile byte for
byte as the single-machine `lidarqa tpu`, and the collected summary equals its summary; a
worker killed mid-run loses nothing, finished tiles are not redone, and no partial tile is
ever left looking complete.

Run as `python3 crates/py/tests/test_dask.py` (prints "N passed, N failed") or with pytest.
Needs the wheel installed (`pip install ./crates/py`), dask[distributed], and the release
binary (or $LIDARQA_BIN). $LIDARQA_TEST_PULSE_HZ sets the survey size (default 20000 Hz:
~730 000 points in 16 tiles).
"""

import json
import os
import signal
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402

import lidarqa  # noqa: E402
from lidarqa.dask import run_manifest  # noqa: E402

PULSE_HZ = float(os.environ.get("LIDARQA_TEST_PULSE_HZ", "20000"))
_STATE = {}


def setup():
    if not _STATE:
        work = Path(tempfile.mkdtemp(prefix="lidarqa-dask-"))
        _STATE["work"] = work
        _STATE["shared"] = common.survey(work, PULSE_HZ)
    return _STATE["work"], _STATE["shared"]


def normalised(summary):
    """The summary with tile paths reduced to file names (the runs write to other directories)."""
    s = json.loads(json.dumps(summary))
    for t in s["tiles"]:
        t["input"] = Path(t["input"]).name
        t["output"] = Path(t["output"]).name
    return s


def reference(work):
    return normalised(json.loads((work / "cli.json").read_text()))


def same_as_cli(work, out_dir, name):
    return (out_dir / name).read_bytes() == (work / "cli" / name).read_bytes()


def test_dask_equals_cli_byte_for_byte():
    from dask.distributed import Client

    work, shared = setup()
    manifest = common.plan(work, shared, "dask")
    with common.local_cluster(2) as cluster, Client(cluster) as client:
        assert len(client.scheduler_info()["workers"]) == 2
        summary, results = run_manifest(manifest, client, summary=work / "dask" / "summary.json")
    assert [r["index"] for r in results] == list(range(16))
    assert not any(r["skipped"] for r in results)
    for name in common.TILE_NAMES:
        assert same_as_cli(work, work / "dask" / "tpu", name), f"{name} differs from lidarqa tpu's"
    assert normalised(summary) == reference(work), "collected summary differs from lidarqa tpu's"
    # The file written equals `lidarqa collect` of the same manifest, and the table's numbers.
    written = json.loads((work / "dask" / "summary.json").read_text())
    assert written == summary
    assert summary["points_written"] > 16 * 1000


def test_killed_worker_loses_nothing():
    from dask.distributed import Client, as_completed

    work, shared = setup()
    manifest = common.plan(work, shared, "killed")
    out = work / "killed" / "tpu"
    with common.local_cluster(2) as cluster, Client(cluster) as client:
        pids = client.run(os.getpid)  # worker address -> pid
        futures = [client.submit(lidarqa.dask._run_entry, str(manifest), i, False,
                                 key=f"killed-{i}", pure=False, retries=3) for i in range(16)]
        done_before_kill = []
        victim = None
        for f in as_completed(futures):
            done_before_kill.append(f.result()["index"])
            if len(done_before_kill) == 3:
                busy = {w: ks for w, ks in client.processing().items() if ks}
                victim = next(iter(busy), next(iter(pids)))
                os.kill(pids[victim], signal.SIGKILL)
                break
        killed_at = time.time()
        # Right after the kill: whatever has a report (the completion marker) is complete and
        # equal to the reference; nothing else is taken as complete.
        complete = {int(json.loads(p.read_text())["index"]) for p in out.glob("*.report.json")}
        for i in complete:
            assert same_as_cli(work, out, common.TILE_NAMES[i]), f"entry {i} looks complete but is not"
        temporaries = [p.name for p in out.iterdir() if p.name.endswith(".tmp")]
        # Dask reschedules the killed worker's task; the first run finishes (or fails with
        # KilledWorker, which the rerun below recovers from either way).
        try:
            client.gather(futures)
        except Exception as e:  # noqa: BLE001 - any loss is recovered by the rerun
            print(f"first run ended with {type(e).__name__}: {e}")
        mtimes = {p.name: p.stat().st_mtime_ns for p in out.glob("*.laz")}
        complete_before_rerun = sorted(int(json.loads(p.read_text())["index"])
                                       for p in out.glob("*.report.json"))
        summary, results = run_manifest(manifest, client)
    skipped = sorted(r["index"] for r in results if r["skipped"])
    redone = sorted(r["index"] for r in results if not r["skipped"])
    print(f"killed worker {victim} (pid {pids[victim]}) after entries {sorted(done_before_kill)}; "
          f"temporary files at the kill: {temporaries}; complete before rerun: "
          f"{len(complete_before_rerun)}; rerun skipped {len(skipped)}, redid {redone}")
    assert skipped == complete_before_rerun, "a finished tile was redone"
    assert set(done_before_kill) <= set(skipped)
    for name, t in mtimes.items():
        i = common.TILE_NAMES.index(name)
        if i in skipped:
            assert (out / name).stat().st_mtime_ns == t, f"{name} was rewritten"
    for name in common.TILE_NAMES:
        assert same_as_cli(work, out, name), name
    assert normalised(summary) == reference(work)
    assert killed_at > 0


if __name__ == "__main__":
    sys.exit(common.run_tests(globals()))
