"""Reading images from files into the engine's frame contract (RGB, uint8/uint16/float32)."""
from __future__ import annotations

import io
import os
import stat
from contextlib import contextmanager, redirect_stdout
from dataclasses import dataclass

import cv2
import numpy as np

try:
    import simplejpeg
except ImportError:     # a declared dependency; OpenCV (which prints its warnings) otherwise
    simplejpeg = None

from ..errors import InputError
from .image_size import (EXR_MAGIC, HEADER_BYTES, PNG_MAGIC, check_decodable, check_pixels,
                         header_size)

IMAGE_EXTENSIONS = (".exr", ".hdr", ".pic", ".png", ".jpg", ".jpeg", ".tif", ".tiff",
                    ".bmp", ".webp", ".pfm", ".ppm", ".pgm")


class TransientReadError(InputError):
    """The file could not be read just now for a reason that is not its content (an I/O
    error, memory): reading the same file again may work, so it is not remembered as bad."""


def read_image(path, max_pixels: int = 0, said=None) -> np.ndarray:
    """Read an image file as an (H, W, 3) RGB array.

    OpenEXR files are read with the ``openexr`` package (the OpenCV wheels have no EXR
    codec) and returned as float32; everything else through OpenCV with
    ``IMREAD_UNCHANGED`` (8-bit, 16-bit and Radiance .hdr float stay as they are).

    Parameters
    ----------
    path : str or os.PathLike
        The image file.
    max_pixels : int
        Pixel budget (width × height, pixels; 0: none). An image whose header declares more
        is refused with :class:`~.image_size.FrameTooLarge` before anything beyond its
        header is read or decoded.
    said : callable, optional
        Called with what the JPEG decoder said of a damaged file it decoded by repairing it
        (e.g. "Corrupt JPEG data: premature end of data segment"); by default, one line on
        stderr.

    Raises
    ------
    InputError
        In one readable line, for a missing, unreadable, truncated or corrupt file;
        :class:`TransientReadError` (a subclass) when reading again may work.
    """
    path = os.fspath(path)
    if not os.path.exists(path):
        raise InputError(f"no such file: {path}")
    if os.path.isdir(path):
        raise InputError(f"{path} is a directory, not an image")
    try:
        with open(path, "rb") as f:
            data = f.read(HEADER_BYTES)
            size = header_size(data)
            if size is None and max_pixels and len(data) == HEADER_BYTES:
                data += f.read()       # a header beyond the first bytes (a TIFF's directory)
                size = header_size(data)
            if size is not None:       # refused from the header: nothing more read or decoded
                check_pixels(*size, max_pixels, f"{path}: image")
                check_decodable(*size, data, f"cannot read {path}")
            radiance = data[:2] == b"#?"
            if not radiance:           # Radiance files are decoded from their path (below)
                data += f.read()
    except OSError as exc:
        raise TransientReadError(f"cannot read {path}: {exc.strerror or exc}") from None
    # By content, not by name: an EXR saved as .jpg is still an EXR (OpenCV's wheels cannot
    # decode EXR, so the name alone would refuse it).
    if data[:4] == EXR_MAGIC or (path.lower().endswith(".exr") and len(data) < 4):
        _check_exr_complete(path, data)
        del data
        img = _read_exr(path)
    else:
        img = _decode(path, data, radiance, said)
    if size is None:   # a format whose size only its decoder reads: checked once decoded
        check_pixels(img.shape[1], img.shape[0], max_pixels, f"{path}: image", decoded=True)
    return img


