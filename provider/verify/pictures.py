"""Validation pictures: objects lit by the SH9 shader beside a brute-force irradiance reference.

For one equirect panorama: a sphere and a torus rendered with shaders/lit_diffuse.* (white
albedo, so each pixel is E(n)/π of the SH9 matrices), the same pixels lit by brute-force
irradiance E(n) = Σ L(ω) max(0, n·ω) dω summed straight from the (block-summed) panorama at the
very normal the shader used, and a heat map of their difference. Both images go through the
same display transform (exposure, Reinhard, sRGB), so what differs is SH9 itself: the
order-2 truncation (1-7.5 % RMS on real scenes, docs/contract.md §5) and the clamp where it rings.
"""
from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np

from ..core.geometry import sh
from ..core.sh9.engine import compute_sh9
from ..core.radiometry.images import read_image
from ..core.geometry.projections import Equirect
from .render import (lit_diffuse_program, look_at, mesh_vertex_array, perspective,
                     set_irradiance_matrices, set_uniform, shader_source, srgb_encode, tone_map,
                     torus, uv_sphere, write_matrix, expand_includes, load_program,
                     upload_lights)

#: Heat-map scale: this relative error (of the object's mean radiance) is the top colour.
HEAT_MAP_MAX = 0.2
#: Brute-force reference grid (width; height is half): 64×32 blocks of 5.6°.
REFERENCE_WIDTH = 64

_NORMAL_FRAG = """#version 330 core
in vec3 worldNormal;
out vec4 fragColor;
void main() { fragColor = vec4(normalize(worldNormal), 1.0); }
"""


# -- brute-force reference ------------------------------------------------------------------------

