"""``--sections speed``: time per frame against irradiance error, per path and frame size."""
from __future__ import annotations

import math
import os
import sys
from pathlib import Path

from .common import _auto_exposure, _exact_float64, _median_ms_cycling, _progress, _to_srgb8


def paper_pipeline(frame_u8):
    """The paper's pipeline: resize the 8-bit frame to 64×48 (averaging sRGB values), then
    linearise and project with sin θ weights at pixel centres."""
    import cv2
    import numpy as np
    from ..core.geometry import sh
    from ..core.sh9.engine import srgb_to_linear
    small = cv2.resize(frame_u8, (64, 48), interpolation=cv2.INTER_AREA)
    lin = srgb_to_linear(small / 255.0)
    h, w = 48, 64
    theta = math.pi * (np.arange(h) + 0.5) / h
    phi = 2 * math.pi * ((np.arange(w) + 0.5) / w - 0.5)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    d = np.stack([np.sin(p) * np.sin(t), np.cos(t), -np.cos(p) * np.sin(t)], -1)
    dw = (2 * math.pi / w) * (math.pi / h) * np.sin(t)
    return np.einsum("hwk,hwc->kc", sh.sh_basis(d) * dw[..., None], lin)


# -- speed against error ------------------------------------------------------------------------

def bench_speed(hdri, out: Path, args):
    import cv2
    import numpy as np
    from ..core.geometry import sh
    from ..core.sh9.engine import SH9Projector, srgb_to_linear
    from ..core.radiometry.images import read_image

    sizes = [(640, 320), (1920, 960)] if args.quick else [(640, 320), (1920, 960), (3840, 1920)]
    repeat = 3 if args.quick else args.repeat
    panoramas = [(p.stem, read_image(p)) for p in hdri[: (3 if args.quick else None)]]
    # --downsample is withdrawn on equirect frames (issue 34: slower than exact at every size
    # measured, 1.25-1.9×); the fisheye's fast path is in the edge section
    paths = [("exact", 1)]
    lut8 = srgb_to_linear(np.arange(256) / 255.0)
    rows = []
    for (w, h) in sizes:
        for dtype in ("uint8", "float32"):
            frames = []
            for name, hdr in panoramas:
                big = cv2.resize(hdr, (w, h), interpolation=cv2.INTER_LINEAR)
                big = np.where(np.isfinite(big), big, 0).astype(np.float32)
                truth = _exact_float64(big)
                if dtype == "uint8":
                    ev = _auto_exposure(big)
                    f = _to_srgb8(big, ev)
                    frames.append((name, f, _exact_float64(f, lut8), truth * ev))
                else:
                    frames.append((name, big, truth, truth))
            images = [f for _, f, _, _ in frames]
            cycles = max(2, repeat // 3)
            floor = _median_ms_cycling(cv2.sumElems, images, cycles)
            variants = [(label, SH9Projector(w, h, downsample=ds)) for label, ds in paths]
            for label, proj in variants:
                _progress(f"bench {w}×{h} {dtype} {label}")
                ms = _median_ms_cycling(proj.project, images, cycles)
                errs, errs_hdr = [], []
                for _, f, ref, hdr_ref in frames:
                    c = proj.project(f).coefficients
                    errs.append(sh.irradiance_error(c, ref))
                    errs_hdr.append(sh.irradiance_error(c, hdr_ref))
                rows.append(dict(size=f"{w}×{h}", dtype=dtype, path=label, ms=ms,
                                 ratio=ms / floor, floor_ms=floor, err_max=max(errs),
                                 err_mean=float(np.mean(errs)),
                                 err_hdr=float(np.max(errs_hdr)) if dtype == "uint8" else None))
            if dtype == "float32":
                rows += _dirty_float_rows(frames, w, h, floor, cycles)
            if dtype == "uint8":
                _progress(f"bench {w}×{h} uint8 paper pipeline")
                ms = _median_ms_cycling(paper_pipeline, images, cycles)
                errs = [sh.irradiance_error(paper_pipeline(f), ref) for _, f, ref, _ in frames]
                errs_hdr = [sh.irradiance_error(paper_pipeline(f), hr) for _, f, _, hr in frames]
                rows.append(dict(size=f"{w}×{h}", dtype=dtype, path="paper (sRGB 64×48)",
                                 ms=ms, ratio=ms / floor, floor_ms=floor, err_max=max(errs),
                                 err_mean=float(np.mean(errs)), err_hdr=float(np.max(errs_hdr))))
    _write_speed(rows, out, panoramas, args)
    _progress("bench: the library beside a CPU hog")
    write_library_beside_a_hog(library_beside_a_hog(n=9 if args.quick else 31), out)


#: One frame after another through the library (no command line to size BLAS first); the
#: median ms per frame on stdout. argv: width height frames [no-limit].
_LIBRARY = r"""
import json, sys, time
import numpy as np
w, h, n = (int(a) for a in sys.argv[1:4])
if sys.argv[4:] == ["no-limit"]:            # the engine as it was before issue 33
    import provider.core.blas as blas
    blas._blas = lambda: None
from provider.core.sh9.engine import SH9Projector
rng = np.random.default_rng(0)
frames = [rng.integers(0, 256, (h, w, 3), dtype=np.uint8) for _ in range(3)]
p = SH9Projector(w, h)
p.project(frames[0])
ts = []
for i in range(n):
    t = time.perf_counter()
    p.project(frames[i % 3])
    ts.append(time.perf_counter() - t)
print(json.dumps(sorted(ts)[len(ts) // 2] * 1000))
"""


def library_beside_a_hog(n: int = 31, size=(1920, 960)) -> list[dict]:
    """``SH9Projector.project`` on 8-bit frames of ``size``, imported as a library, beside
    one process that spins on a core: BLAS's pool sized to one before numpy loads (the
    floor: what the command line does), as shipped (the engine limits its own calls), and
    with that limit taken out (what issue 33's audit measured: 16× on 2 cores)."""
    import json
    import subprocess
    base = {k: v for k, v in os.environ.items()
            if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}
    cases = [("BLAS pool sized to 1 before numpy loads", {"OPENBLAS_NUM_THREADS": "1"}, []),
             ("as a library (the engine's own limit)", {}, []),
             ("as a library, the limit taken out", {}, ["no-limit"])]
    hog = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        rows = []
        for label, extra, flag in cases:
            out = subprocess.run([sys.executable, "-c", _LIBRARY, str(size[0]), str(size[1]),
                                  str(n), *flag], env={**base, **extra}, capture_output=True,
                                 text=True, timeout=600, check=True).stdout
            rows.append({"case": label, "ms": float(json.loads(out.strip().splitlines()[-1]))})
    finally:
        hog.kill()
        hog.wait()
    for r in rows:
        r["ratio"] = r["ms"] / rows[0]["ms"]
    return rows


def write_library_beside_a_hog(rows: list[dict], out: Path) -> None:
    lines = ["# The library beside a CPU hog", "",
             f"`SH9Projector.project`, 1920×960 8-bit, imported as a library; one process spins "
             f"beside it; {os.cpu_count()} cores. Median ms per frame, and its ratio to the "
             "first row, measured in the same run (issue 33's target: the library within 1.5×).",
             "", "| case | ms/frame | × pool sized to 1 |", "|---|---:|---:|"]
    lines += [f"| {r['case']} | {r['ms']:.1f} | {r['ratio']:.2f} |" for r in rows]
    out.mkdir(parents=True, exist_ok=True)
    (out / "library_beside_a_hog.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


def _dirty_float_rows(frames, w, h, floor, cycles):
    """The exact float path on frames with 0.1 % bad samples (scattered, so every band of
    rows holds some: the worst case for the band-by-band clean-up): NaN, or half +inf and
    half negative. Error against the exact projection of the frame with them zeroed."""
    import numpy as np
    from ..core.geometry import sh
    from ..core.sh9.engine import SH9Projector
    proj = SH9Projector(w, h)
    rows = []
    for label, values in (("exact, 0.1 % NaN samples", (np.nan,)),
                          ("exact, 0.1 % +inf / negative samples", (np.inf, -0.5))):
        _progress(f"bench {w}×{h} float32 {label}")
        rng = np.random.default_rng(7)
        dirty, refs = [], []
        for _, f, _, _ in frames:
            d = f.copy()
            idx = rng.choice(d.size, d.size // 1000, replace=False)
            for k, v in enumerate(values):
                d.flat[idx[k::len(values)]] = v
            clean = d.copy()
            clean.flat[idx] = 0
            dirty.append(d)
            refs.append(_exact_float64(clean))
        ms = _median_ms_cycling(proj.project, dirty, cycles)
        errs = [sh.irradiance_error(proj.project(d).coefficients, r) for d, r in zip(dirty, refs)]
        rows.append(dict(size=f"{w}×{h}", dtype="float32", path=label, ms=ms, ratio=ms / floor,
                         floor_ms=floor, err_max=max(errs), err_mean=float(np.mean(errs)),
                         err_hdr=None))
    return rows


def _write_speed(rows, out, panoramas, args):
    import platform
    lines = [
        "# Speed against error (one core)",
        "",
        f"Command: `shlight bench{' --quick' if args.quick else ''}`; machine: "
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores (one used).",
        f"Frames: {', '.join(n for n, _ in panoramas)} (provider/data/hdri), resized to each size; "
        "uint8 frames are sRGB-encoded with auto exposure (median → 0.18), so suns clip.",
        "Timing: each call gets the next of these frames in turn, as live video delivers "
        "them (not one frame again and again, which the cache would flatter); the median call. "
        "Ratio: time ÷ `cv2.sumElems` on the same frames, same run. Error: relative RMS "
        "irradiance over the sphere of normals against the float64 exact projection of the same "
        "frame (max and mean over frames); 'vs HDR' adds what 8-bit capture itself loses.",
        "`--downsample` is withdrawn on equirect frames: its exact weights are separable, and "
        "the area average cost more than the exact pass at every size measured (1.25-1.9×, "
        "2026-11-22 and 11-26); the fisheye's fast path is in the edge section.",
        "",
        "| size | pixels | path | ms/frame | × floor | floor ms | error max | error mean | vs HDR (max) |",
        "|---|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        hdr = "" if r["err_hdr"] is None else f"{r['err_hdr'] * 100:.1f} %"
        lines.append(f"| {r['size']} | {r['dtype']} | {r['path']} | {r['ms']:.2f} | "
                     f"{r['ratio']:.1f} | {r['floor_ms']:.3f} | {r['err_max'] * 100:.3f} % | "
                     f"{r['err_mean'] * 100:.3f} % | {hdr} |")
    (out / "speed_vs_error.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib not installed: no plot (pip install matplotlib)", file=sys.stderr)
        return
    fig, ax = plt.subplots(figsize=(8, 5.5))
    markers = {"exact": "o", "fast /2": "s", "fast /4": "^", "fast /8": "v",
               "paper (sRGB 64×48)": "x"}
    colours = {}
    for r in rows:
        key = f"{r['size']} {r['dtype']}"
        colours.setdefault(key, f"C{len(colours)}")
        ax.scatter(r["ratio"], max(r["err_max"], 1e-7) * 100, marker=markers.get(r["path"], "o"),
                   color=colours[key], s=45)
    for key, c in colours.items():
        ax.scatter([], [], color=c, label=key)
    for path, m in markers.items():
        ax.scatter([], [], color="grey", marker=m, label=path)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.axhline(0.5, color="grey", ls=":", lw=1)
    ax.set_xlabel("time per frame ÷ reading the frame once (cv2.sumElems)")
    ax.set_ylabel("max relative RMS irradiance error (%)")
    ax.set_title("SH9 projection: speed against error (one core)")
    ax.legend(fontsize=7, ncol=2)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "speed_vs_error.png", dpi=110)
    plt.close(fig)
