#!/usr/bin/env python3
"""AR composite: a virtual object on an ArUco marker, lit by live SH9 room lighting.

The OpenCV + OpenGL renderer of Alipour & Schulze, as a working example: read a camera,
a video or an image; find an ArUco marker (cv2.aruco); estimate its pose (cv2.solvePnP);
draw a mesh standing on it with the shipped GLSL (shaders/lit_diffuse.vert/.frag, which
include shaders/sh9_irradiance.glsl); composite it over the frame; show it in a window or
write an image or a video.

    # lighting from a running provider (`shlight serve`), camera 0, a window
    python examples/ar_composite.py --input 0 --lighting ws://127.0.0.1:8765/
    # lighting from a panorama, a photo in, a photo out (headless: EGL, no display needed)
    python examples/ar_composite.py --input photo.jpg --lighting room.exr --output out.png

Frames (read this before changing a sign)
-----------------------------------------
* Lighting ("probe") frame: the wire frame, right-handed, +Y up (docs/contract.md §1); the
  panorama centre looks along -Z, u = 0.75 along +X.
* Marker frame (OpenCV/ArUco): origin at the marker centre, x along the printed marker's
  right edge direction, y toward its top edge, z out of the printed face.
* Anchor: the marker lies flat (face up) and the probe stands on it: probe +Y = marker +z
  (up), probe +X = marker +x (right), probe -Z = marker +y (toward the printed top edge).
  So ``world = A · marker`` with ``A = [[1,0,0],[0,0,1],[0,-1,0]]``. Put the 360° camera
  with its front (panorama centre) facing the way the marker's top edge points, or give
  ``--probe-rotate YAW,PITCH,ROLL`` (degrees; the rotation taking probe directions to this
  anchored frame, as :func:`provider.core.geometry.sh.rotation_from_euler`).
* OpenCV camera: x right, y down, z forward. solvePnP gives ``X_cv = R·X_marker + t``.
* OpenGL eye frame: x right, y up, z backward: ``X_gl = C·X_cv`` with ``C = diag(1,-1,-1)``.
* The mesh is drawn in the OpenGL eye frame: model = C·[R|t]·Aᵀ·(object on the marker),
  normals n_eye = (C R Aᵀ) n_world, and the lighting is rotated into the same frame:
  ``M_eye = R̃ M R̃ᵀ`` with ``R̃ = diag(C·R·Aᵀ·P, 1)`` (P = ``--probe-rotate``). Then
  E_eye(n_eye) = E_world(n_world): the object is lit from the room's directions however the
  camera looks at the marker.
* Projection: the OpenGL matrix built from the intrinsics (fx, fy, cx, cy; OpenCV pixel
  centres at integer coordinates, image row 0 at the top), so the object lines up with
  the marker pixel for pixel. Lens distortion (``D``) is used for the pose only; the
  overlay is drawn undistorted.

Intrinsics: ``--calibration FILE.json`` with ``{"K": 3x3, "D": [k1, k2, p1, p2, k3],
"image_size": [w, h]}`` (``camera_matrix``/``dist_coeffs`` are accepted too; K is scaled
if the frames have another size), or a pinhole guess: 60° horizontal field of view,
principal point at the image centre, no distortion.

Exit status: 0 ok; 2 a user error (unreadable input, lighting, calibration; one line on
stderr); 3 no marker was found in any frame (the background is still written unchanged).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from example_common import (MESHES, LightingError, LitMeshRenderer, auto_exposure,  # noqa: E402
                            mesh_data, open_lighting, render)
from provider.core.geometry.sh import rotate_matrices, rotation_from_euler  # noqa: E402

#: OpenCV camera (x right, y down, z forward) -> OpenGL eye (x right, y up, z backward).
CV_TO_GL = np.diag([1.0, -1.0, -1.0])
#: Marker frame (x right, y to the printed top edge, z up out of the face) -> world (+Y up).
MARKER_TO_WORLD = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])

IMAGE_EXTENSIONS = {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp", ".exr", ".hdr"}
VIDEO_EXTENSIONS = {".mp4", ".avi", ".mov", ".mkv", ".m4v"}

DEFAULT_HFOV_DEG = 60.0


class UserError(Exception):
    """Something the user can fix; printed as one line, exit status 2."""


# -- camera and marker ------------------------------------------------------------------------

def default_intrinsics(width: int, height: int, hfov_deg: float = DEFAULT_HFOV_DEG):
    """Pinhole guess: square pixels, ``hfov_deg`` horizontal field of view, centred, no
    distortion. Returns (K 3×3, D (5,))."""
    f = (width / 2.0) / math.tan(math.radians(hfov_deg) / 2.0)
    K = np.array([[f, 0, (width - 1) / 2.0], [0, f, (height - 1) / 2.0], [0, 0, 1]], np.float64)
    return K, np.zeros(5)


def load_intrinsics(path: str, width: int, height: int):
    """(K, D) from a calibration JSON, scaled to a ``width``×``height`` frame."""
    try:
        data = json.loads(Path(path).read_text())
    except OSError as exc:
        raise UserError(f"cannot read calibration {path}: {exc.strerror}") from None
    except ValueError as exc:
        raise UserError(f"calibration {path} is not JSON: {exc}") from None
    K = data.get("K", data.get("camera_matrix")) if isinstance(data, dict) else None
    D = data.get("D", data.get("dist_coeffs", [])) if isinstance(data, dict) else None
    try:
        K = np.asarray(K, np.float64).reshape(3, 3)
        D = np.asarray(D if D is not None else [], np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise UserError(f"calibration {path}: needs \"K\" (3x3) and optionally \"D\"") from None
    size = data.get("image_size")
    if size:
        sx, sy = width / float(size[0]), height / float(size[1])
        K = K.copy()
        K[0] *= sx
        K[1] *= sy
    return K, D


def aruco_dictionary(name: str):
    import cv2
    if not hasattr(cv2.aruco, name):
        raise UserError(f"unknown ArUco dictionary {name!r} (e.g. DICT_4X4_50, DICT_6X6_250)")
    return cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, name))


def make_detector(dictionary: str = "DICT_4X4_50"):
    import cv2
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    return cv2.aruco.ArucoDetector(aruco_dictionary(dictionary), params)


def detect_marker(image_bgr, detector, marker_id: int | None = None):
    """(id, corners (4, 2) float64: top-left, top-right, bottom-right, bottom-left of the
    printed marker) of the wanted marker, or of the largest one; None if there is none."""
    import cv2
    gray = image_bgr if image_bgr.ndim == 2 else cv2.cvtColor(image_bgr, cv2.COLOR_BGR2GRAY)
    corners, ids, _ = detector.detectMarkers(gray)
    if ids is None or len(ids) == 0:
        return None
    found = [(int(i), c.reshape(4, 2).astype(np.float64)) for i, c in zip(ids.ravel(), corners)]
    if marker_id is not None:
        found = [f for f in found if f[0] == marker_id]
        if not found:
            return None
    return max(found, key=lambda f: cv2.contourArea(f[1].astype(np.float32)))


def marker_object_points(length: float) -> np.ndarray:
    """The marker corners in the marker frame, in ArUco's order (SOLVEPNP_IPPE_SQUARE's)."""
    h = length / 2.0
    return np.array([[-h, h, 0], [h, h, 0], [h, -h, 0], [-h, -h, 0]], np.float64)


def estimate_pose(corners, length: float, K, D):
    """(R 3×3, t (3,)) with X_cv = R·X_marker + t (OpenCV camera frame, ``length`` units)."""
    import cv2
    obj = marker_object_points(length)
    img = np.asarray(corners, np.float64).reshape(4, 2)
    # IPPE_SQUARE's two solutions, and SQPnP's: the one that reprojects best. IPPE alone
    # returns the identity, 599 px off, for a marker seen exactly head-on (a rotation of
    # exactly 180° about x: a picture of the printed marker, the README's example).
    candidates = []
    for flags in (cv2.SOLVEPNP_IPPE_SQUARE, cv2.SOLVEPNP_SQPNP):
        try:
            n, rvecs, tvecs, _ = cv2.solvePnPGeneric(obj, img, K, D, flags=flags)
        except cv2.error:
            continue
        candidates += list(zip(rvecs[:n], tvecs[:n]))
    best, best_err = None, math.inf
    for rvec, tvec in candidates:
        if float(tvec.reshape(3)[2]) <= 0:        # behind the camera
            continue
        projected, _ = cv2.projectPoints(obj, rvec, tvec, K, D)
        err = float(np.abs(projected.reshape(4, 2) - img).max())
        if err < best_err:
            best, best_err = (rvec, tvec), err
    if best is None:
        return None
    R, _ = cv2.Rodrigues(best[0])
    return R, best[1].reshape(3)


# -- frames -----------------------------------------------------------------------------------

def camera_rotation(R_marker) -> np.ndarray:
    """World (anchored probe frame, +Y up) directions -> OpenGL eye directions: C·R·Aᵀ."""
    return CV_TO_GL @ np.asarray(R_marker, np.float64) @ MARKER_TO_WORLD.T


def lighting_in_eye(matrices_probe, R_marker, probe_rotation=None) -> np.ndarray:
    """Irradiance matrices in the OpenGL eye frame: M' = R̃ M R̃ᵀ, R = C·R_marker·Aᵀ·P."""
    P = np.eye(3) if probe_rotation is None else np.asarray(probe_rotation, np.float64)
    return rotate_matrices(matrices_probe, camera_rotation(R_marker) @ P)


