"""The built-in demo source: an animated HDR room, so that a new user sees lighting
change with no camera."""
from __future__ import annotations

import math
import time

import numpy as np

from .base import Frame, Pacer, Source


class DemoSource(Source):
    """An animated HDR panorama, so that a new user sees lighting change with no camera.

    256×128 float32 linear radiance (equirect, docs/contract.md §1): a blue sky over brown
    ground, a sun circling the horizon once every ``period`` seconds, and a warm red lamp
    at +X that switches on and off every ``switch`` seconds.
    """

    def __init__(self, width: int = 256, height: int = 128, fps: float = 30.0,
                 period: float = 20.0, switch: float = 3.0):
        super().__init__()
        self.width, self.height, self.period, self.switch = width, height, period, switch
        self.nominal_fps = fps
        self._pacer = Pacer(fps)
        v = (np.arange(height) + 0.5) / height
        u = (np.arange(width) + 0.5) / width
        theta = np.pi * v[:, None]
        phi = 2 * np.pi * (u[None, :] - 0.5)
        self._dirs = np.stack(np.broadcast_arrays(
            np.sin(phi) * np.sin(theta), np.cos(theta), -np.cos(phi) * np.sin(theta)),
            axis=-1).astype(np.float32)                                    # (H, W, 3)
        up = self._dirs[..., 1:2]
        zenith, horizon = np.array([0.20, 0.38, 0.85]), np.array([0.85, 0.90, 1.00])
        ground = np.array([0.22, 0.17, 0.12])
        sky = horizon + (zenith - horizon) * np.sqrt(np.clip(up, 0, 1))
        earth = ground * (0.5 + 0.5 * np.clip(1 + up, 0, 1))
        blend = np.clip(up * 20 + 0.5, 0, 1)                                # soft horizon
        self._base = (earth + (sky - earth) * blend).astype(np.float32)
        lamp = (math.cos(math.radians(10)), math.sin(math.radians(10)), 0.0)
        # The lamp does not move: its picture is made once (the demo runs all day at 30 fps).
        self._lamp = self._disc(lamp, 9.0, 2.0) * np.float32([60, 14, 4])
        self._t0 = time.time()

    def _disc(self, direction, radius_deg: float, softness_deg: float,
              cos_d: np.ndarray | None = None) -> np.ndarray:
        """Soft-edged disc mask (H, W, 1) around ``direction``."""
        if cos_d is None:
            cos_d = self._dirs @ np.asarray(direction, np.float32)
        inner, outer = math.radians(radius_deg), math.radians(radius_deg + softness_deg)
        w = (cos_d - np.float32(math.cos(outer))) * np.float32(
            1 / (math.cos(inner) - math.cos(outer)))
        return np.clip(w, 0, 1)[..., None]

    def render(self, t: float) -> np.ndarray:
        """The scene ``t`` seconds after the start (a new array)."""
        az = 2 * math.pi * t / self.period
        el = math.radians(35)
        sun = (math.cos(el) * math.sin(az), math.sin(el), -math.cos(el) * math.cos(az))
        cos_d = self._dirs @ np.asarray(sun, np.float32)
        img = self._base + self._disc(sun, 4.0, 1.5, cos_d) * np.float32([180, 165, 140])
        img += self._disc(sun, 12.0, 10.0, cos_d) * np.float32([1.5, 1.3, 1.0])    # glow
        if int(t // self.switch) % 2 == 0:                                 # the lamp
            img += self._lamp
        return img

    def read(self) -> Frame:
        self._pacer.wait(self)
        now = time.time()
        return Frame(self.render(now - self._t0), now)
