"""Shared pieces of the examples: where the lighting comes from, and drawing a lit mesh.

Lighting sources (``open_lighting``)
------------------------------------
* ``ws://HOST:PORT/...`` (or ``wss://``): a running ``shlight serve``. A background thread
  keeps only the *latest* ``sh9`` message (its ``"matrices"``: 48 numbers, M_r, M_g, M_b,
  row-major) and reconnects with a growing back-off (0.5 s up to 5 s) whenever the
  connection drops.
* a panorama file (``.exr``, ``.hdr``, ``.png``, ...): :func:`provider.compute_sh9` once.

Every matrix here is in the wire frame (right-handed, +Y up) until a caller rotates it with
``M' = R̃ M R̃ᵀ`` (:func:`provider.rotate_matrices`).
"""
from __future__ import annotations

import json
import math
import os
import sys
import threading
from pathlib import Path

import numpy as np

# The examples run from a source checkout: make ``provider`` importable without installing.
_ROOT = Path(__file__).resolve().parent.parent
if str(_ROOT) not in sys.path:
    sys.path.insert(0, str(_ROOT))

from provider.verify import render  # noqa: E402
from provider.core.geometry.sh import irradiance_matrices  # noqa: E402


class LightingError(RuntimeError):
    """A user-facing problem with the lighting source (one line)."""


# -- lighting sources ---------------------------------------------------------------------------

class StaticLighting:
    """Lighting of one panorama file, computed once with ``compute_sh9``."""

    def __init__(self, path: str, **options):
        from provider import compute_sh9, InputError
        if not os.path.exists(path):
            raise LightingError(f"no such panorama: {path}")
        try:
            result = compute_sh9(path, **options)
        except InputError as exc:
            raise LightingError(f"cannot use {path} as lighting: {exc}") from None
        self.matrices = np.asarray(result.matrices, np.float64).reshape(3, 4, 4)
        self.coefficients = np.asarray(result.coefficients, np.float64)
        self.version = 1
        self.description = path

    def latest(self):
        """(matrices (3, 4, 4), version): the version changes when the lighting does."""
        return self.matrices, self.version

    def wait(self, timeout: float):  # noqa: ARG002 - same interface as LiveLighting
        return self.latest()

    def close(self) -> None:
        pass