def gl_projection(K, width: int, height: int, near: float, far: float) -> np.ndarray:
    """OpenGL projection reproducing the pinhole K on a ``width``×``height`` viewport.

    OpenCV pixel (u, v) has its centre at integer coordinates and v grows downward; the
    OpenGL window pixel centre is (u + 0.5, height - v - 0.5).
    """
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    return np.array([
        [2 * fx / width, 0, 1 - (2 * cx + 1) / width, 0],
        [0, 2 * fy / height, (2 * cy + 1) / height - 1, 0],
        [0, 0, (far + near) / (near - far), 2 * far * near / (near - far)],
        [0, 0, -1, 0]], np.float64)


def object_on_marker(mesh: str, marker_length: float, scale: float = 1.0) -> np.ndarray:
    """Object -> world (marker anchored, +Y up): the mesh centred on the marker, its widest
    extent ``scale`` × the marker side, resting on the marker plane."""
    _, _, _, rest = mesh_data(mesh)
    s = scale * marker_length / 2.0           # sphere radius / torus outer radius = 1 in object space
    m = np.diag([s, s, s, 1.0])
    m[1, 3] = rest * s
    return m


def model_to_eye(R_marker, t_marker, object_to_world) -> np.ndarray:
    """Object -> OpenGL eye: C·[R|t]·Aᵀ·object_to_world (4×4)."""
    cam = np.eye(4)
    cam[:3, :3], cam[:3, 3] = R_marker, t_marker
    c4, a4 = np.eye(4), np.eye(4)
    c4[:3, :3], a4[:3, :3] = CV_TO_GL, MARKER_TO_WORLD.T
    return c4 @ cam @ a4 @ np.asarray(object_to_world, np.float64)


