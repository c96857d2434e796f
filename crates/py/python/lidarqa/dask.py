"""Run a lidarqa tile manifest on a ``dask.distributed`` cluster (SPEC §9).

Dask schedules; lidarqa only provides the per-entry function. Each entry is one task that
calls :func:`lidarqa.run_manifest_entry` on a worker (the Rust code releases the GIL), so a
finished tile is never redone and a tile whose worker died is simply run again: its output is
written atomically and its report after it, so nothing partial ever looks complete.

>>> from dask.distributed import Client, LocalCluster
>>> from lidarqa.dask import run_manifest
>>> with LocalCluster(n_workers=2, processes=True) as cluster, Client(cluster) as client:
...     summary = run_manifest("manifest.json", client)      # doctest: +SKIP
"""

import lidarqa


def _run_entry(manifest, index, force):
    # Imported on the worker: the task ships only the path and the index.
    import lidarqa as _lq

    return _lq.run_manifest_entry(manifest, index, force)


def run_manifest(manifest, client, summary=None, force=False, retries=2):
    """Maps every entry of ``manifest`` over ``client``, waits, then collects.

    Returns ``(summary, results)``: the survey summary (the object ``lidarqa collect`` and
    ``lidarqa tpu --summary`` write; also written to ``summary`` when given) and each entry's
    result dict (``index``, ``skipped``, ``points_read``, ...). ``retries`` is Dask's per-task
    retry count (a task lost with its worker is rescheduled by Dask regardless).
    """
    manifest = str(manifest)
    n = lidarqa.manifest_len(manifest)
    futures = [
        client.submit(_run_entry, manifest, i, force, key=f"lidarqa-entry-{i}-{manifest}",
                      pure=False, retries=retries)
        for i in range(n)
    ]
    results = client.gather(futures)
    return lidarqa.collect(manifest, summary), results
