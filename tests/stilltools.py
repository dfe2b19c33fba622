"""Stills as a camera writes them, and the command line run on them (shared by the tests of
the sun's colour and the colour checker)."""
from __future__ import annotations

import subprocess
import sys
from fractions import Fraction

import numpy as np
from PIL import Image
from PIL.TiffImagePlugin import IFDRational


def shlight(*args, timeout=300):
    """``shlight ARGS`` in a child process (the installed command's module), its output."""
    return subprocess.run([sys.executable, "-m", "provider.cli", *map(str, args)],
                          capture_output=True, text=True, timeout=timeout)


def jpeg_still(path, rgb, t: float, n: float, iso: int, subsampling: int = -1) -> None:
    """An 8-bit JPEG (quality 95) with EXIF ExposureTime, FNumber and ISO in the Exif IFD;
    ``subsampling``: Pillow's (-1 its default, 4:2:0 at this quality; 0: 4:4:4, full
    chroma, which colour to 2 % needs: docs/photometry.md)."""
    exif = Image.Exif()
    ifd = exif.get_ifd(0x8769)
    t_, n_ = (Fraction(v).limit_denominator(1_000_000) for v in (t, n))
    ifd[0x829A] = IFDRational(t_.numerator, t_.denominator)
    ifd[0x829D] = IFDRational(n_.numerator, n_.denominator)
    ifd[0x8827] = int(iso)
    Image.fromarray(np.ascontiguousarray(rgb)).save(path, exif=exif, quality=95,
                                                     subsampling=subsampling)