def project_point(point_marker, R, t, K) -> np.ndarray:
    """Pixel (u, v) of a marker-frame point (no distortion)."""
    p = np.asarray(R, np.float64) @ np.asarray(point_marker, np.float64) + np.asarray(t)
    uvw = K @ p
    return uvw[:2] / uvw[2]


# -- compositing ------------------------------------------------------------------------------

class ARCompositor:
    """Renders the lit object for a marker pose and composites it over a BGR frame."""

    def __init__(self, ctx, size, *, mesh: str = "sphere", marker_length: float = 0.05,
                 scale: float = 1.0, albedo=(0.8, 0.8, 0.8), tone_map: str = "reinhard"):
        self.renderer = LitMeshRenderer(ctx, size)
        self.mesh, self.marker_length, self.scale = mesh, marker_length, scale
        self.albedo, self.tone_map = albedo, tone_map
        self.object_to_world = object_on_marker(mesh, marker_length, scale)

    def render(self, K, R, t, matrices_probe, exposure: float, probe_rotation=None) -> np.ndarray:
        """(H, W, 4) uint8 RGBA (premultiplied, sRGB) of the object alone."""
        w, h = self.renderer.size
        dist = float(np.linalg.norm(t))
        proj = gl_projection(K, w, h, near=dist / 50.0, far=dist * 50.0)
        model = model_to_eye(R, t, self.object_to_world)
        m_eye = lighting_in_eye(matrices_probe, R, probe_rotation)
        self.renderer.begin()
        self.renderer.draw(self.mesh, model, proj, m_eye, albedo=self.albedo, exposure=exposure,
                           tone_map=self.tone_map, srgb=True)
        return self.renderer.read_rgba()

    @staticmethod
    def composite(background_bgr, rgba) -> np.ndarray:
        """Premultiplied ``rgba`` over an 8-bit BGR background."""
        a = rgba[..., 3:4].astype(np.float32) / 255.0
        obj_bgr = rgba[..., 2::-1].astype(np.float32)
        out = obj_bgr + background_bgr.astype(np.float32) * (1.0 - a)
        return np.clip(out + 0.5, 0, 255).astype(np.uint8)