def panorama_flux(image: np.ndarray, width: int = REFERENCE_WIDTH):
    """Block-summed radiance × solid angle of an equirect: (directions (B, 3), flux (B, 3)).

    Negative and non-finite samples count as 0 (as in the engine). Each block's flux sits at
    its flux-weighted mean direction (so a sun keeps its position inside the block); with
    64×32 blocks the reference stays within 0.1 % RMS (0.3 % max) of the full-resolution sum on the
    bundled panoramas, the sunny one included.
    """
    img = np.asarray(image, np.float64)
    img = np.where(np.isfinite(img) & (img > 0), img, 0.0)
    h, w = img.shape[:2]
    width = min(width, w)
    height = max(1, width // 2)
    pano = Equirect(w, h)
    flux = img * pano.solid_angle[..., None]
    weight = flux.sum(axis=-1, keepdims=True)
    moment = weight * pano.directions()            # direction × flux, for block centroids
    small = _block_sum(np.concatenate([flux, moment], axis=-1), width, height)
    dirs = small[..., 3:].reshape(-1, 3)
    norm = np.linalg.norm(dirs, axis=-1, keepdims=True)
    centres = Equirect(width, height).directions().reshape(-1, 3)
    dirs = np.where(norm > 0, dirs / np.where(norm > 0, norm, 1.0), centres)
    return dirs, small[..., :3].reshape(-1, 3)


def _block_sum(values: np.ndarray, width: int, height: int) -> np.ndarray:
    """Sum (H, W, C) over a (height, width) grid of blocks."""
    h, w, c = values.shape
    if w % width == 0 and h % height == 0:
        return values.reshape(height, h // height, width, w // width, c).sum(axis=(1, 3))
    # area resize averages; times the pixel ratio it sums
    return cv2.resize(values, (width, height), interpolation=cv2.INTER_AREA) * (w * h / (width * height))


def brute_force_irradiance(directions, flux, normals, chunk: int = 8192) -> np.ndarray:
    """E(n) = Σ_b flux_b max(0, n·ω_b) at unit ``normals`` (N, 3) -> (N, 3) float64."""
    n = np.asarray(normals, np.float32).reshape(-1, 3)
    d = np.asarray(directions, np.float32)
    f = np.asarray(flux, np.float64)
    out = np.empty((len(n), 3))
    for i in range(0, len(n), chunk):
        kernel = np.maximum(n[i:i + chunk] @ d.T, 0.0).astype(np.float64)
        out[i:i + chunk] = kernel @ f
    return out


# -- rendering --------------------------------------------------------------------------------------

class ObjectRenderer:
    """Renders a mesh twice with one camera: SH9-lit radiance (lit_diffuse) and world normals."""

    def __init__(self, ctx, size: int = 256):
        self.ctx, self.size = ctx, size
        self.lit = lit_diffuse_program(ctx)
        self.normal = ctx.program(vertex_shader=expand_includes(shader_source("lit_diffuse.vert")),
                                  fragment_shader=_NORMAL_FRAG)
        self.meshes = {"sphere": uv_sphere(96, 48), "torus": torus()}
        self.eye = eye = np.array([0.0, 1.2, 3.0])   # on +Z, a little above the objects
        self.view_projection = perspective(40.0, 1.0, 0.1, 20.0) @ look_at(eye)
        tilt = sh.rotation_from_euler(0, 35, 0)
        self.models = {"sphere": np.eye(4), "torus": np.eye(4)}
        self.models["torus"][:3, :3] = tilt

    def render(self, name: str):
        """(radiance (S, S, 3) = E/π clamped, normals (S, S, 3), mask (S, S)), top row first."""
        ctx, s = self.ctx, self.size
        pos, nrm, idx = self.meshes[name]
        model = self.models[name]
        color = ctx.texture((s, s), 4, dtype="f4")
        depth = ctx.depth_renderbuffer((s, s))
        fbo = ctx.framebuffer(color_attachments=[color], depth_attachment=depth)
        images = []
        try:
            fbo.use()
            ctx.enable(ctx.DEPTH_TEST | ctx.CULL_FACE)   # meshes are counter-clockwise
            for prog in (self.lit, self.normal):
                write_matrix(prog, "model", model)
                write_matrix(prog, "viewProjection", self.view_projection)
                write_matrix(prog, "normalMatrix", np.linalg.inv(model[:3, :3]).T)
                vao = mesh_vertex_array(ctx, prog, pos, nrm, idx)
                fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
                vao.render()
                images.append(np.frombuffer(fbo.read(components=4, dtype="f4"), np.float32)
                              .reshape(s, s, 4)[::-1].copy())
                vao.release()
            ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE)
        finally:
            for obj in (fbo, color, depth):
                obj.release()
        return images[0][..., :3], images[1][..., :3], images[1][..., 3] > 0.5

    def set_lighting(self, matrices) -> None:
        set_irradiance_matrices(self.lit, matrices)
        set_uniform(self.lit, "albedo", (1.0, 1.0, 1.0))
        set_uniform(self.lit, "exposure", 1.0)
        set_uniform(self.lit, "toneMap", 0)
        set_uniform(self.lit, "srgbOutput", False)


# -- composing --------------------------------------------------------------------------------------

def _display(radiance, exposure):
    """Linear radiance -> 8-bit sRGB after exposure and Reinhard (same for both images)."""
    return np.round(srgb_encode(tone_map(radiance * exposure, "reinhard")) * 255).astype(np.uint8)


def _label(img, text, scale=0.45):
    """White text on a darkened strip at the top of a panel (readable on any background)."""
    img[:24] = (img[:24].astype(np.uint16) * 2 // 5).astype(np.uint8)
    cv2.putText(img, text, (6, 17), cv2.FONT_HERSHEY_SIMPLEX, scale, (255, 255, 255), 1,
                cv2.LINE_AA)
    return img


def _heat(rel, mask):
    v = np.clip(rel / HEAT_MAP_MAX, 0, 1)
    bgr = cv2.applyColorMap(np.round(v * 255).astype(np.uint8), cv2.COLORMAP_INFERNO)
    bgr[~mask] = 40
    return np.ascontiguousarray(bgr[..., ::-1])  # to RGB


def _colour_bar(width, height=28):
    ramp = np.tile(np.linspace(0, 255, width).astype(np.uint8), (10, 1))
    bar = np.full((height, width, 3), 24, np.uint8)
    bar[2:12] = cv2.applyColorMap(ramp, cv2.COLORMAP_INFERNO)[..., ::-1]
    for frac in (0.0, 0.5, 1.0):
        x = int(frac * (width - 1))
        text = f"{frac * HEAT_MAP_MAX:.0%}"
        tx = min(max(x - 12, 2), width - 40)
        cv2.putText(bar, text, (tx, 25), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (230, 230, 230), 1,
                    cv2.LINE_AA)
    return bar


def validation_picture(renderer: ObjectRenderer, image: np.ndarray, title: str):
    """(RGB uint8 picture, statistics) for one panorama."""
    result = compute_sh9(image, error_estimate=False)
    dirs, flux = panorama_flux(image)
    renderer.set_lighting(result.matrices)
    s = renderer.size
    rows, stats = [], {}
    lit = {}
    for name in ("sphere", "torus"):
        shader, normals, mask = renderer.render(name)
        ref = np.zeros_like(shader, dtype=np.float64)
        ref[mask] = brute_force_irradiance(dirs, flux, normals[mask]) / math.pi
        lit[name] = (shader.astype(np.float64), ref, mask)
    # One exposure for the whole picture: the mean reference radiance maps to 0.5.
    mean_ref = np.mean(np.concatenate([lit[n][1][lit[n][2]] for n in lit]))
    exposure = 0.5 / max(mean_ref, 1e-12)
    for name, (shader, ref, mask) in lit.items():
        rel = (np.abs(shader - ref).mean(axis=-1) / max(ref[mask].mean(), 1e-12))
        rms = sh.relative_rms(shader[mask], ref[mask])
        stats[f"{name}_rms_rel"] = rms
        stats[f"{name}_max_rel"] = float(rel[mask].max())
        panels = [_display(shader, exposure), _display(ref, exposure), _heat(rel, mask)]
        for p in panels:
            p[~mask] = 40
        _label(panels[0], f"{name}: SH9 shader")
        _label(panels[1], "brute-force reference")
        _label(panels[2], f"|SH9 - reference|: RMS {rms:.1%}")
        rows.append(np.hstack(panels))
    # docs/contract.md §5's measure: over the whole sphere of normals, not only the visible ones.
    stats["all_normals_rms_rel"] = sh.relative_rms(
        np.maximum(sh.irradiance_from_matrices(result.matrices, sh.SPHERE_NORMALS), 0.0),
        brute_force_irradiance(dirs, flux, sh.SPHERE_NORMALS))
    pano = cv2.resize(np.asarray(image, np.float32), (3 * s, 3 * s // 2), interpolation=cv2.INTER_AREA)
    pano = _display(np.maximum(pano, 0), exposure)
    _label(pano, f"{title}: panorama (centre looks along -Z), exposure {exposure:.3g}")
    picture = np.vstack([pano, *rows, _colour_bar(3 * s)])
    return picture, stats


def write_validation_pictures(ctx, panoramas, out_dir: Path, size: int = 256) -> list[dict]:
    """One PNG per panorama in ``out_dir``; returns per-picture statistics."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    renderer = ObjectRenderer(ctx, size)
    out = []
    for path in panoramas:
        path = Path(path)
        picture, stats = validation_picture(renderer, read_image(path), path.stem)
        file = out_dir / f"{path.stem}.png"
        cv2.imwrite(str(file), picture[..., ::-1])
        out.append({"file": str(file), "panorama": str(path), **stats})
    return out


# -- what lights change (provider.verify.lights, shaders/lit_diffuse_lights.frag) ----------------

class LightsObjectRenderer(ObjectRenderer):
    """:class:`~provider.verify.pictures.ObjectRenderer` with shaders/lit_diffuse_lights.frag."""

    def __init__(self, ctx, size: int = 256):
        super().__init__(ctx, size)
        self.lit = load_program(ctx, "lit_diffuse.vert", "lit_diffuse_lights.frag")

    def set_lights(self, ambient_matrices, directions, irradiance) -> None:
        self.set_lighting(ambient_matrices)
        upload_lights(self.lit, directions, irradiance)


def lights_picture(ctx, image: np.ndarray, title: str, size: int = 256):
    """(RGB uint8 picture, statistics): SH9 alone vs ambient + lights vs brute force.

    The panorama (lights marked), then per object (sphere, torus) the SH9 shader, the
    ambient + lights shader and the brute-force reference, and under them the two error
    heat maps (same scale as the SH9 pictures).
    """
    result = compute_sh9(image, error_estimate=False, lights="auto")
    d = np.array([light.direction for light in result.lights]).reshape(-1, 3)
    irr = np.array([light.irradiance for light in result.lights]).reshape(-1, 3)
    dirs, flux = panorama_flux(image)
    plain, lit = ObjectRenderer(ctx, size), LightsObjectRenderer(ctx, size)
    plain.set_lighting(result.matrices)
    lit.set_lights(result.ambient_matrices, d, irr)
    renders = {}
    for name in ("sphere", "torus"):
        sh9, normals, mask = plain.render(name)
        both, _, _ = lit.render(name)
        ref = np.zeros_like(sh9, dtype=np.float64)
        ref[mask] = brute_force_irradiance(dirs, flux, normals[mask]) / math.pi
        renders[name] = (sh9.astype(np.float64), both.astype(np.float64), ref, mask)
    mean_ref = np.mean(np.concatenate([r[2][r[3]] for r in renders.values()]))
    exposure = 0.5 / max(mean_ref, 1e-12)
    rows, stats = [], {"lights": len(d)}
    for name, (sh9, both, ref, mask) in renders.items():
        panels, heat = [], []

        def panel(radiance, text):
            img = _display(radiance, exposure)
            img[~mask] = 40
            return _label(img, text)
        for key, label, shown in (("sh9", "SH9 alone", sh9),
                                  ("lights", f"ambient + {len(d)} light(s)", both)):
            rel = np.abs(shown - ref).mean(axis=-1) / max(ref[mask].mean(), 1e-12)
            rms = sh.relative_rms(shown[mask], ref[mask])
            stats[f"{name}_{key}_rms_rel"] = rms
            panels.append(panel(shown, f"{name}: {label}"))
            heat.append(_label(_heat(rel, mask), f"|{label} - reference|: RMS {rms:.1%}"))
        panels.append(panel(ref, "brute-force reference"))
        note = np.full_like(heat[0], 40)
        _label(note, "heat: |shader - reference| / mean", 0.4)
        rows += [np.hstack(panels), np.hstack(heat + [note])]
    # Over the whole sphere of normals (docs/contract.md §5's measure).
    truth = brute_force_irradiance(dirs, flux, sh.SPHERE_NORMALS)
    stats["all_normals_sh9_rms_rel"] = sh.relative_rms(
        np.maximum(result.irradiance(sh.SPHERE_NORMALS), 0.0), truth)
    stats["all_normals_lights_rms_rel"] = sh.relative_rms(
        np.maximum(result.irradiance_with_lights(sh.SPHERE_NORMALS), 0.0), truth)
    s = size
    pano = cv2.resize(np.asarray(image, np.float32), (3 * s, 3 * s // 2),
                      interpolation=cv2.INTER_AREA)
    pano = _display(np.maximum(pano, 0), exposure)
    for dk in d:      # mark each light: u = φ/2π + 0.5, v = θ/π (docs/contract.md §1)
        u = math.atan2(dk[0], -dk[2]) / (2 * math.pi) + 0.5
        v = math.acos(max(-1.0, min(1.0, float(dk[1])))) / math.pi
        cv2.drawMarker(pano, (int(u * 3 * s), int(v * 3 * s // 2)), (0, 255, 255),
                       cv2.MARKER_CROSS, 28, 2)
    _label(pano, f"{title}: + = light found; sphere of normals: SH9 "
                 f"{stats['all_normals_sh9_rms_rel']:.1%}, ambient + lights "
                 f"{stats['all_normals_lights_rms_rel']:.1%} RMS")
    return np.vstack([pano, *rows, _colour_bar(3 * s)]), stats


def write_lights_picture(ctx, panoramas, out_dir: Path, size: int = 256) -> dict | None:
    """The picture of the panorama where lights help most (largest SH9 → ambient + lights
    error drop: the sun of sky.exr among the bundled ones), as ``lights_NAME.png``."""
    best = None
    for path in panoramas:
        r = compute_sh9(read_image(path), lights="auto")
        gain = r.stats["sh9_error"] - r.stats["light_error"]
        if r.lights and (best is None or gain > best[0]):
            best = (gain, Path(path))
    if best is None:
        return None
    path = best[1]
    picture, stats = lights_picture(ctx, read_image(path), path.stem, size)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    file = out_dir / f"lights_{path.stem}.png"
    cv2.imwrite(str(file), picture[..., ::-1])
    return {"file": str(file), "panorama": str(path), **stats}