def _decode(path: str, data: bytes, radiance: bool, said=None) -> np.ndarray:
    """A file's bytes decoded as RGB (see :func:`read_image`): a JPEG by
    :func:`decode_jpeg`, anything else by OpenCV."""
    png = check_complete(path, data)
    if png is not None:
        data = png          # the PNG as libpng is given it (no ancillary chunks)
    try:
        img = None
        if data[:3] == b"\xff\xd8\xff":
            img, words = decode_jpeg(data, f"cannot read {path}: the JPEG is corrupt")
            if words is not None and said is not None:
                said(words)
            elif words is not None:
                _say_on_stderr(f"warning: {path}: the JPEG is damaged, decoded as far as it "
                               f"goes (the decoder says: {words})")
            return img
        if radiance:
            # OpenCV decodes Radiance .hdr bytes through a temporary file (its decoder reads
            # files only): with /tmp full a valid file would fail. Read from its own path,
            # and from the bytes only when OpenCV cannot open the path (non-ASCII on
            # Windows). Its log's "imread_(...): can't read data" is said in our words below.
            with _opencv_log_quiet():
                img = cv2.imread(path, cv2.IMREAD_UNCHANGED)
                if img is None and not _opencv_can_open(path):
                    with open(path, "rb") as f:
                        data = f.read()
                    img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
        else:
            with _opencv_log_quiet():   # libtiff's errors come through OpenCV's log
                img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
        if img is not None:
            if img.ndim == 2:
                return np.repeat(img[..., None], 3, axis=2)
            if img.shape[2] == 4:
                img = img[..., :3]
            return np.ascontiguousarray(img[..., ::-1])  # BGR -> RGB
    except OSError as exc:
        raise TransientReadError(f"cannot read {path}: {exc.strerror or exc}") from None
    except MemoryError:
        raise TransientReadError(f"cannot read {path}: out of memory decoding it") from None
    except cv2.error as exc:
        if exc.code == cv2.Error.StsNoMem:
            raise TransientReadError(f"cannot read {path}: out of memory decoding it") from None
        # OpenCV refuses a header that declares more than CV_IO_MAX_IMAGE_PIXELS (2^30)
        raise InputError(f"cannot read {path}: its header declares an image too large to "
                         "decode (over 2^30 pixels), or it is corrupt") from None
    if radiance:
        raise InputError(f"cannot read {path}: not a Radiance .hdr file OpenCV can decode "
                         "(corrupt or truncated)")
    raise InputError(f"cannot read {path}: not an image OpenCV can decode")


# ---- JPEG: the decoder's words returned, not printed ------------------------------------------
#
# libjpeg, as OpenCV builds it, prints "Corrupt JPEG data: ..." straight to file descriptor 2
# for every damaged frame; capturing that meant pointing descriptor 2 elsewhere around each
# decode, process-wide, one decode at a time (issue 41). simplejpeg (libjpeg-turbo's TurboJPEG
# API, bundled in its wheels) keeps the decoder's message in its handle and raises it, and
# decodes with the GIL released, so that several cameras decode side by side. OpenCV decodes
# only where simplejpeg is not installed.

def decode_jpeg(data: bytes, what: str) -> tuple[np.ndarray, str | None]:
    """Decode a JPEG.

    Parameters
    ----------
    data : bytes
        The JPEG's bytes (its size already checked against the budget by the caller).
    what : str
        What it is, for the error (e.g. ``"corrupt JPEG frame (812 bytes)"``).

    Returns
    -------
    (numpy.ndarray, str or None)
        The (H, W, 3) RGB uint8 image, and what the decoder said of a frame it could decode
        only by repairing it (e.g. "Corrupt JPEG data: premature end of data segment": the
        rest of the picture grey, as libjpeg has always done), else None.

    Raises
    ------
    InputError
        ``what``, for bytes that do not decode (the decoder's words after a colon).
    """
    if simplejpeg is None:
        return _decode_opencv(data, what), None
    try:
        return simplejpeg.decode_jpeg(data, "RGB", strict=True), None
    except ValueError as exc:       # a warning (the data repaired) or an error (none)
        said = " ".join(str(exc).split())
    try:
        # strict=False: what libjpeg itself does with a damaged scan (decode what it can)
        return simplejpeg.decode_jpeg(data, "RGB", strict=False), said
    except ValueError:              # a damaged header or tables: nothing to decode
        raise InputError(f"{what}: {said[:200]}") from None


def _decode_opencv(data: bytes, what: str) -> np.ndarray:
    try:
        bgr = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    except cv2.error:       # a header declaring more than OpenCV decodes
        bgr = None
    if bgr is None:
        raise InputError(what)
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


def _say_on_stderr(line: str) -> None:
    import sys
    print(line, file=sys.stderr, flush=True)


class _opencv_log_quiet:
    """OpenCV's log silenced while a decode runs (it prints "[ERROR:0@0.1] global
    loadsave.cpp ... imread_(...)" for a corrupt file, which the caller says in one line of
    its own); the level it had is put back, unless it was already silent or another decode
    changed it meanwhile (so concurrent decodes never leave it silenced for good)."""

    def __enter__(self):
        import cv2.utils.logging as cv_log
        self.log = cv_log
        self.before = cv_log.getLogLevel()
        if self.before != cv_log.LOG_LEVEL_SILENT:
            cv_log.setLogLevel(cv_log.LOG_LEVEL_SILENT)
        return self

    def __exit__(self, *exc):
        if self.before != self.log.LOG_LEVEL_SILENT:
            self.log.setLogLevel(self.before)
        return False