# -- input and output -------------------------------------------------------------------------

class FrameSource:
    """Frames (BGR uint8) from a camera index, a video file or one image."""

    def __init__(self, spec: str):
        import cv2
        self.spec, self.image, self.capture = spec, None, None
        if spec.isdigit() or spec.startswith("camera:"):
            index = int(spec.split(":")[-1])
            try:    # OpenCV's back ends print warnings for a missing camera; the error says it
                cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)
            except AttributeError:
                pass
            self.capture = cv2.VideoCapture(index)
            if not self.capture.isOpened():
                raise UserError(f"cannot open camera {index}")
            return
        if not os.path.exists(spec):
            raise UserError(f"no such input file: {spec}")
        ext = Path(spec).suffix.lower()
        if ext in IMAGE_EXTENSIONS:
            img = cv2.imread(spec, cv2.IMREAD_COLOR)
            if img is None:
                raise UserError(f"cannot read image {spec} (not an image OpenCV can decode)")
            self.image = img
            return
        self.capture = cv2.VideoCapture(spec)
        ok, first = self.capture.read() if self.capture.isOpened() else (False, None)
        if not ok:
            raise UserError(f"cannot read {spec} as a video or an image")
        self._first = first

    @property
    def is_still(self) -> bool:
        return self.image is not None

    def fps(self) -> float:
        import cv2
        f = self.capture.get(cv2.CAP_PROP_FPS) if self.capture is not None else 0
        return f if f and f > 0 and f < 240 else 30.0

    def frames(self):
        if self.image is not None:
            yield self.image
            return
        first = getattr(self, "_first", None)
        if first is not None:
            self._first = None
            yield first
        while True:
            ok, frame = self.capture.read()
            if not ok:
                return
            yield frame

    def close(self) -> None:
        if self.capture is not None:
            self.capture.release()


class Output:
    """An image file, a video file, or (``path`` None) a glfw window."""

    def __init__(self, path: str | None, size):
        self.path, self.size, self.writer, self.window = path, size, None, None
        self.kind = "window"
        if path is None:
            return
        ext = Path(path).suffix.lower()
        parent = Path(path).resolve().parent
        if not parent.is_dir():
            raise UserError(f"cannot write {path}: folder {parent} does not exist")
        if ext in VIDEO_EXTENSIONS:
            self.kind = "video"
        elif ext in IMAGE_EXTENSIONS:
            self.kind = "image"
        else:
            raise UserError(f"--output {path}: use an image (.png, .jpg) or video "
                            f"({', '.join(sorted(VIDEO_EXTENSIONS))}) extension")

    def write(self, frame_bgr, index: int) -> bool:
        """False when the user closed the window."""
        import cv2
        if self.kind == "image":
            target = self.path
            if index > 0:   # several frames into an image name: name-00001.png
                p = Path(self.path)
                target = str(p.with_name(f"{p.stem}-{index:05d}{p.suffix}"))
            if not cv2.imwrite(target, frame_bgr):
                raise UserError(f"cannot write {target}")
            return True
        if self.kind == "video":
            if self.writer is None:
                fourcc = cv2.VideoWriter_fourcc(*("MJPG" if self.path.lower().endswith(".avi")
                                                  else "mp4v"))
                self.writer = cv2.VideoWriter(self.path, fourcc, self.fps_hint,
                                              (frame_bgr.shape[1], frame_bgr.shape[0]))
                if not self.writer.isOpened():
                    raise UserError(f"cannot open {self.path} for writing a video")
            self.writer.write(frame_bgr)
            return True
        return self.window.show(frame_bgr)

    fps_hint = 30.0

    def close(self) -> None:
        if self.writer is not None:
            self.writer.release()


