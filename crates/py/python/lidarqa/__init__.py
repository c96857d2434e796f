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
    "evaluate_targets",
    "evaluate_nva",
    "overlap",
    "budget",
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


def find_targets(inputs, control, radius_m=None, method="circle-fit", window_m=6.0, output=None):
    """Targets in several files, each searched on its own and the centres merged per control id
    (as ``lidarqa targets``); returns ``{"report": ..., "warnings": [...]}``; with ``output``
    also writes the targets CSV there, as ``lidarqa targets -o``."""
    return _json.loads(_lidarqa.find_targets([str(p) for p in inputs], str(control), radius_m,
                                             method, window_m, _s(output)))


def evaluate_targets(targets, control, horizontal_class_m=None, vertical_class_m=None,
                     sensor=None, height_m=None, scan_angle_deg=None, tpu=None):
    """Accuracy of a targets CSV against a control CSV (``lidarqa evaluate --targets --control``):
    residuals, RMSE (Zhang et al. 2018, eqs. 7-8), ASPRS and NSSDA; the predicted σ beside it from
    ``tpu`` (a ``tpu_summary.json``: its median per-point σ, as ``--tpu``) or from ``sensor`` with
    ``height_m`` (that sensor file's budget, as ``--sensor``)."""
    return _json.loads(_lidarqa.evaluate_targets(str(targets), str(control), horizontal_class_m,
                                                 vertical_class_m, _s(sensor), height_m,
                                                 scan_angle_deg, _s(tpu)))


def evaluate_nva(ground, checkpoints, ground_class=2, vertical_class_m=None):
    """Vertical checkpoints against the TIN of the ground points of LAS/LAZ files (NVA, as
    ``lidarqa evaluate --ground --checkpoints``)."""
    return _json.loads(_lidarqa.evaluate_nva([str(p) for p in ground], str(checkpoints),
                                             ground_class, vertical_class_m))


def overlap(strips, cell_m=1.0, max_roughness_m=0.05, max_slope_deg=10.0):
    """Swath-to-swath height differences of overlapping strips on smooth cells (``lidarqa
    overlap -o``): per pair RMSDz, max |dz| and mean dz (first strip minus second), the dz grid
    and a profile."""
    return _json.loads(_lidarqa.overlap([str(p) for p in strips], cell_m, max_roughness_m,
                                        max_slope_deg))


def budget(preset=None, sensor=None, **geometry):
    """The error budget of one geometry (``lidarqa budget --format json``): ``preset`` (zhang2018, formerly seed000;
    czmil) or ``sensor`` (a sensor file), and keywords in degrees and metres: heading_deg,
    pitch_deg, roll_deg, scan_angle_deg, range_m, height_m, azimuth_deg, range_air_m,
    range_water_m, depth_m, sweep ("NAME=START:STOP:STEP"), bias ("key=value,...")."""
    return _json.loads(_lidarqa.budget(preset, _s(sensor), **geometry))


def run_manifest_entry(manifest, index, force=False):
    """Runs entry ``index`` of a manifest unless complete; returns what was done."""
    return _json.loads(_lidarqa.run_manifest_entry(str(manifest), int(index), force))


def manifest_len(manifest):
    """Number of entries in a manifest."""
    return _lidarqa.manifest_len(str(manifest))


def collect(manifest, summary=None):
    """Merges a manifest's tile reports (as ``lidarqa collect``); writes ``summary`` if given."""
    return _json.loads(_lidarqa.collect(str(manifest), _s(summary)))
