"""``--sections environment``: the reflection cube's cost, error and bytes.

* **Cost**: one cube update of a 1920×960 8-bit frame (decode, work image, overlap, pyramid,
  prefilter) for sizes 16, 32, 64, as ratios to the SH9 path of the same frames and to the
  floor (``cv2.sumElems``, reading the frame once), measured side by side in one run; and
  what a projector costs to build (once per frame size).
* **Error** against a float64 brute force of the same definitions over every pixel of each
  real panorama (docs/contract.md §12): mip 0 per-texel relative error (median) against
  super-sampled texel means, each prefiltered mip's relative RMS against PF at its texel
  centres, per size and roughness; and the cube's cosine-convolved irradiance against
  brute-force irradiance beside SH9's.
* **Bytes** per update and per second at 1,000 subscribers at 1 Hz
  (:mod:`provider.bench.environment_transport`).

Written to ``environment.md`` and ``environment.png``.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from .common import _progress, _to_srgb8, _auto_exposure


def _equirect(width, height):
    v = (np.arange(height) + 0.5) / height
    u = (np.arange(width) + 0.5) / width
    theta, phi = np.pi * v[:, None], 2 * np.pi * (u[None, :] - 0.5)
    d = np.stack(np.broadcast_arrays(np.sin(phi) * np.sin(theta), np.cos(theta),
                                     -np.cos(phi) * np.sin(theta)), axis=-1)
    edges = np.pi * np.arange(height + 1) / height
    omega = (2 * np.pi / width) * (np.cos(edges[:-1]) - np.cos(edges[1:]))
    return d, np.broadcast_to(omega[:, None], (height, width))


def brute_prefiltered(image, directions, roughness, chunk=8):
    """Float64 PF over every pixel of an equirect ``image`` at unit ``directions`` (T, 3).

    With n = v = r, cos²θ_h = (1 + r·l)/2, so D(h)⟨r·l⟩ ∝ max(r·l, 0)/(A + B r·l)², A =
    (1 + α²)/2, B = (α² − 1)/2 (the constant α²/π cancels): one product r·l per pair, in
    chunks that stay in cache."""
    h, w = image.shape[:2]
    d, omega = _equirect(w, h)
    lt = np.ascontiguousarray(d.reshape(-1, 3).T)
    om = omega.reshape(-1)
    rhs = np.concatenate([image.reshape(-1, 3).astype(np.float64) * om[:, None], om[:, None]],
                         axis=1)
    a2 = roughness ** 4
    A, B = (1 + a2) / 2, (a2 - 1) / 2
    out = np.empty((len(directions), 3))
    for k in range(0, len(directions), chunk):
        rl = directions[k:k + chunk] @ lt
        den = A + B * rl
        den *= den
        np.maximum(rl, 0, out=rl)
        rl /= den
        s = rl @ rhs
        out[k:k + chunk] = s[:, :3] / s[:, 3:]
    return out


def brute_texel_means(image, n, supersample=4):
    """Float64 solid-angle-weighted mean of an equirect ``image`` over each texel."""
    from ..core.geometry import cubemap
    h, w = image.shape[:2]
    d, omega = _equirect(w * supersample, h * supersample)
    rows = np.arange(h * supersample) // supersample
    cols = np.arange(w * supersample) // supersample
    px = image[rows][:, cols].reshape(-1, 3).astype(np.float64)
    face, i, j, _, _ = cubemap.direction_to_texel(d.reshape(-1, 3), n)
    t = cubemap.flat_index(face, i, j, n)
    om = omega.reshape(-1)
    area = np.bincount(t, weights=om, minlength=6 * n * n)
    return np.stack([np.bincount(t, weights=om * px[:, c], minlength=6 * n * n)
                     for c in range(3)], -1) / area[:, None]


def _rel_rms(a, b):
    return float(np.sqrt(np.mean((a - b) ** 2)) / np.sqrt(np.mean(b ** 2)))


def errors(images: dict, sizes=(16, 32, 64)) -> list[dict]:
    """Per (panorama, size): mip 0 median texel error, each mip's relative RMS, and the
    cube's and SH9's irradiance errors against brute force."""
    from ..core.geometry import cubemap, sh
    from ..core.sh9.engine import compute_sh9
    from ..core.reflections.environment import compute_environment
    normals = sh.fibonacci_sphere(256)
    rows = []
    for name, img in images.items():
        d, omega = _equirect(img.shape[1], img.shape[0])
        kernel = np.maximum(normals @ d.reshape(-1, 3).T, 0) * omega.reshape(-1)
        truth = kernel @ img.reshape(-1, 3).astype(np.float64)
        sh9_err = _rel_rms(compute_sh9(img).irradiance(normals), truth)
        for n in sizes:
            env = compute_environment(img, size=n)
            want = brute_texel_means(img, n)
            rel = np.abs(env.mips[0].reshape(-1, 3) - want) / np.maximum(np.abs(want), 1e-6)
            mips = []
            for k in range(1, len(env.mips)):
                m = env.mips[k].shape[1]
                ref = brute_prefiltered(img, cubemap.texel_directions(m).reshape(-1, 3),
                                        env.roughness[k])
                mips.append((env.roughness[k], _rel_rms(env.mips[k].reshape(-1, 3), ref)))
            rows.append(dict(name=name, size=n, mip0_median=float(np.median(rel)), mips=mips,
                             cube_irradiance=_rel_rms(env.irradiance(normals), truth),
                             sh9_irradiance=sh9_err))
            _progress(f"  {name} {n}²: mip0 {np.median(rel) * 100:.2f} %, worst mip "
                      f"{max(e for _, e in mips) * 100:.2f} %")
    return rows


def costs(images: dict, sizes=(16, 32, 64), repeat=5) -> list[dict]:
    """Cube update and SH9 path per 1920×960 8-bit frame, side by side, with the floor."""
    import cv2
    from ..core.sh9.engine import SH9Projector
    from ..core.reflections.environment import EnvironmentProjector
    frames = []
    for img in list(images.values())[:4]:
        big = cv2.resize(np.maximum(img, 0), (1920, 960), interpolation=cv2.INTER_LINEAR)
        frames.append(_to_srgb8(big, _auto_exposure(big)))
    sh9 = SH9Projector(1920, 960)
    rows = []
    for n in sizes:
        t0 = time.perf_counter()
        env = EnvironmentProjector(1920, 960, size=n)
        build = time.perf_counter() - t0
        # Interleaved, frame by frame, so that a noisy neighbour slows all alike. "shared":
        # SH9's pass also fills the cube's work image (what `serve` does when a cube is
        # due), then the cube is made from it; its cost is what it adds to SH9 alone.
        work = {}

        def sh9_sharing(f):
            work["w"] = env.new_work(sh9)
            sh9.project(f, work=work["w"])

        runs = {"floor": cv2.sumElems, "sh9": sh9.project, "cube": env.project,
                "sh9_sharing": sh9_sharing, "cube_shared": lambda f: env.project(f, work=work["w"])}
        times = {k: [] for k in runs}
        for fn in runs.values():
            fn(frames[0])
        for _ in range(repeat):
            for f in frames:
                for k, fn in runs.items():
                    t1 = time.perf_counter()
                    fn(f)
                    times[k].append(time.perf_counter() - t1)
        t = {k: np.array(v) for k, v in times.items()}
        floor, sh9_ms, cube_ms = (float(np.median(t[k])) * 1e3 for k in ("floor", "sh9", "cube"))
        ratio = float(np.median(t["cube"] / t["sh9"]))
        shared = t["sh9_sharing"] - t["sh9"] + t["cube_shared"]
        rows.append(dict(size=n, cube_ms=cube_ms, sh9_ms=sh9_ms, floor_ms=floor,
                         ratio=ratio, shared_ms=float(np.median(shared)) * 1e3,
                         shared_ratio=float(np.median(shared / t["sh9"])),
                         build_s=build, nnz=env.nnz))
        _progress(f"  {n}²: cube {cube_ms:.1f} ms = {ratio:.2f} × SH9 ({sh9_ms:.1f} ms); "
                  f"sharing SH9's decode {rows[-1]['shared_ratio']:.2f} ×; built in {build:.1f} s")
    return rows


def bench_environment(hdri: list, out: Path, args) -> None:
    from ..core.radiometry.images import read_image
    from .environment_transport import markdown, transport_bytes
    paths = list(hdri)
    images = {p.stem: np.where(np.isfinite(x := read_image(p)) & (x > 0), x, 0)
              .astype(np.float32) for p in paths}
    sizes = (16, 32) if args.quick else (16, 32, 64)
    err_images = dict(list(images.items())[:3]) if args.quick else images
    _progress("environment: cost per update (1920×960 8-bit)")
    cost = costs(images, sizes, repeat=2 if args.quick else 5)
    _progress("environment: error against float64 brute force")
    err = errors(err_images, sizes)
    traffic = transport_bytes(sizes)
    _write(out, cost, err, traffic, markdown(traffic))


def _write(out: Path, cost, err, traffic, traffic_md) -> None:
    lines = ["# Reflection cube: cost, error, bytes", "",
             "Cost: one update of a 1920×960 8-bit frame, median of several frames, one core; "
             "× SH9: the median ratio to the SH9 path of the same frame, timed "
             "alternately in the same run; × floor: "
             "`cv2.sumElems` on the same frames. Alone: the cube decodes the frame itself; "
             "sharing: SH9's pass fills the cube's work image on its way (what `serve` does "
             "when a cube is due) and the cost is what the cube adds to SH9 alone.", "",
             "| size | alone ms | alone × SH9 | sharing ms | sharing × SH9 | × floor (alone) "
             "| SH9 ms | operator non-zeros | build s |",
             "|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in cost:
        lines.append(f"| {r['size']}² | {r['cube_ms']:.1f} | {r['ratio']:.2f} | "
                     f"{r['shared_ms']:.1f} | {r['shared_ratio']:.2f} | "
                     f"{r['cube_ms'] / r['floor_ms']:.0f} | {r['sh9_ms']:.1f} | {r['nnz']:,} | "
                     f"{r['build_s']:.1f} |")
    lines += ["", "Error against a float64 brute force over every panorama pixel (docs/contract.md "
              "§12): mip 0 median per-texel error; each prefiltered mip's relative RMS at its "
              "texel centres (roughness in brackets); irradiance: relative RMS over 256 "
              "normals, the cube's (mip 0, cosine-convolved) beside SH9's.", "",
              "| panorama | size | mip 0 median | prefiltered mips (roughness: error) | "
              "cube E | SH9 E |", "|---|---:|---:|---|---:|---:|"]
    for r in err:
        mips = ", ".join(f"{g:.2f}: {e * 100:.2f} %" for g, e in r["mips"])
        lines.append(f"| {r['name']} | {r['size']}² | {r['mip0_median'] * 100:.2f} % | {mips} | "
                     f"{r['cube_irradiance'] * 100:.2f} % | {r['sh9_irradiance'] * 100:.2f} % |")
    lines += ["", "Bytes (RGBA16F KTX2 with all mips; WebSocket: the JSON message and the "
              "binary frame), at 1,000 subscribers at 1 Hz:", "", traffic_md, ""]
    (out / "environment.md").write_text("\n".join(lines))
    _plot(out, cost, err)
    _progress(f"wrote {out / 'environment.md'} and {out / 'environment.png'}")


def _plot(out: Path, cost, err) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    for n in sorted({r["size"] for r in err}):
        rs = [r for r in err if r["size"] == n]
        rough = [g for g, _ in rs[0]["mips"]]
        worst = [max(r["mips"][k][1] for r in rs) * 100 for k in range(len(rough))]
        mean = [np.mean([r["mips"][k][1] for r in rs]) * 100 for k in range(len(rough))]
        line, = a.plot(rough, mean, "o-", label=f"{n}² mean")
        a.plot(rough, worst, "x--", color=line.get_color(), label=f"{n}² worst")
    a.axhline(3, color="grey", lw=0.8, ls=":")
    a.set_xlabel("perceptual roughness of the mip")
    a.set_ylabel("relative RMS error against brute force (%)")
    a.set_title("prefiltered mips, real panoramas")
    a.legend(fontsize=8)
    x = np.arange(len(cost))
    b.bar(x - 0.2, [r["ratio"] for r in cost], 0.4, label="cube decodes the frame itself")
    b.bar(x + 0.2, [r["shared_ratio"] for r in cost], 0.4, label="sharing SH9's decode")
    b.set_xticks(x, [f"{r['size']}²" for r in cost])
    b.legend(fontsize=8)
    b.axhline(2, color="grey", lw=0.8, ls=":")
    b.set_ylabel("cube update ÷ SH9 path (same frames)")
    b.set_title("cost, 1920×960 8-bit frame")
    fig.tight_layout()
    fig.savefig(out / "environment.png", dpi=110)
    plt.close(fig)
