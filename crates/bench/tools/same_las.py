"""Check that two LAS/LAZ files hold the same header, VLRs and point records, byte for byte.

A change to how `lidarqa tpu` or `correct` reads and writes records (not to what they compute)
must leave their outputs' content unchanged: this reads both with laspy (independently of
lidarqa's reader) and compares every public header field but the generating software (its
version may differ), every VLR and EVLR (user, record id, description, data) and the point
records' bytes, field by field, naming the first field and point that differ.

    python3 crates/bench/tools/same_las.py A B      # A, B: files or directories of .la[sz]
"""

import sys
from pathlib import Path

import laspy
import numpy as np

HEADER_FIELDS = [
    "version", "point_format", "point_count", "file_source_id", "global_encoding",
    "system_identifier", "scales", "offsets", "mins", "maxs",
    "number_of_points_by_return", "creation_date", "uuid",
]


def files(p: Path):
    return sorted(p.glob("*.la[sz]")) if p.is_dir() else [p]


def vlrs(v):
    return [(r.user_id, r.record_id, r.description, bytes(r.record_data_bytes())) for r in v]


def same(a: Path, b: Path) -> list[str]:
    la, lb = laspy.read(a), laspy.read(b)
    bad = []
    for f in HEADER_FIELDS:
        # The global encoding is a bit-field object: compare its bits.
        x, y = (getattr(getattr(h, f), "value", getattr(h, f)) for h in (la.header, lb.header))
        if not np.array_equal(np.asarray(x, dtype=object), np.asarray(y, dtype=object)):
            bad.append(f"header {f}: {x} vs {y}")
    if la.header.point_format.id != lb.header.point_format.id:
        bad.append("point format id")
    if vlrs(la.header.vlrs) != vlrs(lb.header.vlrs):
        bad.append(f"VLRs differ: {vlrs(la.header.vlrs)} vs {vlrs(lb.header.vlrs)}")
    if vlrs(la.evlrs or []) != vlrs(lb.evlrs or []):
        bad.append("EVLRs differ")
    pa, pb = la.points.array, lb.points.array
    if pa.dtype != pb.dtype or len(pa) != len(pb):
        bad.append(f"records: {pa.dtype}, {len(pa)} vs {pb.dtype}, {len(pb)}")
        return bad
    for name in pa.dtype.names:
        # Bytes, not values: NaN equals NaN, -0 differs from 0.
        u, v = (np.ascontiguousarray(p[name]).view(np.uint8).reshape(len(p), -1) for p in (pa, pb))
        d = np.flatnonzero((u != v).any(axis=1))
        if d.size:
            bad.append(f"field {name}: {d.size} points differ, first {d[0]}: "
                       f"{pa[name][d[0]]} vs {pb[name][d[0]]}")
    return bad


def main(a: str, b: str) -> int:
    fa, fb = files(Path(a)), files(Path(b))
    # Two directories: the same file names; two files: any names.
    if Path(a).is_dir() and [f.name for f in fa] != [f.name for f in fb]:
        print(f"different files: {[f.name for f in fa]} vs {[f.name for f in fb]}")
        return 1
    status = 0
    for x, y in zip(fa, fb):
        bad = same(x, y)
        print(f"{x.name}: " + ("same header, VLRs and records" if not bad else "; ".join(bad)))
        status |= bool(bad)
    return status


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:3]))
