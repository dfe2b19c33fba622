"""Chessboard photos rendered through a known lens curve (Ricoh's THETA V design curve, with
the projection's own maths: FisheyeLens.angles and to_world, supersampled), for the
`shlight calibrate-lens` tests; the `calibrated` fixture in tests/conftest.py runs the
command once on fourteen of them."""
import json
import math

import cv2
import numpy as np

from provider.core.geometry.lens_profiles import ricoh_curve
from provider.core.geometry.projections import FisheyeLens
from servertools import run_cli


N = 480                 # photo size; the 90° ring at 180 px, 100° at 192 px


RING90 = 180.0


BOARD = (8, 5)          # inner corners


SQUARE = 0.04           # metres


def true_lens():
    curve = ricoh_curve("V")
    return FisheyeLens(N / 2, N / 2, RING90 / float(curve.radius(math.pi / 2)), 200.0,
                       (0, 0, 1), (1, 0, 0), curve=curve)   # image up = −y: OpenCV's camera


def render_board(lens, R, t, ss=2):
    """An 8-bit photo of a chessboard at pose (R, t) (board → camera), grey surroundings."""
    cols, rows = BOARD[0] + 1, BOARD[1] + 1        # squares
    acc = np.zeros((N, N))
    for k in range(ss * ss):
        oy, ox = (k // ss + 0.5) / ss, (k % ss + 0.5) / ss
        py, px = np.mgrid[0:N, 0:N] + np.array([oy, ox])[:, None, None]
        theta, psi = lens.angles(px, py)
        d = lens.to_world(theta, psi)
        n = R[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            lam = (t @ n) / (d @ n)
        p = lam[..., None] * d - t
        u, v = np.floor(p @ R[:, 0] / SQUARE), np.floor(p @ R[:, 1] / SQUARE)
        near = (u >= -1) & (u <= cols) & (v >= -1) & (v <= rows) & (lam > 0)
        board = (u >= 0) & (u < cols) & (v >= 0) & (v < rows)
        value = np.where(board, np.where((u + v) % 2 == 0, 0.05, 0.95), 0.95)
        acc += np.where(near & (theta <= lens.theta_max), value, 0.3)
    return np.clip(acc / (ss * ss) * 255 + 0.5, 0, 255).astype(np.uint8)


def poses(count, seed=1):
    """Boards facing the lens from 0-70° off its axis, 0.25-0.4 m away, tilted."""
    rng = np.random.default_rng(seed)
    for _ in range(count):
        a, b = math.radians(rng.uniform(0, 70)), rng.uniform(0, 2 * math.pi)
        c = np.array([math.sin(a) * math.cos(b), math.sin(a) * math.sin(b), math.cos(a)])
        z = -c + rng.normal(0, 0.25, 3)
        z /= np.linalg.norm(z)
        x = np.cross([0, 1, 0], z)
        x /= np.linalg.norm(x)
        R = np.stack([x, np.cross(z, x), z], 1)
        yield R, c * rng.uniform(0.25, 0.4) - R @ np.array([0.18, 0.12, 0])


def calibrate(d):
    """(d, lens file as a dict, the finished command) of `shlight calibrate-lens` run on
    fourteen boards and one blank photo written into folder ``d``."""
    lens = true_lens()
    photos = []
    for i, (R, t) in enumerate(poses(14)):
        photos.append(str(d / f"board{i:02d}.png"))
        assert cv2.imwrite(photos[-1], render_board(lens, R, t))
    cv2.imwrite(str(d / "blank.png"), np.full((N, N), 128, np.uint8))
    out = d / "lens.json"
    res = run_cli("calibrate-lens", *photos, str(d / "blank.png"), "--board", "8x5",
                  "-o", str(out), timeout=300)
    assert res.returncode == 0, res.stderr
    return d, json.loads(out.read_text()), res
