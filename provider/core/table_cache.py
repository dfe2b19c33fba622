"""Built tables kept on disk, so that a restart costs a file read instead of a build.

A projector's pixel-independent tables (SH9's per-pixel weights and lens folds, the cube's
overlap and prefilter operators, the lights' mid-copy geometry) cost seconds to build on a
desktop and most of a minute on a 1 GHz edge board, at every start. :func:`cached` builds
them once per key and keeps them in the user's cache directory (``$SHLIGHT_CACHE_DIR``, else
``$XDG_CACHE_HOME/shlight``, else ``~/.cache/shlight``; ``tables/`` in it);
``SHLIGHT_TABLE_CACHE=0`` (the commands' ``--no-table-cache``) turns it off.

Key: the kind of table, what it is built from (frame size, the projection's whole state:
lens, calibration, options) and a hash of this package's source, so a new version or an
edited module never reads an old table.

File: a header (format version, kind, key, the byte ranges of the arrays, a CRC-32 of
everything after the header) then a pickle (protocol 5) whose arrays lie out of band,
64-byte aligned. A load maps the file and the arrays are read-only views of the mapping:
no copy, pages shared between processes and paged in on use. A file that fails any check
(another format, another key, a bad checksum, a short file, an unpickling error) is
rebuilt and replaced, and the caller gets one line saying so; files of other versions of the
code are removed when a new one is written. Writes go to a temporary
file in the same folder, then ``os.replace``: a reader never sees half a file, and two
processes writing the same key each leave a whole one.

Only names of ``numpy`` and ``provider`` (and plain containers) are unpickled: a table file
is data, not code.
"""
from __future__ import annotations

import builtins
import ctypes
import ctypes.util
import functools
import hashlib
import io
import json
import mmap
import os
import pickle
import tempfile
import zlib
from pathlib import Path

#: The file layout's version: a file of another is rebuilt.
FORMAT = 1
MAGIC = b"SHLIGHT-TABLES\n"
ALIGN = 64
#: Environment switches: the folder, and "0" to turn the cache off.
DIR_ENV, SWITCH_ENV = "SHLIGHT_CACHE_DIR", "SHLIGHT_TABLE_CACHE"
#: numpy's functions that pickles of arrays and scalars call.
_NUMPY_MAKERS = {"_frombuffer", "_reconstruct", "scalar"}
_SAFE_BUILTINS = {"list", "dict", "tuple", "set", "frozenset", "slice", "complex", "bytearray",
                  "range", "int", "float", "bool", "str", "bytes"}


def enabled() -> bool:
    """Whether tables are read from and written to disk (``SHLIGHT_TABLE_CACHE`` not 0)."""
    return os.environ.get(SWITCH_ENV, "1").strip().lower() not in ("0", "off", "no", "false")


def cache_dir() -> Path:
    """The folder that holds the table files."""
    root = os.environ.get(DIR_ENV)
    if not root:
        xdg = os.environ.get("XDG_CACHE_HOME")
        root = Path(xdg) / "shlight" if xdg else Path.home() / ".cache" / "shlight"
    return Path(root) / "tables"


@functools.lru_cache(maxsize=1)
def code_hash() -> str:
    """A hash of this package's version and of every source file of the maths: tables
    built by other code are never read."""
    from provider import __version__
    h = hashlib.sha256(__version__.encode())
    core = Path(__file__).resolve().parent
    for path in sorted(core.rglob("*.py")):
        h.update(str(path.relative_to(core)).encode())
        h.update(path.read_bytes())
    return h.hexdigest()


def state_of(obj, skip=("_weights", "progress", "warnings")) -> tuple:
    """What a projection object is made of (its class and attributes, built tables and
    call-backs left out): the part of a key that names a lens and its options."""
    return (type(obj).__module__, type(obj).__qualname__,
            {k: v for k, v in sorted(vars(obj).items()) if k not in skip})


def key_of(kind: str, *parts) -> str | None:
    """The hex key of ``kind`` built from ``parts`` (anything picklable), or None where the
    parts cannot be pickled (such tables are not cached)."""
    try:
        blob = pickle.dumps((FORMAT, kind, code_hash(), parts), protocol=4)
    except Exception:  # noqa: BLE001 - a call-back or a handle in the options: not cached
        return None
    return hashlib.sha256(blob).hexdigest()