def _opencv_can_open(path: str) -> bool:
    """Whether OpenCV opens ``path`` by name (its C++ ``fopen``: any path here, but a
    non-ASCII one on Windows)."""
    return os.name != "nt" or path.isascii()


#: How OpenEXR's bindings begin what they print about a file they cannot read.
_EXR_SAYS = "Warning: Exception raised"


@contextmanager
def _exr_words():
    """OpenEXR's bindings say why a file's pixels cannot be read with Python's ``print``
    ("Warning: Exception raised reading pixel data ..."), on stdout, where it would land in
    the JSON a command prints. Within the block what is printed is taken (the yielded
    function returns the library's lines so far, for the error); anything else printed
    meanwhile is written on afterwards, in order."""
    taken = io.StringIO()

    def said() -> list:
        return [ln for ln in taken.getvalue().splitlines() if ln.startswith(_EXR_SAYS)]
    try:
        with redirect_stdout(taken):
            yield said
    finally:
        others = [ln for ln in taken.getvalue().splitlines() if not ln.startswith(_EXR_SAYS)]
        if others:
            print("\n".join(others))


def _read_exr(path: str) -> np.ndarray:
    """The pixels of an OpenEXR file through OpenEXR's bindings, in every layout (scan
    lines, tiles, mipmaps: level 0, multi-part: the part :func:`exr_layout` picks)."""
    try:
        import OpenEXR
    except ImportError:  # pragma: no cover - a declared dependency
        raise InputError("reading .exr needs the 'openexr' package: pip install openexr")
    layout = exr_layout(path)
    try:
        with _exr_words() as said, OpenEXR.File(path) as f:
            index = layout.part if layout is not None else 0
            if index >= len(f.parts):       # the library read no pixels (it said why)
                words = "".join(f" (the library: {w[len(_EXR_SAYS):].strip()[:200]})"
                                for w in said()[:1])
                raise InputError(f"cannot read {path}: the OpenEXR file's pixels cannot be "
                                 "read (truncated or corrupt: a broken chunk table or "
                                 f"missing mipmap levels){words}; copy it again")
            part = f.parts[index]
            channels = part.channels
            if "RGB" in channels:
                rgb = channels["RGB"].pixels
            elif "RGBA" in channels:
                rgb = channels["RGBA"].pixels[..., :3]
            elif all(k in channels for k in "RGB"):
                rgb = np.stack([channels[k].pixels for k in "RGB"], axis=-1)
            elif "Y" in channels:
                rgb = np.repeat(channels["Y"].pixels[..., None], 3, axis=2)
            else:
                raise InputError(f"{path}: no RGB or Y channels (has {sorted(channels)})")
    except InputError:
        raise
    except MemoryError:
        raise TransientReadError(f"cannot read {path}: out of memory decoding it") from None
    except Exception as exc:
        raise InputError(f"cannot read {path} as OpenEXR: {exc}") from None
    return np.ascontiguousarray(rgb, dtype=np.float32)


#: The ``envmap`` attribute's values (ImfEnvmap.h: ENVMAP_LATLONG = 0, ENVMAP_CUBE = 1).
ENVMAP_KINDS = {0: "latlong", 1: "cube"}


@dataclass(frozen=True)
class ExrLayout:
    """What an OpenEXR file's header says (:func:`exr_layout`), read by OpenEXR's bindings.

    ``envmap``: "latlong", "cube", or None (no ``envmap`` attribute, or a value OpenEXR does
    not define: ``envmap_value`` then holds it); ``part``: the part whose pixels are read
    (the first with R, G and B, else the first with Y, else the first) of ``parts``;
    ``width`` × ``height``: that part's data window; ``tiled``, ``levels`` ("one",
    "mipmap", "ripmap": level 0, the full size, is what is read)."""

    path: str
    envmap: str | None
    envmap_value: int | None
    parts: int
    part: int
    part_name: str
    width: int
    height: int
    tiled: bool
    levels: str
    why: str = "the first"          # why that part: "the first with R, G and B", …

    @property
    def notes(self) -> list:
        """Legal but odd (warnings, one line each): an envmap value OpenEXR does not define,
        several parts of which one is read."""
        out = []
        if self.envmap is None and self.envmap_value is not None:
            out.append(f"{self.path}: its header's envmap = {self.envmap_value} is none that "
                       "OpenEXR defines (0 latlong, 1 cube) and is ignored: --projection "
                       "auto reads the file as an equirect (give --projection exr-latlong "
                       "or exr-cube if it is one)")
        if self.parts > 1:
            name = f" {self.part_name!r}" if self.part_name else ""
            out.append(f"{self.path}: an OpenEXR file of {self.parts} parts; reading part "
                       f"{self.part}{name} ({self.width}×{self.height}, {self.why}) alone")
        return out


