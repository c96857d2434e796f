#!/usr/bin/env python3
"""Convert a lidarqa survey (binary SBET + SMRMSG, LAS/LAZ strips) to the inputs NOAA's cBLUE reads.

cBLUE (github.com/cBLUE-dev-team/cBLUE.github.io, Sbet.py) reads every ``*.txt`` file of a
trajectory directory as whitespace-separated columns without a header, one epoch a line:

    time lon lat X Y Z roll pitch heading stdX stdY stdZ stdroll stdpitch stdheading

time in GPS seconds of week (it converts them to adjusted standard GPS time with the date it parses
from the first 8 characters of the file name, YYYYMMDD) or already adjusted standard time; lon/lat
in degrees; X/Y projected in the CRS of the points (it matches them to the LAS coordinates); Z
ellipsoidal height; attitude and its sigma in degrees; position sigma in metres. That is the
PosPac "export SBET + SMRMSG to ASCII" layout. It reads every ``*.las``/``*.laz`` of a second
directory with laspy: coordinates, gps_time (adjusted standard), classification (soundings are
the classes of ``subaqueous_classes`` in its cblue_configuration.json, 40 and 43 by default; every
other class gets only the subaerial part) and point_source_id (one flight line per id).
lidarqa's strips already hold all that (LAS 1.4 format 6, classes 2/40/41, one source id per strip),
so they are copied unchanged: cBLUE sees exactly the points lidarqa's TPU sees. cBLUE takes the
water surface as one ellipsoidal height for the whole run (depth = that height − z); this script
prints the median height of the water-surface returns (class 41) as the value to give it.

Usage (numpy, laspy with lazrs, pyproj):

    python3 docs/cblue/to_cblue.py --sbet B/sbet.out --smrmsg B/smrmsg.out --gps-week 2200 \
        -o CBLUE_IN B/strip_001.laz B/strip_002.laz

writes CBLUE_IN/trajectory/YYYYMMDD_sbet.txt and CBLUE_IN/las/*.laz.
"""

import argparse
import datetime
import os
import shutil
import sys

import laspy
import numpy as np
import pyproj

SBET_FIELDS = 17  # f64 per record (docs/reference/formats.md)
SMRMSG_FIELDS = 10
GPS_EPOCH = datetime.date(1980, 1, 6)
SURFACE_CLASS = 41


def fail(msg):
    print(f"to_cblue: {msg}", file=sys.stderr)
    sys.exit(1)


def read_records(path, fields, what):
    try:
        raw = np.fromfile(path, dtype="<f8")
    except OSError as e:
        fail(f"{path}: cannot read the {what} file ({e.strerror})")
    if raw.size == 0 or raw.size % fields:
        fail(
            f"{path}: {raw.size * 8} bytes is not a whole number of {fields * 8}-byte {what} "
            "records (is it the right file?)"
        )
    rec = raw.reshape(-1, fields)
    if not np.all(np.diff(rec[:, 0]) > 0):
        fail(f"{path}: {what} times do not increase")
    return rec


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sbet", required=True, help="binary SBET (GPS seconds of week)")
    ap.add_argument("--smrmsg", required=True, help="binary SMRMSG (sigma of the SBET)")
    ap.add_argument("--gps-week", type=int, required=True, help="GPS week of the survey")
    ap.add_argument("--epsg", type=int, help="EPSG of the points (default: the strips' CRS)")
    ap.add_argument("-o", "--output", required=True, help="output directory (created)")
    ap.add_argument("strips", nargs="+", help="LAS/LAZ strips")
    a = ap.parse_args()

    sbet = read_records(a.sbet, SBET_FIELDS, "SBET")
    msg = read_records(a.smrmsg, SMRMSG_FIELDS, "SMRMSG")
    t = sbet[:, 0]
    if t[0] < 0 or t[-1] > 7 * 86400:
        fail(f"{a.sbet}: times {t[0]} to {t[-1]} s are not GPS seconds of week")
    if msg[0, 0] > t[0] + 1 or msg[-1, 0] < t[-1] - 1:
        fail(f"{a.smrmsg}: covers {msg[0, 0]}–{msg[-1, 0]} s, the SBET {t[0]}–{t[-1]} s")

    epsg = a.epsg
    surface_z = []
    for s in a.strips:
        try:
            las = laspy.read(s)
        except Exception as e:  # laspy raises several types for bad files
            fail(f"{s}: not a readable LAS/LAZ file ({e})")
        crs = las.header.parse_crs()
        if crs is not None and crs.to_epsg() is not None:
            if epsg is None:
                epsg = crs.to_epsg()
            elif crs.to_epsg() != epsg:
                fail(f"{s}: CRS EPSG:{crs.to_epsg()} differs from EPSG:{epsg}")
        surface_z.append(np.asarray(las.z)[np.asarray(las.classification) == SURFACE_CLASS])
    if epsg is None:
        fail("the strips carry no CRS: give --epsg")

    lat_deg = np.degrees(sbet[:, 1])
    lon_deg = np.degrees(sbet[:, 2])
    to_grid = pyproj.Transformer.from_crs(4326, epsg, always_xy=True)
    x, y = to_grid.transform(lon_deg, lat_deg)

    # SMRMSG sigma at the SBET epochs (it may be recorded at another rate)
    def sig(col):
        return np.interp(t, msg[:, 0], msg[:, col])

    arcmin_to_deg = 1.0 / 60.0
    cols = np.column_stack(
        [
            t,
            lon_deg,
            lat_deg,
            x,
            y,
            sbet[:, 3],
            np.degrees(sbet[:, 7]),
            np.degrees(sbet[:, 8]),
            np.degrees(sbet[:, 9]),
            sig(2),  # east sigma -> stdX
            sig(1),  # north sigma -> stdY
            sig(3),  # down sigma -> stdZ
            sig(7) * arcmin_to_deg,
            sig(8) * arcmin_to_deg,
            sig(9) * arcmin_to_deg,
        ]
    )

    day = GPS_EPOCH + datetime.timedelta(days=7 * a.gps_week + int(t[0] // 86400))
    traj_dir = os.path.join(a.output, "trajectory")
    las_dir = os.path.join(a.output, "las")
    os.makedirs(traj_dir, exist_ok=True)
    os.makedirs(las_dir, exist_ok=True)
    traj = os.path.join(traj_dir, f"{day:%Y%m%d}_sbet.txt")
    fmt = ["%.6f", "%.10f", "%.10f", "%.4f", "%.4f", "%.4f"] + ["%.8f"] * 3 + ["%.5f"] * 3 + ["%.7f"] * 3
    np.savetxt(traj, cols, fmt=fmt, delimiter=" ")
    for s in a.strips:
        shutil.copyfile(s, os.path.join(las_dir, os.path.basename(s)))

    z = np.concatenate(surface_z)
    print(f"wrote {traj} ({len(t)} epochs, EPSG:{epsg}) and {len(a.strips)} strips to {las_dir}")
    if z.size:
        print(f"water surface ellipsoid height (median of {z.size} class-{SURFACE_CLASS} returns): {np.median(z):.3f} m")
    else:
        print(f"no class-{SURFACE_CLASS} returns: give cBLUE the water surface height yourself")


if __name__ == "__main__":
    main()