class LiveLighting:
    """The newest lighting of a ``shlight serve`` provider, kept by a reconnecting thread."""

    def __init__(self, url: str, *, open_timeout: float = 3.0, max_backoff: float = 5.0):
        self.url, self.description = url, url
        self.open_timeout, self.max_backoff = open_timeout, max_backoff
        self.matrices = None
        self.version = 0            # increments with every sh9 message
        self.seq = None
        self.stale = False
        self.connected = False
        self.connections = 0        # successful connections so far (reconnects = this - 1)
        self.last_error = None
        self._cond = threading.Condition()
        self._stop = threading.Event()
        self._ws = None
        self._thread = threading.Thread(target=self._run, name="shlight-live", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        from websockets.sync.client import connect
        backoff = 0.5
        while not self._stop.is_set():
            try:
                with connect(self.url, open_timeout=self.open_timeout, close_timeout=1) as ws:
                    self._ws = ws
                    self.connected, backoff = True, 0.5
                    self.connections += 1
                    for text in ws:
                        self._on_message(text)
                        if self._stop.is_set():
                            break
            except Exception as exc:  # noqa: BLE001 - any network failure means: reconnect
                self.last_error = f"{type(exc).__name__}: {exc}"
            finally:
                self._ws, self.connected = None, False
            if self._stop.wait(backoff):
                break
            backoff = min(self.max_backoff, backoff * 2)

    def _on_message(self, text) -> None:
        try:
            msg = json.loads(text)
        except (ValueError, TypeError):
            return
        if not isinstance(msg, dict) or msg.get("type") != "sh9":
            return
        m = msg.get("matrices")
        if not isinstance(m, list) or len(m) != 48:
            return
        with self._cond:
            self.matrices = np.asarray(m, np.float64).reshape(3, 4, 4)
            self.seq, self.stale = msg.get("seq"), bool(msg.get("stale", False))
            self.version += 1
            self._cond.notify_all()

    def latest(self):
        """(matrices (3, 4, 4) or None before the first message, version)."""
        with self._cond:
            return self.matrices, self.version

    def wait(self, timeout: float):
        """Block until a first message arrived; :class:`LightingError` after ``timeout`` s."""
        with self._cond:
            if not self._cond.wait_for(lambda: self.matrices is not None, timeout):
                why = f" (last error: {self.last_error})" if self.last_error else ""
                raise LightingError(f"no lighting from {self.url} within {timeout:g} s{why}; "
                                    "is `shlight serve` running there?")
            return self.matrices, self.version

    def close(self) -> None:
        self._stop.set()
        ws = self._ws
        if ws is not None:
            try:
                ws.close()
            except Exception:  # noqa: BLE001
                pass
        self._thread.join(timeout=3)


def open_lighting(spec: str):
    """A ws:// URL -> :class:`LiveLighting`; anything else is a panorama file."""
    if spec.startswith(("ws://", "wss://")):
        return LiveLighting(spec)
    return StaticLighting(spec)


def uniform_matrices(radiance: float = 1.0) -> np.ndarray:
    """Irradiance matrices of a uniform environment (E = π·radiance on every normal)."""
    c = np.zeros((9, 3))
    c[0] = radiance * math.sqrt(4 * math.pi)
    return irradiance_matrices(c)


def auto_exposure(matrices, target: float = 0.6) -> float:
    """Exposure that maps the sphere-average white radiance ρE/π (ρ = 1) to ``target``.

    The average of E over all normals is the constant part of ñᵀMñ averaged over the sphere:
    M33 + (M00 + M11 + M22)/3.
    """
    m = np.asarray(matrices, np.float64).reshape(3, 4, 4)
    mean_e = m[:, 3, 3] + (m[:, 0, 0] + m[:, 1, 1] + m[:, 2, 2]) / 3.0
    luminance = float(np.dot([0.2126, 0.7152, 0.0722], mean_e)) / math.pi
    return target / luminance if luminance > 1e-12 else 1.0


# -- drawing ------------------------------------------------------------------------------------

MESHES = ("sphere", "torus")


def mesh_data(name: str):
    """(positions, normals, indices, resting height): the mesh in object space (+Y up),
    with its lowest point at y = -resting height (so translating by it sets it on a plane)."""
    if name == "sphere":
        p, n, i = render.uv_sphere(96, 48)
        return p, n, i, 1.0
    if name == "torus":
        p, n, i = render.torus()
        return p, n, i, 0.3
    raise ValueError(f"mesh must be one of {MESHES}; got {name!r}")


class LitMeshRenderer:
    """Draws meshes with the shipped program (shaders/lit_diffuse.vert/.frag, which
    includes shaders/sh9_irradiance.glsl) into an RGBA framebuffer, 4× MSAA where available.

    ``draw(...)`` takes ``model`` (object -> the frame the lighting matrices are in) and
    ``view_projection`` (that frame -> clip). Alpha is coverage: 0 where nothing was drawn.
    """

    def __init__(self, ctx, size, samples: int = 4):
        self.ctx = ctx
        self.program = render.lit_diffuse_program(ctx)
        self._vaos = {}
        self.resize(size, samples)

    def resize(self, size, samples: int = 4) -> None:
        self.size = (int(size[0]), int(size[1]))
        samples = min(samples, self.ctx.max_samples)
        ctx = self.ctx
        self.fbo = ctx.framebuffer(color_attachments=[ctx.texture(self.size, 4)],
                                   depth_attachment=ctx.depth_renderbuffer(self.size))
        self.msaa = None
        if samples > 1:
            try:
                self.msaa = ctx.framebuffer(
                    color_attachments=[ctx.renderbuffer(self.size, 4, samples=samples)],
                    depth_attachment=ctx.depth_renderbuffer(self.size, samples=samples))
            except Exception:  # noqa: BLE001 - no MSAA: aliased edges, still correct
                self.msaa = None

    def vao(self, mesh: str):
        if mesh not in self._vaos:
            p, n, i, _ = mesh_data(mesh)
            self._vaos[mesh] = render.mesh_vertex_array(self.ctx, self.program, p, n, i)
        return self._vaos[mesh]

    def begin(self, target=None) -> None:
        """Bind and clear the target (default: the offscreen framebuffer)."""
        import moderngl
        fbo = target or self.msaa or self.fbo
        fbo.use()
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        self.ctx.enable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        self._target = fbo

    def draw(self, mesh: str, model, view_projection, matrices, *, albedo=(0.8, 0.8, 0.8),
             exposure: float = 1.0, tone_map: str = "reinhard", srgb: bool = True) -> None:
        prog = self.program
        model = np.asarray(model, np.float64)
        normal_matrix = np.linalg.inv(model[:3, :3]).T
        render.write_matrix(prog, "model", model)
        render.write_matrix(prog, "viewProjection", view_projection)
        render.write_matrix(prog, "normalMatrix", normal_matrix)
        render.set_irradiance_matrices(prog, matrices)
        render.set_uniform(prog, "albedo", tuple(float(a) for a in albedo))
        render.set_uniform(prog, "exposure", float(exposure))
        render.set_uniform(prog, "toneMap", render.TONE_MAPS[tone_map])
        render.set_uniform(prog, "srgbOutput", bool(srgb))
        self.vao(mesh).render()

    def read_rgba(self) -> np.ndarray:
        """The offscreen result as (H, W, 4) uint8, top row first, RGB premultiplied by alpha."""
        if self._target is self.msaa:
            self.ctx.copy_framebuffer(self.fbo, self.msaa)
        w, h = self.size
        data = self.fbo.read(components=4, alignment=1)
        return np.frombuffer(data, np.uint8).reshape(h, w, 4)[::-1].copy()


def read_screen(ctx, size) -> np.ndarray:
    """The default framebuffer (a window) as (H, W, 3) uint8 RGB, top row first."""
    w, h = size
    data = ctx.screen.read(components=3, alignment=1)
    return np.frombuffer(data, np.uint8).reshape(h, w, 3)[::-1].copy()
