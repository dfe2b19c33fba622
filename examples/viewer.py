#!/usr/bin/env python3
"""Live viewer: a sphere and a torus lit by a `shlight serve` provider, in a glfw window.

    shlight serve &                                     # demo lighting on ws://127.0.0.1:8765/
    python examples/viewer.py                           # watch it change
    python examples/viewer.py --lighting ws://pi.local:8765/?probe=desk
    python examples/viewer.py --lighting room.exr --screenshot room.png --frames 3

The scene is drawn in the wire frame itself (right-handed, +Y up, docs/contract.md §1), so the
matrices go to the shader unrotated: the camera stands at +Z looking toward -Z (toward the
panorama centre), +X is to the right of the window. A light at u = 0.75 of the panorama
(+X) lights the right side of both objects.

The connection is kept by a background thread that holds only the newest message and
reconnects with back-off (0.5 s up to 5 s) whenever the provider goes away; the window title
shows the state (waiting / live seq N / stale / reconnecting). Until the first message the
objects are lit by a dim uniform grey. ``--exposure auto`` is fixed from the first message,
so later changes of the room's brightness stay visible.

Smoke testing: ``--frames N`` exits after N frames drawn with real lighting,
``--screenshot FILE`` saves the last frame; ``--on-change 'shot-{n}.png' --changes K`` saves
a screenshot each time the drawn lighting changes and exits after K of them.
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from example_common import (LightingError, LitMeshRenderer, auto_exposure,  # noqa: E402
                            open_lighting, read_screen, render, uniform_matrices)

BACKGROUND = (0.12, 0.12, 0.14)


def scene_matrices(aspect: float):
    """view_projection and the two models (sphere left, torus right, tilted toward the viewer)."""
    view = render.look_at((0.0, 0.8, 4.8), (0.0, 0.0, 0.0))
    vp = render.perspective(40.0, aspect, 0.1, 50.0) @ view
    sphere = np.eye(4)
    sphere[0, 3] = -1.15
    tilt = math.radians(55.0)                       # torus axis (+Y) tilted toward the camera
    torus = np.eye(4)
    torus[:3, :3] = np.array([[1, 0, 0], [0, math.cos(tilt), -math.sin(tilt)],
                              [0, math.sin(tilt), math.cos(tilt)]])
    torus[:3, :3] *= 1.05
    torus[0, 3] = 1.15
    return vp, sphere, torus


def changed(a, b, tol: float = 1e-3) -> bool:
    if a is None or b is None:
        return a is not b
    return float(np.abs(a - b).max()) > tol * max(1e-9, float(np.abs(b).max()))


def parse_args(argv=None):
    p = argparse.ArgumentParser(description="A sphere and a torus lit live by a shlight "
                                            "provider (glfw window, OpenGL 3.3 core).")
    p.add_argument("--lighting", "-l", default="ws://127.0.0.1:8765/",
                   help="ws://HOST:PORT/ of `shlight serve`, or a panorama file")
    p.add_argument("--size", default="960x540", help="window size WxH (default 960x540)")
    p.add_argument("--exposure", default="auto", help="linear exposure or 'auto'")
    p.add_argument("--tone-map", choices=sorted(render.TONE_MAPS), default="reinhard")
    p.add_argument("--albedo", type=float, default=0.8, help="grey albedo (default 0.8)")
    p.add_argument("--fps", type=float, default=30.0, help="frame cap (default 30)")
    p.add_argument("--frames", type=int, default=0,
                   help="exit after N frames drawn with real lighting (0: run until closed)")
    p.add_argument("--screenshot", help="save the last frame drawn to this PNG at exit")
    p.add_argument("--on-change", metavar="PATTERN",
                   help="save a screenshot whenever the drawn lighting changes, e.g. "
                        "'shot-{n}.png' (n = 1, 2, ...)")
    p.add_argument("--changes", type=int, default=0,
                   help="with --on-change: exit after this many screenshots")
    return p.parse_args(argv)


def gl_module(name: str):
    """moderngl or glfw, or one line naming the extra that installs them."""
    try:
        return render.gl_module(name)
    except render.NoOpenGL as exc:
        raise SystemExit(f"viewer: error: {exc}") from None


def open_window(width: int, height: int, title: str):
    glfw = gl_module("glfw")
    if not glfw.init():
        raise SystemExit("viewer: error: glfw cannot initialise (no display? run it under "
                         "`xvfb-run -a`, or install xvfb libgl1-mesa-dri)")
    for hint, value in ((glfw.CONTEXT_VERSION_MAJOR, 3), (glfw.CONTEXT_VERSION_MINOR, 3),
                        (glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE),
                        (glfw.OPENGL_FORWARD_COMPAT, True), (glfw.SAMPLES, 4)):
        glfw.window_hint(hint, value)
    win = glfw.create_window(width, height, title, None, None)
    if not win:
        glfw.terminate()
        raise SystemExit("viewer: error: glfw cannot create an OpenGL 3.3 core window "
                         "(install libgl1-mesa-dri; headless: xvfb-run -a)")
    glfw.make_context_current(win)
    glfw.swap_interval(0)
    return glfw, win


def save_png(path: str, rgb) -> None:
    import cv2
    if not cv2.imwrite(str(path), np.ascontiguousarray(rgb[..., ::-1])):
        raise SystemExit(f"viewer: error: cannot write {path}")


def run(args) -> int:
    moderngl = gl_module("moderngl")
    try:
        width, height = (int(v) for v in args.size.lower().split("x"))
    except ValueError:
        raise SystemExit(f"viewer: error: --size must be WxH, e.g. 960x540; got {args.size!r}")
    try:
        lighting = open_lighting(args.lighting)
    except LightingError as exc:
        raise SystemExit(f"viewer: error: {exc}")
    glfw, win = open_window(width, height, "shlight viewer: waiting for lighting")
    try:
        ctx = moderngl.create_context()
        print(f"viewer: OpenGL {ctx.info['GL_VERSION']} on {ctx.info['GL_RENDERER']}",
              file=sys.stderr, flush=True)
        renderer = LitMeshRenderer(ctx, (width, height), samples=0)
        exposure = None if args.exposure == "auto" else float(args.exposure)
        waiting = uniform_matrices(0.25)
        last_saved, shots, drawn, last = None, 0, 0, None
        title, done = "", False
        while not glfw.window_should_close(win):
            t0 = time.monotonic()
            matrices, version = lighting.latest()
            live = matrices is not None
            if live and exposure is None:
                exposure = auto_exposure(matrices)
            m = matrices if live else waiting
            fw, fh = glfw.get_framebuffer_size(win)
            if fw == 0 or fh == 0:          # minimised
                glfw.wait_events_timeout(0.1)
                continue
            ctx.viewport = (0, 0, fw, fh)
            vp, sphere, torus = scene_matrices(fw / fh)
            renderer.begin(ctx.screen)
            ctx.screen.clear(*BACKGROUND, 1.0, depth=1.0)
            for mesh, model in (("sphere", sphere), ("torus", torus)):
                renderer.draw(mesh, model, vp, m, albedo=(args.albedo,) * 3,
                              exposure=exposure or 1.0, tone_map=args.tone_map)
            ctx.finish()
            if live:
                drawn += 1
                if args.on_change and changed(matrices, last_saved):
                    shots += 1
                    save_png(args.on_change.format(n=shots), read_screen(ctx, (fw, fh)))
                    print(f"viewer: lighting change {shots} (message {version}) saved",
                          file=sys.stderr, flush=True)
                    last_saved = matrices
                last = (fw, fh)
            done = (args.frames and drawn >= args.frames) or \
                (args.on_change and args.changes and shots >= args.changes)
            if done and args.screenshot:
                save_png(args.screenshot, read_screen(ctx, last))
            glfw.swap_buffers(win)
            glfw.poll_events()
            state = ("waiting for lighting" if not live else
                     ("stale" if getattr(lighting, "stale", False) else "live") +
                     (f" seq {lighting.seq}" if getattr(lighting, "seq", None) is not None else ""))
            if live and getattr(lighting, "connected", True) is False:
                state = "reconnecting (showing the last lighting)"
            new_title = f"shlight viewer: {lighting.description}: {state}"
            if new_title != title:
                glfw.set_window_title(win, new_title)
                title = new_title
            if done:
                break
            time.sleep(max(0.0, 1.0 / args.fps - (time.monotonic() - t0)))
        if args.screenshot and not done and last is not None:
            print("viewer: window closed before the last frame; no screenshot", file=sys.stderr)
        return 0
    finally:
        lighting.close()
        glfw.terminate()


def main(argv=None) -> int:
    return run(parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