class Window:
    """A glfw window showing BGR frames (a textured quad), with its own GL 3.3 context."""

    QUAD_VS = """#version 330 core
in vec2 in_pos; out vec2 uv;
void main() { uv = vec2(in_pos.x, -in_pos.y) * 0.5 + 0.5; gl_Position = vec4(in_pos, 0.0, 1.0); }"""
    QUAD_FS = """#version 330 core
uniform sampler2D frame; in vec2 uv; out vec4 color;
void main() { color = vec4(texture(frame, uv).bgr, 1.0); }"""

    def __init__(self, size, title: str = "shlight AR composite"):
        glfw, moderngl = render.gl_module("glfw"), render.gl_module("moderngl")
        if not glfw.init():
            raise UserError("glfw cannot initialise (no display? use --output FILE to run "
                            "headless)")
        for hint, value in ((glfw.CONTEXT_VERSION_MAJOR, 3), (glfw.CONTEXT_VERSION_MINOR, 3),
                            (glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE),
                            (glfw.OPENGL_FORWARD_COMPAT, True)):
            glfw.window_hint(hint, value)
        w, h = size
        scale = min(1.0, 1280.0 / w)
        self.win = glfw.create_window(int(w * scale), int(h * scale), title, None, None)
        if not self.win:
            glfw.terminate()
            raise UserError("glfw cannot create an OpenGL 3.3 window (no display?)")
        glfw.make_context_current(self.win)
        glfw.swap_interval(1)
        self.glfw = glfw
        self.ctx = moderngl.create_context()
        self.prog = self.ctx.program(vertex_shader=self.QUAD_VS, fragment_shader=self.QUAD_FS)
        quad = np.array([-1, -1, 1, -1, -1, 1, 1, 1], "f4")
        self.vao = self.ctx.vertex_array(self.prog, [(self.ctx.buffer(quad.tobytes()), "2f",
                                                      "in_pos")])
        self.tex = self.ctx.texture((w, h), 3)

    def show(self, frame_bgr) -> bool:
        import moderngl
        glfw = self.glfw
        if glfw.window_should_close(self.win):
            return False
        self.tex.write(np.ascontiguousarray(frame_bgr).tobytes())
        fw, fh = glfw.get_framebuffer_size(self.win)
        self.ctx.screen.use()
        self.ctx.viewport = (0, 0, fw, fh)
        self.ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        self.tex.use(0)
        self.vao.render(moderngl.TRIANGLE_STRIP)
        glfw.swap_buffers(self.win)
        glfw.poll_events()
        return not glfw.window_should_close(self.win)

    def close(self) -> None:
        self.glfw.terminate()


# -- main -------------------------------------------------------------------------------------

def parse_args(argv=None):
    p = argparse.ArgumentParser(
        description="Draw a mesh on an ArUco marker, lit by SH9 room lighting (live or "
                    "from a panorama), over a camera, video or image.",
        epilog="Frames and conventions: see the module docstring (python -c 'import "
               "ar_composite; help(ar_composite)' from examples/).")
    p.add_argument("--input", "-i", required=True,
                   help="camera index (0, camera:1), video file or image file")
    p.add_argument("--lighting", "-l", default="ws://127.0.0.1:8765/",
                   help="ws://HOST:PORT/ of a `shlight serve` (latest message, reconnecting), "
                        "or a panorama file (default ws://127.0.0.1:8765/)")
    p.add_argument("--output", "-o", help="image (.png/.jpg) or video (.mp4/.avi) file; "
                                          "default: a glfw window")
    p.add_argument("--calibration", help="camera intrinsics JSON {\"K\": 3x3, \"D\": [...], "
                                         "\"image_size\": [w, h]} (default: 60° pinhole guess)")
    p.add_argument("--hfov", type=float, default=DEFAULT_HFOV_DEG,
                   help="horizontal field of view of the pinhole guess (degrees)")
    p.add_argument("--dictionary", default="DICT_4X4_50", help="ArUco dictionary")
    p.add_argument("--marker-id", type=int, help="use this marker id (default: the largest)")
    p.add_argument("--marker-length", type=float, default=0.05,
                   help="printed marker side (black square), metres (default 0.05)")
    p.add_argument("--mesh", choices=MESHES, default="sphere")
    p.add_argument("--scale", type=float, default=1.0,
                   help="object width as a multiple of the marker side (default 1)")
    p.add_argument("--albedo", default="0.8,0.8,0.8", help="linear RGB albedo (default 0.8)")
    p.add_argument("--exposure", default="auto",
                   help="linear exposure, or 'auto' (average white surface at 0.6; fixed "
                        "from the first lighting)")
    p.add_argument("--tone-map", choices=sorted(render.TONE_MAPS), default="reinhard")
    p.add_argument("--probe-rotate", default="0,0,0", metavar="YAW,PITCH,ROLL",
                   help="rotation from the probe's frame to the marker-anchored frame")
    p.add_argument("--lighting-timeout", type=float, default=10.0,
                   help="seconds to wait for the first message of a provider (default 10)")
    p.add_argument("--max-frames", type=int, default=0, help="stop after N frames (0: all)")
    p.add_argument("--pose-log", action="store_true",
                   help="print one JSON line per frame: marker id, rvec, tvec, lighting seq")
    return p.parse_args(argv)


