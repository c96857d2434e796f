"""Independent check of `lidarqa tpu` on a beam scanner's strip (rotating mirror, spinning
multi-beam, Risley pair, elliptical): for a sample of points, this script recovers the range and
the head's angles from the point, the SBET and the sensor file with its own code (pyproj for the
projection, its own rotations and beam directions), draws every source the sensor file gives a
sigma (GNSS, attitude, mounting, range with its ppm part, encoders, channel elevation) 20 000
times through its own forward model, and compares the Monte Carlo sigma per axis with the sigma
lidarqa wrote (within 3 %). A Risley pair's prism angles are solved numerically (scipy) from a
grid of starts: the two pairs that fire the beam are found and their covariances averaged, as
the tpu documents.

Usage: python3 beam_sigma.py DIR, with DIR/scenario.toml, DIR/sim/{strip_001.las, sbet.out,
sensor.toml} and DIR/tpu.las. Prints "N passed, 0 failed" when every check holds.
"""

import sys
import tomllib
from pathlib import Path

import laspy
import numpy as np
from pyproj import Transformer
from scipy.optimize import least_squares

DEG = np.pi / 180.0
N_DRAWS = 20_000
SAMPLE = 40


def rx(t):
    c, s = np.cos(t), np.sin(t)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def ry(t):
    c, s = np.cos(t), np.sin(t)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rz(t):
    c, s = np.cos(t), np.sin(t)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def rodrigues(axis, angle):
    """Rotation matrices (…, 3, 3) about unit axes (…, 3) by angles (…)."""
    k = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
    kx = np.zeros(k.shape[:-1] + (3, 3))
    kx[..., 0, 1], kx[..., 0, 2] = -k[..., 2], k[..., 1]
    kx[..., 1, 0], kx[..., 1, 2] = k[..., 2], -k[..., 0]
    kx[..., 2, 0], kx[..., 2, 1] = -k[..., 1], k[..., 0]
    a = np.asarray(angle)[..., None, None]
    eye = np.broadcast_to(np.eye(3), kx.shape)
    return eye + np.sin(a) * kx + (1 - np.cos(a)) * (kx @ kx)


def zyx_many(r, p, h):
    """Rz(h) Ry(p) Rx(r) for arrays of angles, (n, 3, 3)."""
    n = np.broadcast(r, p, h).shape
    ez = np.broadcast_to([0.0, 0.0, 1.0], n + (3,))
    ey = np.broadcast_to([0.0, 1.0, 0.0], n + (3,))
    ex = np.broadcast_to([1.0, 0.0, 0.0], n + (3,))
    return rodrigues(ez, h) @ rodrigues(ey, p) @ rodrigues(ex, r)


class Head:
    def __init__(self, scanner):
        self.kind = scanner["type"]
        self.h = rz(scanner.get("head_yaw_deg", 0.0) * DEG) @ ry(
            scanner.get("head_pitch_deg", 0.0) * DEG
        ) @ rx(scanner.get("head_roll_deg", 0.0) * DEG)
        self.ppm = scanner.get("range_sigma_ppm", 0.0) * 1e-6
        self.delta = [v * DEG for v in scanner.get("prism_deviations_deg", [0.0, 0.0])]
        self.alpha = scanner.get("cone_half_angle_deg", 0.0) * DEG

    def direction(self, a, b, e):
        """Unit beams in the head frame for arrays of encoder angles a, b and elevations e."""
        a, b, e = np.broadcast_arrays(np.asarray(a, float), np.asarray(b, float), np.asarray(e, float))
        if self.kind == "rotating-mirror":
            return np.stack([np.zeros_like(a), np.sin(a), np.cos(a)], -1)
        if self.kind == "spinning-multibeam":
            return np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], -1)
        if self.kind == "elliptical":
            s = np.sin(self.alpha)
            return np.stack([s * np.cos(a), s * np.sin(a), np.full_like(a, np.cos(self.alpha))], -1)
        # Risley: each wedge tilts the beam by its deviation about the axis 90° from its angle.
        axis = lambda t: np.stack([-np.sin(t), np.cos(t), np.zeros_like(t)], -1)
        z = np.broadcast_to([0.0, 0.0, 1.0], a.shape + (3,))
        w1 = rodrigues(axis(a), np.full_like(a, self.delta[0]))
        w2 = rodrigues(axis(b), np.full_like(a, self.delta[1]))
        return (w2 @ (w1 @ z[..., None]))[..., 0]

    def invert(self, d):
        """The (a, b, e) triples that fire the head-frame unit beam d."""
        if self.kind == "rotating-mirror":
            return [(np.arctan2(d[1], d[2]), 0.0, 0.0)]
        if self.kind == "spinning-multibeam":
            return [(np.arctan2(d[1], d[0]), 0.0, np.arcsin(d[2]))]
        if self.kind == "elliptical":
            return [(np.arctan2(d[1], d[0]), 0.0, 0.0)]
        found = []
        for a0 in np.linspace(-np.pi, np.pi, 8, endpoint=False):
            for b0 in np.linspace(-np.pi, np.pi, 8, endpoint=False):
                r = least_squares(lambda x: self.direction(x[0], x[1], 0.0) - d, [a0, b0], xtol=1e-15, ftol=1e-15, gtol=1e-15)
                if np.linalg.norm(r.fun) > 1e-9:
                    continue
                a, b = np.mod(r.x + np.pi, 2 * np.pi) - np.pi
                if all(abs(np.angle(np.exp(1j * (a - fa)))) + abs(np.angle(np.exp(1j * (b - fb)))) > 1e-6 for fa, fb, _ in found):
                    found.append((a, b, 0.0))
        return found