def exr_layout(path) -> ExrLayout | None:
    """The header of an OpenEXR file (:class:`ExrLayout`), read by OpenEXR's bindings
    (scan lines, tiles, mipmaps, multi-part alike); None for what is not a regular OpenEXR
    file (another format, a FIFO or a device, which is never opened here: it may block) or
    a header the library cannot read (reading its pixels then says why, in one line)."""
    path = os.fspath(path)
    try:
        if not stat.S_ISREG(os.stat(path).st_mode):
            return None
        with open(path, "rb") as f:
            if f.read(4) != EXR_MAGIC:
                return None
        import OpenEXR
        with OpenEXR.File(path, header_only=True) as f:
            headers = [dict(part.header) for part in f.parts]
            names = [part.name() for part in f.parts]
    except Exception:           # OSError, the library's own errors: said when read
        return None
    if not headers:
        return None

    def channels(h):
        return {c.name for c in h.get("channels", ())}
    rgb = [i for i, h in enumerate(headers) if set("RGB") <= channels(h)]
    grey = [i for i, h in enumerate(headers) if "Y" in channels(h)]
    pick, why = ((rgb[0], "the first with R, G and B") if rgb else
                 (grey[0], "the first with Y") if grey else (0, "the first"))
    h = headers[pick]
    try:
        value = h.get("envmap")
        value = None if value is None else int(value)
        (x0, y0), (x1, y1) = h["dataWindow"]
        tiles = h.get("tiles")
        levels = "one"
        if tiles is not None:
            levels = {0: "one", 1: "mipmap", 2: "ripmap"}.get(int(tiles.mode), "one")
    except (KeyError, TypeError, ValueError):     # a header the library let through oddly
        return None
    return ExrLayout(path, ENVMAP_KINDS.get(value), value, len(headers), pick,
                     names[pick] or "", int(x1 - x0 + 1), int(y1 - y0 + 1),
                     tiles is not None, levels, why)


def exr_envmap(path) -> str | None:
    """The ``envmap`` of an OpenEXR file's header (:func:`exr_layout`): "latlong", "cube",
    or None (not OpenEXR, no such attribute, or a value OpenEXR does not define)."""
    layout = exr_layout(path)
    return None if layout is None else layout.envmap


def check_complete(path: str, data: bytes):
    """Refuse a JPEG or PNG that ends before its image does (a copy cut short): OpenCV
    would decode the part it has and fill the rest with grey, and libjpeg/libpng would
    print their own words. For a PNG, returns what libpng is given (see
    :func:`_check_png_chunks`); else None."""
    if data[:3] == b"\xff\xd8\xff":                                    # JPEG
        tail = data.rstrip(b"\x00\r\n ")
        scan = data.rfind(b"\xff\xda")                     # the last start of scan
        if not tail.endswith(b"\xff\xd9") and (scan < 0 or data.rfind(b"\xff\xd9") < scan):
            raise InputError(f"cannot read {path}: the JPEG is truncated (it ends before its "
                             "end-of-image marker); copy it again")
    elif data[:8] == PNG_MAGIC:
        return _check_png_chunks(path, data)
    return None


#: IHDR's legal bit depths for each colour type (PNG specification, 11.2.2).
_PNG_DEPTHS = {0: (1, 2, 4, 8, 16), 2: (8, 16), 3: (1, 2, 4, 8), 4: (8, 16), 6: (8, 16)}


