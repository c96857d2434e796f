"""Compare lidarqa's per-point σ with leeward's own TPU of the same points (docs/guide/real-data.md).

    python3 docs/real-data/compare_leeward.py OUT.las LEEWARD_TPU.csv

OUT.las is `lidarqa tpu`'s output, LEEWARD_TPU.csv is leeward's per-point TPU of the same
files, as a CSV with columns x, y, range, incidence_angle, horizontal, vertical (both keep the
input's point order; the script checks the coordinates match). Needs laspy, numpy.
"""

import sys

import laspy
import numpy as np


def main(out_las, leeward_csv):
    ours = laspy.read(out_las)
    lw = np.genfromtxt(leeward_csv, delimiter=",", names=True)
    assert len(ours.x) == len(lw), "point counts differ"
    assert np.allclose(ours.x, lw["x"], atol=0.006) and np.allclose(ours.y, lw["y"], atol=0.006)
    # leeward's range term: sqrt(σ_r² + ρ·γ/4·tan α), a length added to a variance.
    lw_range = np.sqrt(0.02 ** 2 + lw["range"] * 0.25e-3 / 4 * np.tan(lw["incidence_angle"]))
    print(f"points {len(lw)}")
    for ours_name, lw_name in [("sigma_horizontal", "horizontal"), ("sigma_vertical", "vertical")]:
        a, b = np.asarray(ours[ours_name], dtype=float), lw[lw_name]
        print(f"{lw_name:>10}: lidarqa median {np.median(a):.3f} m, leeward median {np.median(b):.3f}"
              f" m, median ratio lidarqa/leeward {np.median(a / b):.2f}, correlation "
              f"{np.corrcoef(a, b)[0, 1]:+.2f}; leeward vs its own range term: correlation "
              f"{np.corrcoef(b, lw_range)[0, 1]:+.3f}")
    print(f"leeward's range term: median {np.median(lw_range):.3f} m")


if __name__ == "__main__":
    main(*sys.argv[1:3])