def ned_basis(lat, lon):
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    return np.array([[-sl * co, -so, -cl * co], [-sl * so, co, -cl * so], [cl, 0.0, -sl]])


def geodetic_to_ecef(lat, lon, h):
    a, f = 6378137.0, 1 / 298.257223563
    e2 = f * (2 - f)
    n = a / np.sqrt(1 - e2 * np.sin(lat) ** 2)
    return np.array([(n + h) * np.cos(lat) * np.cos(lon), (n + h) * np.cos(lat) * np.sin(lon), (n * (1 - e2) + h) * np.sin(lat)])


def main(root):
    root = Path(root)
    scenario = tomllib.loads((root / "scenario.toml").read_text())
    sensor = tomllib.loads((root / "sim" / "sensor.toml").read_text())
    head = Head(sensor["scanner"])
    sig = {k: v for k, v in sensor.get("sigma", {}).items()}
    mnt = sensor.get("mounting", {})
    r_m = zyx_many(mnt.get("boresight_roll_deg", 0.0) * DEG, mnt.get("boresight_pitch_deg", 0.0) * DEG, mnt.get("boresight_yaw_deg", 0.0) * DEG)
    lever = np.array(mnt.get("lever_arm_m", [0.0, 0.0, 0.0]))

    sbet = np.fromfile(root / "sim" / "sbet.out", dtype="<f8").reshape(-1, 17)
    las = laspy.read(root / "sim" / "strip_001.las")
    out = laspy.read(root / "tpu.las")
    assert len(out.points) == len(las.points)
    to_ecef = Transformer.from_crs(f"EPSG:{scenario['epsg']}", "EPSG:4978", always_xy=True)
    rng = np.random.default_rng(7)
    idx = [int(v) for v in rng.choice(len(las.points), size=min(SAMPLE, len(las.points)), replace=False)]
    xs, ys, zs, ts = (np.asarray(v, float) for v in (las.x, las.y, las.z, las.gps_time))
    sig_out = [np.asarray(out[n], float) for n in ("sigma_north", "sigma_east", "sigma_up")]

    passed = failed = 0
    worst = 0.0
    for i in idx:
        x, y, z = xs[i], ys[i], zs[i]
        sow = (ts[i] + 1e9) % 604800.0
        k = int(np.clip(np.searchsorted(sbet[:, 0], sow) - 1, 0, len(sbet) - 2))
        w = (sow - sbet[k, 0]) / (sbet[k + 1, 0] - sbet[k, 0])
        rec = sbet[k] + w * (sbet[k + 1] - sbet[k])
        lat, lon, alt, roll, pitch, heading = rec[1], rec[2], rec[3], rec[7], rec[8], rec[9] - rec[10]
        p0 = geodetic_to_ecef(lat, lon, alt)
        p = np.array(to_ecef.transform(x, y, z))
        ned = ned_basis(lat, lon).T @ (p - p0)
        r_n = zyx_many(roll, pitch, heading)
        s = r_m.T @ (r_n.T @ ned - lever)
        rho = np.linalg.norm(s)
        d = head.h.T @ s / rho
        covs = []
        for a, b, e in head.invert(d):
            g = lambda name, unit=1.0: sig.get(name, 0.0) * unit
            n = N_DRAWS
            dr = rng.standard_normal((n, 15))
            gnss = dr[:, 0:3] * [g("gnss_north_m"), g("gnss_east_m"), -g("gnss_up_m")]
            att = zyx_many(roll + dr[:, 3] * g("roll_deg", DEG), pitch + dr[:, 4] * g("pitch_deg", DEG), heading + dr[:, 5] * g("heading_deg", DEG))
            bm = zyx_many(
                mnt.get("boresight_roll_deg", 0.0) * DEG + dr[:, 6] * g("boresight_roll_deg", DEG),
                mnt.get("boresight_pitch_deg", 0.0) * DEG + dr[:, 7] * g("boresight_pitch_deg", DEG),
                mnt.get("boresight_yaw_deg", 0.0) * DEG + dr[:, 8] * g("boresight_yaw_deg", DEG),
            )
            lv = lever + dr[:, 9:12] * [g("lever_x_m"), g("lever_y_m"), g("lever_z_m")]
            rr = rho + dr[:, 12] * (g("range_m") + head.ppm * rho)
            dd = head.direction(a + dr[:, 13] * g("scan_angle_deg", DEG), b + dr[:, 14] * g("scan_angle_2_deg", DEG), e + rng.standard_normal(n) * g("channel_elevation_deg", DEG))
            sv = (head.h @ dd[..., None])[..., 0] * rr[:, None]
            f = gnss + (att @ ((bm @ sv[..., None])[..., 0] + lv)[..., None])[..., 0]
            f[:, 2] *= -1  # down → up
            covs.append(np.cov(f.T))
        if not covs:
            print(f"FAIL point {i}: no prism angles fire its beam")
            failed += 1
            continue
        c = sum(covs) / len(covs)
        mc = np.sqrt(np.diag(c))
        tpu = np.array([c[i] for c in sig_out])
        rel = np.abs(tpu / mc - 1)
        worst = max(worst, rel.max())
        if rel.max() <= 0.03:
            passed += 1
        else:
            failed += 1
            print(f"FAIL point {i} ({len(covs)} solutions): tpu {tpu} vs Monte Carlo {mc}")
    print(f"{head.kind}: largest |tpu sigma / Monte Carlo sigma - 1| over {passed + failed} points: {worst:.4f}")
    print(f"{passed} passed, {failed} failed")
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main(sys.argv[1])
