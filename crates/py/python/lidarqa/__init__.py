"""lidarqa for Python: the per-tile functions of the lidarqa Rust toolkit (SPEC §9).

Each function takes paths (a tile stays on disk), releases the GIL while it runs, and returns
a dict. Errors raise :class:`LidarqaError` with lidarqa's one-line message.

>>> import lidarqa
>>> report = lidarqa.tpu_tile("tile.laz", "tile_tpu.laz", trajectory="sbet.out",
...                           sensor="sensor.toml", smrmsg="smrmsg.out")   # doctest: +SKIP
>>> report["points_written"]                                                # doctest: +SKIP

For a survey, plan a manifest with ``lidarqa plan tpu`` and run it with
:func:`lidarqa.dask.run_manifest` on a ``dask.distributed`` client, or run one entry per job
array task with ``lidarqa run manifest.json --index N``.
"""

import json as _json

from . import _lidarqa
from ._lidarqa import LidarqaError, __version__

__all__ = [
    "LidarqaError",
    "__version__",
    "tpu_tile",
    "correct_tile",
    "extract_targets_tile",
    "find_targets",
    "run_manifest_entry",
    "manifest_len",
    "collect",
]


def _s(p):
    return None if p is None else str(p)


def tpu_tile(input, output, trajectory, sensor, smrmsg=None, gps_week=None, epsg=None,
             skip_outside=False, skip_invalid=False):
    """Per-point TPU of one tile; returns the tile's summary (``lidarqa tpu --summary``)."""
    return _json.loads(_lidarqa.tpu_tile(str(input), str(output), str(trajectory), str(sensor),
                                         _s(smrmsg), gps_week, epsg, skip_outside, skip_invalid))


def correct_tile(input, output, trajectory, sensor, calibration, gps_week=None):
    """Re-georeferences one tile with calibration.json; returns ``{input, output, points}``."""
    return _json.loads(_lidarqa.correct_tile(str(input), str(output), str(trajectory),
                                             str(sensor), str(calibration), gps_week))


def extract_targets_tile(input, output, control, radius_m=None, method="circle-fit",
                         window_m=6.0):
    """Targets near the control points in one tile; writes and returns the tile's report."""
    return _json.loads(_lidarqa.extract_targets_tile(str(input), str(output), str(control),
                                                     radius_m, method, window_m))


def find_targets(inputs, control, radius_m=None, method="circle-fit", window_m=6.0):
    """Targets in several files, each searched on its own and the centres merged per control id
    (as ``lidarqa targets``); returns ``{"report": ..., "warnings": [...]}``, writes nothing."""
    return _json.loads(_lidarqa.find_targets([str(p) for p in inputs], str(control), radius_m,
                                             method, window_m))


def run_manifest_entry(manifest, index, force=False):
    """Runs entry ``index`` of a manifest unless complete; returns what was done."""
    return _json.loads(_lidarqa.run_manifest_entry(str(manifest), int(index), force))


def manifest_len(manifest):
    """Number of entries in a manifest."""
    return _lidarqa.manifest_len(str(manifest))


def collect(manifest, summary=None):
    """Merges a manifest's tile reports (as ``lidarqa collect``); writes ``summary`` if given."""
    return _json.loads(_lidarqa.collect(str(manifest), _s(summary)))