def _floats(text: str, n: int, what: str):
    try:
        v = [float(x) for x in text.split(",")]
    except ValueError:
        v = []
    if len(v) == 1 and n == 3 and what == "--albedo":
        v = v * 3
    if len(v) != n:
        raise UserError(f"{what} needs {n} comma-separated numbers; got {text!r}")
    return v


def check_numbers(args) -> None:
    """The numeric options, before any frame or connection: a size, a scale or a field of
    view that is not a positive finite number would draw nothing (or NaN) and exit 0."""
    for flag, value, high in (("--marker-length", args.marker_length, None),
                              ("--scale", args.scale, None),
                              ("--hfov", args.hfov, 180.0),
                              ("--lighting-timeout", args.lighting_timeout, None)):
        if not (math.isfinite(value) and value > 0 and (high is None or value < high)):
            raise UserError(f"{flag} must be a finite number above 0"
                            + (f" and below {high:g}" if high else "") + f", got {value:g}")
    if args.max_frames < 0:
        raise UserError(f"--max-frames must be 0 (all) or more, got {args.max_frames}")


def run(args) -> int:
    import cv2
    check_numbers(args)
    albedo = _floats(args.albedo, 3, "--albedo")
    probe_rotation = rotation_from_euler(*_floats(args.probe_rotate, 3, "--probe-rotate"))
    exposure = None if args.exposure == "auto" else _floats(args.exposure, 1, "--exposure")[0]
    detector = make_detector(args.dictionary)

    source = FrameSource(args.input)
    lighting = None
    output = window = None
    try:
        try:
            lighting = open_lighting(args.lighting)
            matrices, _ = lighting.wait(args.lighting_timeout)
        except LightingError as exc:
            raise UserError(str(exc)) from None
        if exposure is None:
            exposure = auto_exposure(matrices)

        compositor = None
        found = frames = 0
        for index, frame in enumerate(source.frames()):
            if args.max_frames and index >= args.max_frames:
                break
            h, w = frame.shape[:2]
            if compositor is None:
                if args.calibration:
                    K, D = load_intrinsics(args.calibration, w, h)
                else:
                    K, D = default_intrinsics(w, h, args.hfov)
                output = Output(args.output, (w, h))
                output.fps_hint = source.fps()
                if output.kind == "window":
                    window = output.window = Window((w, h))
                    ctx = window.ctx
                else:
                    ctx = render.create_context()
                compositor = ARCompositor(ctx, (w, h), mesh=args.mesh,
                                          marker_length=args.marker_length, scale=args.scale,
                                          albedo=albedo, tone_map=args.tone_map)
            frames += 1
            det = detect_marker(frame, detector, args.marker_id)
            pose = estimate_pose(det[1], args.marker_length, K, D) if det else None
            out = frame
            matrices, version = lighting.latest()
            if pose is not None:
                found += 1
                rgba = compositor.render(K, pose[0], pose[1], matrices, exposure, probe_rotation)
                out = compositor.composite(frame, rgba)
            if args.pose_log:
                rvec = cv2.Rodrigues(pose[0])[0].ravel().tolist() if pose else None
                print(json.dumps({"frame": index, "marker_id": det[0] if det else None,
                                  "rvec": rvec, "tvec": pose[1].tolist() if pose else None,
                                  "lighting_version": version,
                                  "lighting_seq": getattr(lighting, "seq", None),
                                  "matrices": np.asarray(matrices).reshape(-1).tolist()}),
                      flush=True)
            if not output.write(out, index if not source.is_still else 0):
                break
        if frames == 0:
            raise UserError(f"no frames could be read from {args.input}")
        if found == 0:
            which = f"id {args.marker_id} " if args.marker_id is not None else ""
            where = f"; wrote the background unchanged to {args.output}" if args.output else ""
            print(f"ar_composite: no ArUco marker {which}({args.dictionary}) found in "
                  f"{frames} frame(s) of {args.input}{where}", file=sys.stderr)
            return 3
        if frames > 1:
            print(f"ar_composite: marker found in {found} of {frames} frames", file=sys.stderr)
        return 0
    finally:
        if output is not None:
            output.close()
        if window is not None:
            window.close()
        if lighting is not None:
            lighting.close()
        source.close()


def main(argv=None) -> int:
    args = parse_args(argv)
    try:
        return run(args)
    except UserError as exc:
        print(f"ar_composite: error: {exc}", file=sys.stderr)
        return 2
    except render.NoOpenGL as exc:
        print(f"ar_composite: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
