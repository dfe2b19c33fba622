"""``--sections probes``: light probes (a mirror ball, Debevec's angular map) rendered from
the real panoramas, against the panorama's own SH9.

Every probe image is rendered from the equirect panorama (bilinear, 3×3 samples per pixel,
averaged over the part of the pixel that sees something), projected with the probe's
projection, and compared with the exact SH9 of the panorama itself: relative RMS
irradiance error over the sphere of normals. Measured: against ball resolution (128 to
1024 px across); with an unseen cone behind the ball (the grazing rim a real ball blurs);
what the camera's own reflection costs, masked or not; and what reading a ball filmed by a
pinhole camera at a finite distance as orthographic costs (the perspective correction);
and how well the ball is located in a webcam frame of the room (and whether a circle that is
off says it is weak). Written to ``probes.md`` and ``probes.png``.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from .common import _progress

#: The camera seen in the ball: a dark disc about +Z of this radiance, relative to the
#: panorama's mean (a black camera body and the photographer behind it).
CAMERA_RADIANCE = 0.05


def render_probe(hdr: np.ndarray, projection, samples: int = 3, camera_deg: float = 0.0):
    """The image ``projection`` records of the equirect panorama ``hdr`` (float32 linear):
    each pixel the mean of samples² bilinear looks at the panorama over its seen part;
    ``camera_deg`` > 0 puts a dark camera of that angular radius about +Z."""
    import cv2
    h, w = hdr.shape[:2]
    pano = np.concatenate([hdr[:, -1:], hdr, hdr[:, :1]], axis=1).astype(np.float32)
    pano = np.maximum(pano, 0)
    dark = CAMERA_RADIANCE * hdr.reshape(-1, 3).mean(axis=0)
    H, W = projection.height, projection.width
    py, px = np.mgrid[0:H, 0:W].astype(np.float64)
    acc = np.zeros((H, W, 3), np.float64)
    count = np.zeros((H, W), np.float64)
    offsets = (np.arange(samples) + 0.5) / samples
    for oy in offsets:
        for ox in offsets:
            d, valid = projection.pixel_to_direction(px + ox, py + oy)
            theta = np.arccos(np.clip(d[..., 1], -1, 1))
            phi = np.arctan2(d[..., 0], -d[..., 2])
            mapx = ((phi / (2 * np.pi) + 0.5) * w + 0.5).astype(np.float32)
            mapy = (theta / np.pi * h - 0.5).astype(np.float32)
            look = cv2.remap(pano, mapx, mapy, cv2.INTER_LINEAR,
                             borderMode=cv2.BORDER_REPLICATE).astype(np.float64)
            if camera_deg > 0:
                look[d[..., 2] > np.cos(np.radians(camera_deg))] = dark
            acc += np.where(valid[..., None], look, 0)
            count += valid
    return (acc / np.maximum(count, 1)[..., None]).astype(np.float32)


#: Balls in a 640×480 webcam frame (x, y, radius in px) that the locating section places.
LOCATE_BALLS = ((331.4, 212.7, 118.3), (200.6, 260.2, 150.7), (400.2, 200.9, 90.2))


def ball_in_room(hdr: np.ndarray, ball=LOCATE_BALLS[0], size=(640, 480)) -> np.ndarray:
    """A float32 webcam frame of ``size`` (W, H): the room in front of the camera (the
    panorama's middle half, dimmed ×0.5) with an orthographic mirror ball ``ball`` (x, y,
    radius px) in it reflecting the panorama, anti-aliased on its edge (4×4 coverage)."""
    import cv2

    from ..core.geometry.projections_probe import MirrorBall
    hdr = np.maximum(hdr, 0)
    w, h = size
    back = cv2.resize(hdr[:, hdr.shape[1] // 4: 3 * hdr.shape[1] // 4], (w, h)) * 0.5
    p = MirrorBall(w, h, center=ball[:2], radius=ball[2], crop=False)
    img = render_probe(hdr, p)
    cover = np.zeros((h, w))
    py, px = np.mgrid[0:h, 0:w].astype(float)
    for oy in (np.arange(4) + 0.5) / 4:
        for ox in (np.arange(4) + 0.5) / 4:
            cover += p.pixel_to_direction(px + ox, py + oy)[1]
    cover = (cover / 16)[..., None]
    return (cover * img + (1 - cover) * back).astype(np.float32)


def srgb8(linear: np.ndarray) -> np.ndarray:
    """8-bit sRGB of linear values, clipped to [0, 1] (a camera's JPEG, roughly)."""
    v = np.clip(linear, 0, 1)
    v = np.where(v <= 0.0031308, 12.92 * v, 1.055 * v ** (1 / 2.4) - 0.055)
    return np.round(v * 255).astype(np.uint8)


def locate_rows(panoramas) -> list:
    """``shlight locate-ball`` on each panorama's room with each of :data:`LOCATE_BALLS`,
    as float and as 8-bit sRGB (exposed to its 99th percentile): the markdown lines of the
    table, per scene and over all."""
    from ..core.registration.ball import EDGE_RAYS, locate_ball
    found, lines = [], []
    for name, hdr in panoramas:
        _progress(f"bench probes: locating the ball in {name}")
        for ball in LOCATE_BALLS:
            frame = ball_in_room(hdr, ball)
            for enc, img in (("float", frame),
                             ("sRGB 8-bit", srgb8(frame / np.percentile(frame, 99)))):
                c = locate_ball(img)
                err = max(float(np.hypot(c.x - ball[0], c.y - ball[1])),
                          abs(c.radius - ball[2]))
                found.append((name, ball[2], enc, err, c.edge_points, c.weak))
    lines.append("| scene | within 0.5 px | within 1 px | weak | off > 1 px, weak "
                 "| off > 1 px, not weak | worst (px) |")
    lines.append("|---|---:|---:|---:|---:|---:|---:|")
    for name in [n for n, _ in panoramas] + ["all"]:
        rows = [f for f in found if name in ("all", f[0])]
        off = [f for f in rows if f[3] > 1.0]
        lines.append(f"| {name} | {sum(f[3] <= 0.5 for f in rows)} of {len(rows)} | "
                     f"{sum(f[3] <= 1.0 for f in rows)} | {sum(f[5] for f in rows)} | "
                     f"{sum(f[5] for f in off)} | {sum(not f[5] for f in off)} | "
                     f"{max(f[3] for f in rows):.1f} |")
    lines += ["", f"Weak: fewer than half of the {EDGE_RAYS} rays agree on the edge "
              "(`\"weak\": true` and a warning)."]
    return lines


def _error(projection, image, truth) -> float:
    from ..core.geometry import sh
    from ..core.sh9.engine import SH9Projector
    got = SH9Projector(projection.width, projection.height, projection).project(image)
    return sh.irradiance_error(got.coefficients, truth)


def _row(label, errs) -> str:
    return (f"| {label} | " + " | ".join(f"{e * 100:.2f}" for e in errs)
            + f" | **{np.mean(errs) * 100:.2f}** | {np.max(errs) * 100:.2f} |")


def bench_probes(hdri, out: Path, args):
    from ..core.sh9.engine import SH9Projector
    from ..core.radiometry.images import read_image
    from ..core.geometry.projections_probe import AngularMap, MirrorBall
    paths = list(hdri)[:3] if args.quick else list(hdri)
    panoramas = [(p.stem, read_image(p)) for p in paths]
    names = [n for n, _ in panoramas]
    truth = {n: SH9Projector(hdr.shape[1], hdr.shape[0]).project(hdr).coefficients
             for n, hdr in panoramas}
    head = "| " + " | ".join(names) + " | mean | max |"
    rule = "|---|" + "---:|" * (len(names) + 2)
    sizes = (128, 256) if args.quick else (128, 256, 512, 1024)
    mid = 256 if args.quick else 512
    h0 = panoramas[0][1].shape[0]
    lines = ["# Light probes: a mirror ball and an angular map against the panorama's own SH9",
             "", f"Each probe is rendered from the real panoramas ({panoramas[0][1].shape[1]}×{h0}, "
             "bilinear, 3×3 samples per pixel) and projected; the error is the relative RMS "
             "irradiance error (%) over the sphere of normals against the exact SH9 of the "
             "panorama itself.", "",
             "## Against resolution (px across the ball or map)", "",
             "| probe, px " + head, rule]
    curves = {}
    for fmt, make in (("mirrorball", lambda s: MirrorBall(s, s)),
                      ("angular", lambda s: AngularMap(s, s))):
        for s in sizes:
            _progress(f"bench probes: {fmt} {s} px")
            p = make(s)
            errs = [_error(p, render_probe(hdr, p), truth[n]) for n, hdr in panoramas]
            curves.setdefault(fmt, []).append((s, float(np.mean(errs)), float(np.max(errs))))
            lines.append(_row(f"{fmt} {s}", errs))
    lines += ["", f"## The unseen cone behind the ball ({mid} px ball)", "",
              "The ball is rendered whole; the projection ignores the directions within the "
              "cone of −Z (`--ball-unseen`) and fills them with the mean of the seen band "
              "around them (`--ball-fill rim`) or leaves them black (`zero`).", "",
              "| cone, fill " + head, rule]
    balls = {}
    for n, hdr in panoramas:
        balls[n] = render_probe(hdr, MirrorBall(mid, mid))
    cones = (10, 20, 30, 45) if not args.quick else (20,)
    for cone in cones:
        for fill in ("rim", "zero"):
            _progress(f"bench probes: unseen {cone}° {fill}")
            p = MirrorBall(mid, mid, unseen_deg=cone, fill=fill)
            errs = [_error(p, balls[n], truth[n]) for n, _ in panoramas]
            curves.setdefault(f"unseen-{fill}", []).append((cone, float(np.mean(errs))))
            lines.append(_row(f"{cone}°, {fill}", errs))
    lines += ["", f"## The camera's own reflection ({mid} px ball)", "",
              f"A dark camera (radiance {CAMERA_RADIANCE:g} × the panorama's mean) covers the "
              "directions within the given angle of +Z; read as is, or masked with "
              "`--ball-mask` (the same angle) and filled from around it.", "",
              "| camera, reading " + head, rule]
    for cam in ((6,) if args.quick else (3, 6, 10, 15)):
        shots = {n: render_probe(hdr, MirrorBall(mid, mid), camera_deg=cam)
                 for n, hdr in panoramas}
        for label, p in (("as is", MirrorBall(mid, mid)),
                         ("masked, rim", MirrorBall(mid, mid, mask_deg=cam)),
                         ("masked, zero", MirrorBall(mid, mid, mask_deg=cam, fill="zero"))):
            _progress(f"bench probes: camera {cam}° {label}")
            errs = [_error(p, shots[n], truth[n]) for n, _ in panoramas]
            curves.setdefault(f"camera-{label}", []).append((cam, float(np.mean(errs))))
            lines.append(_row(f"{cam}°, {label}", errs))
    lines += ["", f"## Perspective: a pinhole camera at a finite distance ({mid} px ball)", "",
              "The ball is filmed by a pinhole camera at the given distance (ball radii; a "
              "ball of radius r fills a lens of horizontal field of view F at distance "
              "1/sin(atan(r/f)) radii); read as orthographic, or with that distance "
              "(`--ball-distance`, or `--fov`). The corrected reading still misses the "
              "ball's own shadow cone, asin(1/distance) about −Z (filled from around it).", "",
              "| distance, reading " + head, rule]
    for dist in ((5,) if args.quick else (2, 3, 5, 10, 20, 50)):
        true = MirrorBall(mid, mid, distance=dist)
        shots = {n: render_probe(hdr, true) for n, hdr in panoramas}
        for label, p in (("orthographic", MirrorBall(mid, mid)), ("corrected", true)):
            _progress(f"bench probes: distance {dist} {label}")
            errs = [_error(p, shots[n], truth[n]) for n, _ in panoramas]
            curves.setdefault(f"distance-{label}", []).append((dist, float(np.mean(errs))))
            lines.append(_row(f"{dist} radii, {label}", errs))
    lines += ["", "## Locating the ball (`shlight locate-ball`, `--ball auto`)", "",
              "A 640×480 webcam frame of each room (the panorama's middle half, dimmed) with a "
              "mirror ball reflecting the panorama, at three places and sizes "
              f"({', '.join(f'r {b[2]:g} px' for b in LOCATE_BALLS)}), as float and as 8-bit "
              "sRGB; the error is the larger of the centre's distance and the radius' error.",
              ""]
    lines += locate_rows(panoramas)
    (out / "probes.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    _plot(curves, out / "probes.png")


def _plot(curves, path):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        import matplotlib.ticker  # noqa: F401
    except ImportError:
        print("matplotlib not installed: no plot (pip install matplotlib)", file=sys.stderr)
        return
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    ax = axes[0]
    for fmt in ("mirrorball", "angular"):
        pts = curves.get(fmt, [])
        ax.plot([p[0] for p in pts], [p[1] * 100 for p in pts], "o-", label=f"{fmt} (mean)")
        ax.plot([p[0] for p in pts], [p[2] * 100 for p in pts], "o:", label=f"{fmt} (max)")
    ax.set_xscale("log", base=2)
    ax.set_yscale("log")
    ax.set_xlabel("probe size (px across)")
    ax.set_ylabel("irradiance error vs panorama SH9 (%)")
    ax.set_title("against resolution")
    ax.legend(fontsize=8)
    ax = axes[1]
    for key, style in (("unseen-rim", "o-"), ("unseen-zero", "o--"),
                       ("camera-as is", "s-"), ("camera-masked, rim", "s--")):
        pts = curves.get(key, [])
        ax.plot([p[0] for p in pts], [p[1] * 100 for p in pts], style, label=key)
    ax.set_yscale("log")
    ax.set_xlabel("cone half-angle (degrees)")
    ax.set_title("unseen cone (−Z) and camera reflection (+Z)")
    ax.legend(fontsize=8)
    ax = axes[2]
    for key in ("distance-orthographic", "distance-corrected"):
        pts = curves.get(key, [])
        ax.plot([p[0] for p in pts], [p[1] * 100 for p in pts], "o-", label=key.split("-")[1])
    ax.set_xscale("log")
    ax.set_yscale("log")
    ticks = [p[0] for p in curves.get("distance-corrected", [])]
    ax.set_xticks(ticks, [f"{t:g}" for t in ticks])
    ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.set_xlabel("camera distance (ball radii)")
    ax.set_title("perspective: read as orthographic or corrected")
    ax.legend(fontsize=8)
    for a in axes:
        a.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
