"""The Python bindings of accuracy evaluation and the error budget: each gives what the
`lidarqa` command prints, and the values are checked against closed forms and Zhang et al. (2018)
Table 1.

Run as `python3 crates/py/tests/test_bindings.py` (prints "N passed, N failed") or with pytest.
Needs the wheel installed (`pip install ./crates/py`), numpy and laspy, and the release binary
(or $LIDARQA_BIN) for the comparison with the CLI.
"""

import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402

import lidarqa  # noqa: E402


def cli_json(*args):
    """`lidarqa ... --format json` parsed, without the CLI's `warnings` list (empty here)."""
    r = subprocess.run([common.lidarqa_bin(), *map(str, args), "--format", "json"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    v = json.loads(r.stdout)
    assert v.pop("warnings") == []
    return v


def test_budget_zhang2018_is_table_1_and_the_cli():
    v = lidarqa.budget(preset="zhang2018")
    # Zhang et al. (2018) Table 1: 30° scan angle, 80 m below: footprint 80·tan 30° east, range 80 / cos 30°.
    assert abs(v["footprint"]["east"] - 80 * math.tan(math.radians(30))) < 1e-9
    assert abs(v["geometry"]["range_m"] - 80 / math.cos(math.radians(30))) < 1e-9
    # The table's totals, 5.27 / 5.19 / 10.04 cm (rounded to 0.1 mm there).
    for axis, cm in [("north", 5.27), ("east", 5.19), ("up", 10.04)]:
        assert abs(v["total"][axis] * 100 - cm) <= 0.005, (axis, v["total"][axis])
    assert v == cli_json("budget", "--preset", "zhang2018")
    # The preset's former name is still accepted and gives the same budget.
    assert lidarqa.budget(preset="seed000") == v


def test_budget_geometry_sweep_and_bias_as_the_cli():
    kw = dict(preset="zhang2018", height_m=200.0, sweep="scan-angle=-30:30:10",
              bias="boresight_roll_deg=0.05,lever_x_m=0.02")
    v = lidarqa.budget(**kw)
    assert v["sweep"] == "scan-angle" and v["unit"] == "deg"
    assert [p["at"] for p in v["points"]] == [-30.0, -20.0, -10.0, 0.0, 10.0, 20.0, 30.0]
    # At nadir the range is the height.
    assert abs(v["points"][3]["geometry"]["range_m"] - 200.0) < 1e-9
    assert v == cli_json("budget", "--preset", "zhang2018", "--height", "200",
                         "--sweep", "scan-angle=-30:30:10",
                         "--bias", "boresight_roll_deg=0.05,lever_x_m=0.02")
    one = lidarqa.budget(preset="czmil", azimuth_deg=90.0)
    assert abs(one["geometry"]["azimuth_deg"] - 90.0) < 1e-12
    assert one == cli_json("budget", "--preset", "czmil", "--azimuth", "90")


def test_budget_errors_name_the_value():
    for kw, want in [(dict(preset="nope"), "unknown preset 'nope'"),
                     (dict(preset="zhang2018", azimuth_deg=10.0), "conic scanner"),
                     (dict(preset="zhang2018", bias="boresight_roll=0.1"), "boresight_roll"),
                     (dict(), "preset or sensor")]:
        try:
            lidarqa.budget(**kw)
        except lidarqa.LidarqaError as e:
            assert want in str(e), (kw, str(e))
        else:
            raise AssertionError(f"{kw}: no error")


def _targets_and_control(d):
    """Five targets displaced from their control by known offsets (m)."""
    control = [("T1", 1000.0, 2000.0, 50.0), ("T2", 1100.0, 2000.0, 51.0),
               ("T3", 1000.0, 2100.0, 52.0), ("T4", 1100.0, 2100.0, 50.5),
               ("T5", 1050.0, 2050.0, 51.5)]
    offsets = [(0.03, -0.02, 0.05), (-0.01, 0.04, -0.02), (0.02, 0.01, 0.04),
               (-0.05, 0.00, -0.06), (0.01, -0.03, 0.01)]
    (d / "control.csv").write_text("id,x,y,z\n" + "".join(
        f"{i},{x:.4f},{y:.4f},{z:.4f}\n" for i, x, y, z in control))
    (d / "targets.csv").write_text("id,x,y,z\n" + "".join(
        f"{i},{x + dx:.4f},{y + dy:.4f},{z + dz:.4f}\n"
        for (i, x, y, z), (dx, dy, dz) in zip(control, offsets)))
    return offsets


def test_evaluate_targets_closed_form_and_cli():
    d = Path(tempfile.mkdtemp(prefix="lidarqa-py-eval-"))
    offsets = _targets_and_control(d)
    e = lidarqa.evaluate_targets(d / "targets.csv", d / "control.csv", vertical_class_m=0.10)
    n = len(offsets)
    # Zhang et al. (2018) eqs. 7 and 8: RMSE_H = √(Σ(dx² + dy²)/n), RMSE_V = √(Σ dz²/n); residual = lidar − control.
    rmse_h = math.sqrt(sum(dx * dx + dy * dy for dx, dy, _ in offsets) / n)
    rmse_v = math.sqrt(sum(dz * dz for _, _, dz in offsets) / n)
    assert e["n"] == n
    assert abs(e["rmse"]["horizontal"] - rmse_h) < 1e-9, e["rmse"]
    assert abs(e["rmse"]["vertical"] - rmse_v) < 1e-9, e["rmse"]
    assert e["predicted"] is None
    assert e == cli_json("evaluate", "--targets", d / "targets.csv", "--control", d / "control.csv",
                         "--vertical-class-m", "0.10")
    # With a sensor file the prediction is its budget at that height: that of Zhang et al. (2018) at 80 m, 30°.
    sensor = d / "zhang2018.toml"
    sensor.write_text(subprocess.run([common.lidarqa_bin(), "budget", "--preset", "zhang2018",
                                      "--print-sensor"], capture_output=True, text=True,
                                     check=True).stdout)
    p = lidarqa.evaluate_targets(d / "targets.csv", d / "control.csv", sensor=sensor,
                                 height_m=80.0, scan_angle_deg=30.0)["predicted"]
    assert abs(p["up"] * 100 - 10.04) <= 0.005, p
    try:
        lidarqa.evaluate_targets(d / "targets.csv", d / "control.csv", sensor=sensor)
    except lidarqa.LidarqaError as err:
        assert "height_m" in str(err)
    else:
        raise AssertionError("sensor without height_m accepted")
    # With a TPU summary the prediction is its median per-point σ: 3, 4, 12 cm give horizontal
    # √(3² + 4²) = 5 cm and 3-D √(5² + 12²) = 13 cm, as `lidarqa evaluate --tpu` shows.
    # The summary is read with its one type: every block `lidarqa tpu` writes, none it does not.
    stats = lambda m: {"min": 0.01, "median": m, "p95": 0.2, "max": 0.3, "mean": m}  # noqa: E731
    incidence = ["file_normals", "invalid_file_normals", "planar", "planar_widened", "linear",
                 "beam_in_plane", "scattered", "too_few_points"]
    summary = {
        "tiles": [], "scanner": "linear", "points_read": 10, "points_written": 10, "points": 10,
        "skipped": {}, "sigma": {"north": stats(0.03), "east": stats(0.04), "up": stats(0.12)},
        "percentiles": "", "source_share": {}, "points_with_surface_normal": 0,
        "incidence": {k: 0 for k in incidence}, "histogram": {"vertical": None, "horizontal": None},
        "grid": None, "scan_angle_check": None, "recovery_residual_m": None,
        "mounting_check": None, "warnings": [],
    }
    (d / "tpu_summary.json").write_text(json.dumps(summary))
    e = lidarqa.evaluate_targets(d / "targets.csv", d / "control.csv", tpu=d / "tpu_summary.json")
    p = e["predicted"]
    assert (p["north"], p["east"], p["up"]) == (0.03, 0.04, 0.12), p
    assert abs(p["horizontal"] - 0.05) < 1e-15 and abs(p["three_d"] - 0.13) < 1e-15, p
    assert e == cli_json("evaluate", "--targets", d / "targets.csv", "--control", d / "control.csv",
                         "--tpu", d / "tpu_summary.json")
    try:
        lidarqa.evaluate_targets(d / "targets.csv", d / "control.csv", tpu=d / "tpu_summary.json",
                                 sensor=sensor, height_m=80.0)
    except lidarqa.LidarqaError as err:
        assert "give one" in str(err)
    else:
        raise AssertionError("tpu and sensor both accepted")


def test_correct_tile_names_a_bad_calibration():
    """The calibration is read by the one reader `lidarqa correct` uses: its errors name the file
    and the key, before any strip is opened."""
    d = Path(tempfile.mkdtemp(prefix="lidarqa-py-correct-"))
    cal = d / "calibration.json"
    args = [d / "strip.laz", d / "out.laz", d / "sbet.out", d / "sensor.toml", cal]
    for text, want in [("{", "not JSON"),
                       (json.dumps({"parameters": {"lever_x_m": 0.0}}),
                        "parameters.lever_y_m is missing or not a number")]:
        cal.write_text(text)
        try:
            lidarqa.correct_tile(*args)
        except lidarqa.LidarqaError as e:
            assert str(e).startswith(f"{cal}: ") and want in str(e), str(e)
        else:
            raise AssertionError(f"{text!r}: no error")


def test_evaluate_nva_on_a_plane():
    import laspy
    import numpy as np

    d = Path(tempfile.mkdtemp(prefix="lidarqa-py-nva-"))
    # Ground on the plane z = 100 + 0.01 x − 0.02 y (metres, 1 m grid): exact at 1 mm LAS scale,
    # so the TIN reproduces the plane and a checkpoint's residual is minus its offset.
    gx, gy = np.meshgrid(np.arange(0.0, 41.0), np.arange(0.0, 41.0))
    x, y = gx.ravel() + 500000.0, gy.ravel() + 4000000.0
    plane = lambda x, y: 100.0 + 0.01 * (x - 500000.0) - 0.02 * (y - 4000000.0)  # noqa: E731
    header = laspy.LasHeader(point_format=1, version="1.2")
    header.scales = np.array([0.001, 0.001, 0.001])
    header.offsets = np.array([500000.0, 4000000.0, 0.0])
    las = laspy.LasData(header)
    las.x, las.y, las.z = x, y, plane(x, y)
    las.classification = np.full(x.size, 2, dtype=np.uint8)
    las.write(d / "ground.las")
    checkpoints = [("C1", 500010.3, 4000012.7, 0.04), ("C2", 500025.5, 4000005.25, -0.03),
                   ("C3", 500033.1, 4000030.9, 0.02), ("C4", 500007.75, 4000036.5, -0.05)]
    (d / "nva.csv").write_text("id,x,y,z\n" + "".join(
        f"{i},{cx},{cy},{plane(cx, cy) + off:.6f}\n" for i, cx, cy, off in checkpoints))
    v = lidarqa.evaluate_nva([d / "ground.las"], d / "nva.csv")
    rmse = math.sqrt(sum(off * off for *_, off in checkpoints) / len(checkpoints))
    assert v["n"] == 4 and v["outside_tin"] == []
    assert abs(v["rmse_v_m"] - rmse) < 2e-6, (v["rmse_v_m"], rmse)
    assert abs(v["mean_up_m"] + sum(off for *_, off in checkpoints) / 4) < 2e-6
    assert v == cli_json("evaluate", "--ground", d / "ground.las", "--checkpoints",
                         d / "nva.csv")["nva"]



def test_overlap_of_two_strips_one_raised():
    import laspy
    import numpy as np

    d = Path(tempfile.mkdtemp(prefix="lidarqa-py-overlap-"))
    # Two strips of the tilted plane z = 100 + 0.004 x (0.25 m grid: 1 mm steps), overlapping
    # over x = 10..20 m; the second is 4 cm higher, so every smooth cell has dz = −0.04 m, to the
    # half millimetre of the LAS scale.
    def strip(name, psid, x0, lift):
        gx, gy = np.meshgrid(np.arange(x0, x0 + 20.0, 0.25), np.arange(0.0, 20.0, 0.25))
        x, y = gx.ravel(), gy.ravel()
        header = laspy.LasHeader(point_format=1, version="1.2")
        header.scales = np.array([0.001, 0.001, 0.001])
        header.offsets = np.array([500000.0, 4000000.0, 0.0])
        las = laspy.LasData(header)
        las.x, las.y = x + 500000.0, y + 4000000.0
        las.z = 100.0 + 0.004 * x + lift
        las.point_source_id = np.full(x.size, psid, dtype=np.uint16)
        las.write(d / name)
        return d / name

    a, b = strip("a.las", 1, 0.0, 0.0), strip("b.las", 2, 10.0, 0.04)
    v = lidarqa.overlap([a, b])
    [pair] = v["pairs"]
    assert pair["strips"] == [1, 2] or pair["strips"] == ["1", "2"], pair["strips"]
    assert abs(pair["rmsdz_m"] - 0.04) < 5e-4 and abs(pair["mean_dz_m"] + 0.04) < 5e-4, pair
    # The overlap is 10 m × 20 m of 1 m cells, less the cells the edges cut.
    assert 150 <= pair["n"] <= 200, pair["n"]
    r = subprocess.run([common.lidarqa_bin(), "overlap", str(a), str(b), "--format", "json"],
                       capture_output=True, text=True, check=True)
    # The same numbers as the command, to the last bits (the wheel and the binary are built with
    # different profiles, which may round a sum differently).
    [cli] = json.loads(r.stdout)["pairs"]
    assert cli["strips"] == pair["strips"] and cli["n"] == pair["n"], (cli, pair)
    for k in ["rmsdz_m", "max_abs_dz_m", "mean_dz_m"]:
        assert math.isclose(cli[k], pair[k], rel_tol=1e-12), (k, cli[k], pair[k])
    try:
        lidarqa.overlap([a, a])
    except lidarqa.LidarqaError as e:
        assert "a.las" in str(e), str(e)
    else:
        raise AssertionError("a strip given twice accepted")



def test_find_targets_recovers_a_disk_and_writes_the_cli_csv():
    import laspy
    import numpy as np

    d = Path(tempfile.mkdtemp(prefix="lidarqa-py-targets-"))
    # A flat field at 100 m (0.25 m grid) with one bright disk, radius 0.8 m and 0.5 m up, centred
    # at (500 010.3, 4 000 020.7): the centre to a few cm, the height exactly.
    cx, cy = 500010.3, 4000020.7
    gx, gy = np.meshgrid(np.arange(0.03, 20.0, 0.25), np.arange(10.07, 30.0, 0.25))
    x, y = gx.ravel() + 500000.0, gy.ravel() + 4000000.0
    on = np.hypot(x - cx, y - cy) < 0.8
    header = laspy.LasHeader(point_format=1, version="1.2")
    header.scales = np.array([0.001, 0.001, 0.001])
    header.offsets = np.array([500000.0, 4000000.0, 0.0])
    las = laspy.LasData(header)
    las.x, las.y, las.z = x, y, np.where(on, 100.5, 100.0)
    las.intensity = np.where(on, 2000, 300).astype(np.uint16)
    las.gps_time = 1.0e8 + np.arange(x.size) * 1e-4
    las.point_source_id = np.ones(x.size, dtype=np.uint16)
    las.write(d / "field.las")
    (d / "control.csv").write_text(f"id,x,y,z\nA,{cx},{cy},100.5\n")
    v = lidarqa.find_targets([d / "field.las"], d / "control.csv", radius_m=0.8,
                             output=d / "py.csv")
    [t] = v["report"]["targets"]
    # The centre's fields are flattened into the target.
    assert t["id"] == "A" and math.hypot(t["x"] - cx, t["y"] - cy) < 0.05, t
    assert abs(t["z"] - 100.5) < 1e-3, t
    subprocess.run([common.lidarqa_bin(), "targets", str(d / "field.las"), "--control",
                    str(d / "control.csv"), "--radius-m", "0.8", "-o", str(d / "cli.csv")],
                   capture_output=True, check=True)
    assert (d / "py.csv").read_bytes() == (d / "cli.csv").read_bytes()


if __name__ == "__main__":
    sys.exit(common.run_tests(globals()))
