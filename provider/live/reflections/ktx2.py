"""A KTX 2.0 writer for uncompressed RGBA16F cube maps with mips (the reflection cube's
container on every transport: docs/contract.md §12, "Transport").

KTX 2.0 is the Khronos texture container (https://registry.khronos.org/KTX/specs/2.0/
ktxspec.v2.html). No kept Python library writes it (PyPI has a parser, pyktx2, and Basis
Universal image converters), so this module writes the small uncompressed subset it needs,
byte for byte after the specification; tests/live/reflections/test_ktx2.py reads the files back with readers
we did not write (the npm package ktx-parse; three.js's KTX2Loader).

What is written, for ``mips[k]`` of shape (6, n_k, n_k, 3) (faces +X −X +Y −Y +Z −Z, row
i = t, column j = s: the OpenGL cube-map order, docs/contract.md §12):

* ``vkFormat`` 97 (``VK_FORMAT_R16G16B16A16_SFLOAT``), ``typeSize`` 2, ``pixelWidth`` =
  ``pixelHeight`` = n_0, ``pixelDepth`` 0, ``layerCount`` 0, ``faceCount`` 6,
  ``levelCount`` len(mips), no supercompression;
* a Basic Data Format Descriptor (RGBSDA, BT.709 primaries, linear transfer, four 16-bit
  float samples R G B A);
* key/value data: ``KTXwriter`` and the caller's keys (sorted by their UTF-8 bytes, as the
  specification requires), each value a NUL-terminated UTF-8 string;
* the levels, smallest first in the file (the specification's order), each 8-byte aligned;
  within a level the six faces in order, each face its rows from row 0, each texel R G B A
  as IEEE half floats, little-endian, A = 1.

Nothing here does I/O: bytes in memory.
"""
from __future__ import annotations

import struct

import numpy as np

from ...core.errors import InputError

IDENTIFIER = b"\xabKTX 20\xbb\r\n\x1a\n"
VK_FORMAT_R16G16B16A16_SFLOAT = 97
TEXEL_BYTES = 8             # 4 channels × 2 bytes
_HEADER = struct.Struct("<9I")              # vkFormat ... supercompressionScheme
_INDEX = struct.Struct("<4I2Q")             # dfd offset/length, kvd offset/length, sgd
_LEVEL = struct.Struct("<3Q")               # byteOffset, byteLength, uncompressedByteLength


def _data_format_descriptor() -> bytes:
    """The DFD of VK_FORMAT_R16G16B16A16_SFLOAT (KTX 2.0 §3.10; Khronos Data Format 1.3
    §5): one basic block, four samples, as libktx's vk2dfd writes it."""
    samples = b""
    float_signed = 0x80 | 0x40                  # KHR_DF_SAMPLE_DATATYPE_FLOAT | _SIGNED
    for i, channel in enumerate((0, 1, 2, 15)):  # R, G, B, A (KHR_DF_CHANNEL_RGBSDA_*)
        samples += struct.pack("<HBB4BII", 16 * i, 15, float_signed | channel, 0, 0, 0, 0,
                               0xBF800000, 0x3F800000)   # -1.0f, 1.0f: the float range
    block_size = 24 + len(samples)
    block = struct.pack("<IHH", 0, 2, block_size)           # Khronos, basic, version 2
    block += bytes((1, 1, 1, 0))        # KHR_DF_MODEL_RGBSDA, BT709, LINEAR, straight alpha
    block += bytes((0, 0, 0, 0))        # texel block 1×1×1×1
    block += bytes((TEXEL_BYTES, 0, 0, 0, 0, 0, 0, 0))      # bytesPlane0..7
    block += samples
    return struct.pack("<I", 4 + len(block)) + block


def _key_value_data(key_values: dict[str, str]) -> bytes:
    out = b""
    for key in sorted(key_values, key=lambda k: k.encode()):
        entry = key.encode() + b"\0" + str(key_values[key]).encode() + b"\0"
        out += struct.pack("<I", len(entry)) + entry + b"\0" * (-len(entry) % 4)
    return out


def check_cube_mips(mips) -> list[np.ndarray]:
    """The mips as float32 (6, n, n, 3) arrays halving from n_0, or :class:`InputError`."""
    arrays = [np.asarray(m) for m in mips]
    if not arrays:
        raise InputError("a cube map needs at least one mip")
    n0 = arrays[0].shape[1] if arrays[0].ndim == 4 else 0
    for k, m in enumerate(arrays):
        n = n0 >> k
        if m.shape != (6, n, n, 3) or n < 1:
            raise InputError(f"mip {k} has shape {m.shape}, expected (6, {n}, {n}, 3)")
    return arrays


def beyond_half_float(mips) -> tuple[int, int]:
    """(texels with a channel beyond ±65504, all texels) over every mip: what
    :func:`encode_cube` stores as ±65504, counted so that a caller can say so."""
    arrays = check_cube_mips(mips)
    over = sum(int((np.abs(m) > 65504.0).any(-1).sum()) for m in arrays)
    return over, sum(m.shape[0] * m.shape[1] * m.shape[2] for m in arrays)


def encode_cube(mips, key_values: dict[str, str] | None = None) -> bytes:
    """A KTX 2.0 file (bytes) of an RGB cube map with its mips: see the module docstring.
    Values beyond the half-float range become ±65504 (never infinity); NaN is refused."""
    arrays = check_cube_mips(mips)
    levels = []
    for m in arrays:
        if not np.all(np.isfinite(m)):
            raise InputError("a cube map with NaN or infinite texels cannot be encoded")
        rgba = np.ones(m.shape[:3] + (4,), np.float16)
        rgba[..., :3] = np.clip(m, -65504.0, 65504.0)
        levels.append(rgba.astype("<f2").tobytes())
    kv = {"KTXwriter": "shlight", **(key_values or {})}
    dfd, kvd = _data_format_descriptor(), _key_value_data(kv)
    n0, count = arrays[0].shape[1], len(arrays)
    head_size = len(IDENTIFIER) + _HEADER.size + _INDEX.size + count * _LEVEL.size
    dfd_offset = head_size
    kvd_offset = dfd_offset + len(dfd)
    end = kvd_offset + len(kvd)
    offsets = [0] * count
    for k in reversed(range(count)):               # smallest level first in the file
        end += -end % TEXEL_BYTES                  # lcm(texel block size 8, 4)
        offsets[k] = end
        end += len(levels[k])
    out = bytearray(end)
    header = _HEADER.pack(VK_FORMAT_R16G16B16A16_SFLOAT, 2, n0, n0, 0, 0, 6, count, 0)
    index = _INDEX.pack(dfd_offset, len(dfd), kvd_offset, len(kvd), 0, 0)
    head = IDENTIFIER + header + index + b"".join(
        _LEVEL.pack(offsets[k], len(levels[k]), len(levels[k])) for k in range(count))
    out[:head_size] = head
    out[dfd_offset:kvd_offset] = dfd
    out[kvd_offset:kvd_offset + len(kvd)] = kvd
    for k in range(count):
        out[offsets[k]:offsets[k] + len(levels[k])] = levels[k]
    return bytes(out)


def cube_bytes(size: int, mip_count: int, key_values: dict[str, str] | None = None) -> int:
    """The length of :func:`encode_cube`'s file for a cube of ``size`` with ``mip_count``
    mips, without building it (the bench's bytes per update)."""
    mips = [np.zeros((6, size >> k, size >> k, 3), np.float32) for k in range(mip_count)]
    return len(encode_cube(mips, key_values))
