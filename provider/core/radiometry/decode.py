"""Decoding a frame into linear radiance, once, for every product (no I/O).

:class:`FrameDecoder` holds what decoding needs and does not depend on pixels: the frame
size, the transfer function or camera response as a table (sRGB by default; a calibrated
curve, docs/contract.md §9, costs the same), and the linear ``exposure`` folded into it.
:class:`~provider.core.sh9.engine.SH9Projector` (SH9, lights) and
:class:`~provider.core.reflections.environment.EnvironmentProjector` (the reflection cube) are both
decoders: the frame contract, its checks and the counts of bad samples are the same for
every product (see :mod:`provider.core.sh9.engine` for the frame contract).
"""
from __future__ import annotations


import cv2
import numpy as np

from ..errors import InputError
from .float_clean import clean_frame
from .response import CameraResponse, apply_lut


def srgb_to_linear(v: np.ndarray) -> np.ndarray:
    """IEC 61966-2-1 sRGB decoding of values in [0, 1]."""
    v = np.asarray(v, np.float64)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def image_array(image) -> np.ndarray:
    """An image given as an array or a path (read with :func:`~provider.core.radiometry.images.read_image`)
    as a non-empty array, else :class:`InputError` in one line."""
    if isinstance(image, (str, bytes)) or hasattr(image, "__fspath__"):
        from .images import read_image
        image = read_image(image)
    if not isinstance(image, np.ndarray):
        raise InputError(f"expected an image array or a path, got {type(image).__name__}")
    if image.size == 0 or image.ndim < 2:
        raise InputError(f"empty image (shape {image.shape})")
    return image


class FrameDecoder:
    """Checks frames of one size and decodes them to linear float32 radiance.

    ``encoding`` ("auto" | "srgb" | "linear") says what integer frames' codes are, unless a
    camera ``response`` (:class:`~provider.core.radiometry.response.CameraResponse`) does; ``exposure``
    scales integer frames through the table (float frames: the caller scales its product).
    """

    def _init_decoder(self, width: int, height: int, encoding: str, exposure: float,
                      response) -> None:
        if response is not None and not isinstance(response, CameraResponse):
            raise InputError(f"response must be a CameraResponse, got {type(response).__name__}")
        if response is not None and encoding != "auto":
            raise InputError(f"encoding {encoding!r} and a camera response both say how to "
                             "decode integer frames: give one")
        self.width, self.height = int(width), int(height)
        self.encoding, self.exposure, self.response = encoding, float(exposure), response
        self._luts = {}

    def radiance_scale(self, exposure_s: float | None = None, gain: float = 1.0,
                       f_number: float | None = None) -> float:
        """What multiplies a frame's plain linear light (an integer frame through its camera
        curve at t = 1 or sRGB, a float frame as it is) to give its coefficients' units: the
        ``exposure``, 1 / (``exposure_s`` · ``gain``) when the frame says its exposure, and the
        curve's C·N² where it has an absolute scale, as ``project`` applies them."""
        from .photometry import absolute_factor
        scale = self.exposure
        if exposure_s:
            scale /= exposure_s * (gain or 1.0)
            factor = absolute_factor(self.response, f_number)
            if factor is not None:
                scale *= factor
        return float(scale)

    # -- linearisation -------------------------------------------------------------------
    def _lut(self, dtype) -> np.ndarray:
        if dtype not in self._luts:
            full = 255 if dtype == np.uint8 else 65535
            if self.response is not None:   # the camera's curve at t = 1 (16-bit: resampled)
                r = self.response.to_bits(8 if dtype == np.uint8 else 16)
                self._luts[dtype] = (r.lut(1.0) * np.float32(self.exposure)).astype(np.float32)
                return self._luts[dtype]
            v = np.arange(full + 1) / full
            lin = v if self.encoding == "linear" else srgb_to_linear(v)
            self._luts[dtype] = (lin * self.exposure).astype(np.float32)
        return self._luts[dtype]

    def _linearise(self, frame: np.ndarray, lut: np.ndarray | None = None) -> np.ndarray:
        """Linear float32 radiance of an integer frame (or a band of one); ``lut``: another
        table than the projector's own (a bracket slot's)."""
        if lut is not None:
            return apply_lut(frame, lut)
        if frame.dtype == np.uint8:
            return cv2.LUT(frame, self._lut(np.uint8))
        lut = self._lut(np.uint16)
        return lut[frame] if lut.ndim == 1 else apply_lut(frame, lut)

    @property
    def radiometry(self) -> str:
        """What integer frames' numbers are: "srgb-assumed", "calibrated" (the camera's
        curve) or "linear" (``encoding="linear"``)."""
        if self.response is not None:
            return "srgb-assumed" if self.response.method == "srgb" else "calibrated"
        return "linear" if self.encoding == "linear" else "srgb-assumed"

    def _clean_float(self, frame: np.ndarray, stats: dict) -> np.ndarray:
        """Float32 linear radiance with non-finite and negative samples set to 0 (counted
        into ``stats``: :mod:`.float_clean`, band by band). Clean float32 frames are not
        copied; exposure is applied to the product, not here. A frame with no usable light
        left (all NaN, all negative) raises :class:`InputError`. SH9's projection cleans
        inside its own pass instead (:class:`~provider.core.framepass.traversal.FloatBands`)."""
        return clean_frame(frame, stats)

    def _prepare(self, frame) -> np.ndarray:
        if not isinstance(frame, np.ndarray):
            raise InputError(f"a frame must be a numpy array, got {type(frame).__name__}")
        if frame.size == 0:
            raise InputError("empty image (0 pixels)")
        if frame.ndim == 2:
            frame = frame[..., None]
        if frame.ndim != 3:
            raise InputError(f"a frame must be H×W×channels, got shape {frame.shape}")
        c = frame.shape[2]
        if c == 1:
            frame = np.repeat(frame, 3, axis=2)
        elif c == 4:
            frame = frame[..., :3]
        elif c != 3:
            raise InputError(f"a frame must have 1, 3 or 4 channels, got {c}")
        if frame.dtype not in (np.uint8, np.uint16, np.float16, np.float32, np.float64):
            raise InputError(f"unsupported pixel type {frame.dtype} "
                             "(use uint8, uint16 or float)")
        if frame.shape[:2] != (self.height, self.width):
            raise InputError(f"frame is {frame.shape[1]}×{frame.shape[0]}, this projector "
                             f"was built for {self.width}×{self.height}")
        window = getattr(self, "window", None)    # (x0, y0, x1, y1): a ball's box
        if window is not None:
            x0, y0, x1, y1 = window
            frame = frame[y0:y1, x0:x1]
        return np.ascontiguousarray(frame)

    def decode(self, frame: np.ndarray, stats: dict) -> np.ndarray:
        """The whole frame as linear float32 radiance (integer frames through the table,
        exposure included; float frames cleaned, exposure *not* applied): after
        :meth:`_prepare`. Bad float samples are set to 0 and counted in ``stats``."""
        if frame.dtype in (np.uint8, np.uint16):
            return self._linearise(frame)
        return self._clean_float(frame, stats)