def cached(kind: str, key: str | None, build, notes: list | None = None):
    """``build()``'s result for ``key``: read from the cache where a valid file is there,
    else built (and written, where the cache is on). A file found invalid is rebuilt and
    replaced, with one line appended to ``notes``; so is a cache that cannot be written."""
    if key is None or not enabled():
        return _built(build)
    version = code_hash()[:12]
    path = cache_dir() / f"{kind}-{version}-{key[:32]}.tables"
    if path.exists():
        try:
            return _load(path, kind, key)
        except Exception as exc:  # noqa: BLE001 - any damage: the file is rebuilt
            if notes is not None:
                notes.append(f"the table cache file {path} could not be used ({exc}); "
                             "the tables were rebuilt and the file replaced")
    value = _built(build)
    try:
        _save(path, kind, key, value)
        _prune(path.parent, kind, version)
    except OSError as exc:
        if notes is not None:
            notes.append(f"the table cache cannot be written ({exc}); the tables are "
                         "rebuilt at every start (--no-table-cache turns the cache off)")
    return value


def _built(build):
    value = build()
    release_free_memory()
    return value


def _save(path: Path, kind: str, key: str, value) -> None:
    buffers = []
    blob = pickle.dumps(value, protocol=5, buffer_callback=buffers.append)
    raws = [b.raw() for b in buffers]
    ranges, at = [], _aligned(len(blob))
    for raw in raws:
        ranges.append([at, raw.nbytes])
        at = _aligned(at + raw.nbytes)
    crc = zlib.crc32(blob)
    for raw in raws:
        crc = zlib.crc32(raw, crc)
    header = json.dumps({"format": FORMAT, "kind": kind, "key": key, "pickle": len(blob),
                         "buffers": ranges, "crc32": crc}).encode()
    path.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=".tables")
    try:
        with os.fdopen(fd, "wb") as fh:
            head = MAGIC + len(header).to_bytes(8, "little") + header
            fh.write(head + bytes(_aligned(len(head)) - len(head)))
            fh.write(blob)
            written = len(blob)
            for (offset, _), raw in zip(ranges, raws):
                fh.write(bytes(offset - written))
                fh.write(raw)
                written = offset + raw.nbytes
            fh.write(bytes(_aligned(written) - written))
        os.replace(tmp, path)     # atomic: readers see the old file or the whole new one
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def _prune(folder: Path, kind: str, version: str) -> None:
    """Removes ``kind``'s files written by other versions of the code: never read again, and
    an edge board's card should not fill up with them, one set an upgrade."""
    for old in folder.glob(f"{kind}-*.tables"):
        if old.name.split("-")[1] != version:
            try:
                old.unlink()
            except OSError:
                pass


def _load(path: Path, kind: str, key: str):
    with open(path, "rb") as fh:
        size = os.fstat(fh.fileno()).st_size
        if size < len(MAGIC) + 8:
            raise ValueError("a short file")
        mapped = mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ)
    view = memoryview(mapped)
    if bytes(view[:len(MAGIC)]) != MAGIC:
        raise ValueError("not a table file")
    n = int.from_bytes(view[len(MAGIC):len(MAGIC) + 8], "little")
    head_end = len(MAGIC) + 8 + n
    if head_end > size:
        raise ValueError("a short file")
    header = json.loads(bytes(view[len(MAGIC) + 8:head_end]))
    if header.get("format") != FORMAT:
        raise ValueError(f"table format {header.get('format')}, this version reads {FORMAT}")
    if header.get("kind") != kind or header.get("key") != key:
        raise ValueError("the file holds other tables")
    base = _aligned(head_end)
    blob_end = base + int(header["pickle"])
    ranges = [(base + int(o), int(m)) for o, m in header["buffers"]]
    if blob_end > size or any(o + m > size for o, m in ranges):
        raise ValueError("a short file")
    crc = zlib.crc32(view[base:blob_end])
    for o, m in ranges:
        crc = zlib.crc32(view[o:o + m], crc)
    if crc != header["crc32"]:
        raise ValueError("a bad checksum")
    return _Unpickler(io.BytesIO(view[base:blob_end]),
                      buffers=[view[o:o + m] for o, m in ranges]).load()


class _Unpickler(pickle.Unpickler):
    """Unpickles numpy arrays, this package's classes and plain containers, nothing else: no
    function is called but numpy's array and scalar constructors."""

    def find_class(self, module, name):
        if module == "builtins" and name in _SAFE_BUILTINS:
            return getattr(builtins, name)
        if module.split(".")[0] in ("numpy", "provider", "collections"):
            found = super().find_class(module, name)
            if isinstance(found, type) or (module.startswith("numpy") and name in _NUMPY_MAKERS):
                return found
        raise pickle.UnpicklingError(f"{module}.{name} is not a table")


def _aligned(n: int) -> int:
    return -(-n // ALIGN) * ALIGN


def release_free_memory() -> None:
    """Hands the heap's free pages back to the system after a build (glibc's
    ``malloc_trim``): a build's temporaries, freed, otherwise stay resident in the
    allocator's arenas (about 200 MB after a Theta S cube). A no-op elsewhere."""
    trim = _malloc_trim()
    if trim is not None:
        trim(0)


@functools.lru_cache(maxsize=1)
def _malloc_trim():
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        return libc.malloc_trim
    except (OSError, AttributeError):
        return None