def _check_png_chunks(path: str, data: bytes):
    """Walk a PNG's chunks to IEND and refuse, in our words, what libpng would refuse with
    its own on stderr (libpng prints straight to descriptor 2, unthrottled and not ours to
    route; issue 41): a file cut short; a critical chunk (IHDR, PLTE, IDAT, IEND) failing its
    CRC (a bit flipped on the way); an IHDR with fields out of the specification; a palette
    image without PLTE; no IDAT; an image stream without a zlib header; an unknown critical
    chunk.

    Returns
    -------
    bytes or memoryview
        What libpng is given: ``data`` itself, or, when the file has ancillary chunks, the
        file without them (libpng warns of a bad one, e.g. "iCCP: known incorrect sRGB
        profile"; none changes the RGB that OpenCV returns: gamma, colour profiles and text
        are not applied, and transparency is dropped).

    What this cannot see without inflating the whole image first (twice the decode's
    work): a compressed stream damaged under valid CRCs (a broken encoder), which libpng
    still reports itself."""
    import struct
    import zlib
    pos, view = 8, memoryview(data)
    keep, dropped, seen = [view[:8]], False, set()

    def corrupt(why):
        return InputError(f"cannot read {path}: the PNG is corrupt ({why})")
    while True:
        if pos + 12 > len(data):
            raise InputError(f"cannot read {path}: the PNG is truncated (no IEND chunk); "
                             "copy it again")
        length, kind = struct.unpack_from(">I4s", data, pos)
        end = pos + 12 + length
        name = kind.decode("latin-1")
        if length > 0x7FFFFFFF or end > len(data):
            raise InputError(f"cannot read {path}: the PNG is truncated (its "
                             f"{name!r} chunk ends beyond the file); copy it again")
        if kind[0] & 0x20:                            # ancillary: lowercase first letter
            dropped = True
            pos = end
            continue
        crc = struct.unpack_from(">I", data, end - 4)[0]
        if zlib.crc32(view[pos + 4:end - 4]) != crc:
            raise corrupt(f"its {name!r} chunk fails its CRC check")
        if kind == b"IHDR":
            if pos != 8 or length != 13:
                raise corrupt("its IHDR chunk is not the first, or not 13 bytes")
            depth, colour, method, filtering, interlace = data[pos + 16:pos + 21]
            if (depth not in _PNG_DEPTHS.get(colour, ()) or method or filtering
                    or interlace > 1):
                raise corrupt(f"its header declares bit depth {depth}, colour type "
                              f"{colour}, methods {method}/{filtering}/{interlace}")
        elif kind == b"IDAT" and b"IDAT" not in seen and length >= 2:
            cmf, flg = data[pos + 8:pos + 10]
            if cmf & 0x0F != 8 or cmf >> 4 > 7 or (cmf << 8 | flg) % 31 or flg & 0x20:
                raise corrupt("its image data has no zlib header")
        elif kind == b"PLTE" and (length % 3 or not 0 < length <= 768):
            raise corrupt(f"its palette has {length} bytes")
        elif kind not in (b"IHDR", b"PLTE", b"IDAT", b"IEND"):
            raise corrupt(f"an unknown critical chunk {name!r}")
        elif kind == b"IEND":
            if b"IHDR" not in seen or b"IDAT" not in seen:
                raise corrupt("no image data" if b"IHDR" in seen else "no IHDR chunk")
            if data[24 + 1] == 3 and b"PLTE" not in seen:
                raise corrupt("a palette image without its palette")
            keep.append(view[pos:end])
            return b"".join(keep) if dropped else data
        seen.add(kind)
        keep.append(view[pos:end])
        pos = end


#: Scan lines per chunk of each OpenEXR compression (by its number in the header).
_EXR_LINES = {0: 1, 1: 1, 2: 1, 3: 16, 4: 32, 5: 16, 6: 32, 7: 32, 8: 32, 9: 256}


def _check_exr_complete(path: str, data: bytes) -> None:
    """Refuse a single-part scan-line OpenEXR file (``data``: its bytes) whose last chunk
    lies beyond its end (a copy cut short): the OpenEXR library would print its own words
    on stdout. Other layouts (tiled, multi-part, deep) are left to the library."""
    import struct
    short = InputError(f"cannot read {path}: the OpenEXR file is truncated or corrupt; copy "
                       "it again")
    if len(data) < 8:
        raise short
    flags = data[5]
    if flags & 0x1E:                         # tiled, long names, deep or multi-part
        return
    pos, attrs = 8, {}
    try:
        while data[pos] != 0:
            end = data.index(b"\0", pos)
            name = data[pos:end]
            end2 = data.index(b"\0", end + 1)
            size = struct.unpack_from("<i", data, end2 + 1)[0]
            attrs[name] = data[end2 + 5:end2 + 5 + size]
            pos = end2 + 5 + size
        pos += 1
        xmin, ymin, xmax, ymax = struct.unpack("<4i", attrs[b"dataWindow"])
        lines = _EXR_LINES.get(attrs[b"compression"][0])
        if lines is None:
            return
        chunks = (ymax - ymin) // lines + 1
        offsets = struct.unpack_from(f"<{chunks}Q", data, pos)
        last = max(offsets)
        size = struct.unpack_from("<i", data, last + 4)[0]
    except (IndexError, KeyError, ValueError, struct.error):
        raise short from None
    if min(offsets) <= pos or last + 8 + size > len(data):
        raise short
