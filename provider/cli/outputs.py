"""Where a command writes: the one rule for every output path (``-o``, ``--out``,
``--write-vectors``), checked before any work, and the atomic write that follows it.

An output file may be a new name or an existing regular file that is none of the command's
inputs; it is then written whole beside its target (a temporary file in the same folder) and
renamed over it (``os.replace``), so that a reader never sees half a file. Refused, in one
line (:class:`~provider.core.errors.InputError`, exit 2), before anything is read or
computed: a device, a FIFO, a socket or a folder where a file is wanted; a folder that is
missing or cannot be written; any of the command's inputs, by identity (``st_dev``,
``st_ino``: the same file by another path, a symbolic or a hard link), not by name. A
symbolic link is written through: its target is replaced, the link stays. ``-``: standard
output, where the command offers it; else refused rather than taken for a file named ``-``.
An output folder (``--out``) may exist as a folder or be created under a folder that can be
written.
"""
from __future__ import annotations

import contextlib
import os
import re
import secrets
import stat
import tempfile

from ..core.errors import InputError

#: Standard output, where a command offers it.
STDOUT = "-"
#: A descriptor's name (/dev/stdout, /dev/fd/3, /proc/self/fd/1): whatever it is open on
#: (a terminal, a pipe, the file a shell redirected) is not the command's to replace.
_DESCRIPTOR = re.compile(r"/dev/(stdin|stdout|stderr|fd/\d+)|/proc/(self|\d+)/fd/")


def file_kind(mode: int) -> str:
    """What a stat mode is, in a user's words (for a refusal)."""
    for test, name in ((stat.S_ISDIR, "folder"), (stat.S_ISCHR, "character device"),
                       (stat.S_ISBLK, "block device"), (stat.S_ISFIFO, "FIFO (a named pipe)"),
                       (stat.S_ISSOCK, "socket"), (stat.S_ISLNK, "symbolic link"),
                       (stat.S_ISREG, "file")):
        if test(mode):
            return name
    return "special file"


def _identity(st: os.stat_result) -> tuple:
    return st.st_dev, st.st_ino


def input_files(inputs) -> dict:
    """``{(st_dev, st_ino): description}`` of the inputs that exist, ``inputs`` being
    ``(path, description)`` pairs (paths that do not exist, or are not paths, are skipped:
    their reading says what is wrong with them)."""
    found = {}
    for path, description in inputs:
        if not path:
            continue
        try:
            found.setdefault(_identity(os.stat(path)), description)
        except (OSError, ValueError):
            pass
    return found


def _probe_folder(folder: str) -> str | None:
    """Why a new file cannot be made in ``folder``, or None: tried for real (a temporary
    file, removed at once), since root passes every permission check that ``os.access``
    would make, yet cannot write under /proc or on a read-only mount."""
    try:
        fd, probe = tempfile.mkstemp(dir=folder, prefix=".shlight-probe-")
    except OSError as exc:
        return exc.strerror or str(exc)
    os.close(fd)
    os.unlink(probe)
    return None


class OutputFile:
    """A checked output file (:func:`output_file`): :meth:`write` or :meth:`writing`."""

    def __init__(self, path: str, target: str | None, name: str, inputs: dict):
        self.path = path            # as the user gave it
        self.target = target        # the file replaced: the link's target; None: stdout
        self.name = name            # how a message names it ("-o cam.json")
        self.inputs = inputs

    @property
    def stdout(self) -> bool:
        return self.target is None

    def write(self, data) -> None:
        """``data`` (bytes, or text as UTF-8) written whole, or to standard output."""
        data = data.encode("utf-8") if isinstance(data, str) else data
        if self.stdout:
            import sys
            from .feedback import output_error
            try:
                sys.stdout.buffer.write(data)
                sys.stdout.buffer.flush()
            except BrokenPipeError:
                raise
            except OSError as exc:
                raise output_error(exc) from None
            return
        with self.writing() as tmp:
            with open(tmp, "wb") as f:
                f.write(data)

    @contextlib.contextmanager
    def writing(self):
        """A temporary path beside the target, with its extension (writers that choose the
        format by name, such as matplotlib's, keep choosing it), for the caller to write;
        renamed over the target when the block ends, after checking once more that the
        target is still a regular file or absent and none of the inputs; removed if
        anything fails."""
        if self.stdout:
            raise InputError(f"{self.name}: this output cannot go to standard output")
        folder, base = os.path.split(self.target)
        stem, ext = os.path.splitext(base)
        while True:
            tmp = os.path.join(folder, f".{stem}.{secrets.token_hex(4)}.part{ext}")
            try:        # 0o666 less the umask: the mode a new file gets from open()
                os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC,
                                 0o666))
                break
            except FileExistsError:
                continue
            except OSError as exc:
                raise InputError(f"cannot write {self.path}: {exc.strerror or exc}") from None
        try:
            yield tmp
            fd = os.open(tmp, os.O_RDONLY | os.O_CLOEXEC)
            try:
                os.fsync(fd)        # the data on disk before the name points at it
            finally:
                os.close(fd)
            try:
                st = os.lstat(self.target)
            except FileNotFoundError:
                st = None
            if st is not None:      # it may have changed since the check, before any work
                self._refuse_existing(st)
                os.chmod(tmp, stat.S_IMODE(st.st_mode))     # a replaced file keeps its mode
            os.replace(tmp, self.target)
        except OSError as exc:
            raise InputError(f"cannot write {self.path}: {exc.strerror or exc}") from None
        finally:
            with contextlib.suppress(OSError):
                os.unlink(tmp)

    def _refuse_existing(self, st, product: str = "output", example: str = "",
                         option: str = "") -> None:
        if not stat.S_ISREG(st.st_mode):
            raise InputError(f"{self.name} is a {file_kind(st.st_mode)}, not a file: give a "
                             "file's name" + (f" (standard output: {option} -)" if option
                                              else ""))
        clash = self.inputs.get(_identity(st))
        if clash:
            raise InputError(f"{self.name} is {clash}: the {product} would overwrite it; "
                             f"give another file{example}")


def output_file(path: str, *, option: str = "-o", inputs=(), product: str = "output",
                extension: str | None = None, stdout: bool = False,
                name: str | None = None, example: str | None = None) -> OutputFile:
    """The output file ``path`` (given as ``option``), checked before any work.

    ``inputs``: the command's input files, ``(path, description)`` pairs ("the input image");
    ``product``: what would overwrite an input ("cube"), and ``extension`` its usual file
    extension, for the message's example; ``stdout``: whether ``-`` means standard output;
    ``name``: how messages name the output (default ``"{option} {path}"``); ``example``:
    the other name a message suggests (default: the same name, with ``extension``)."""
    name = name or f"{option} {path}"
    if path == STDOUT:
        if stdout:
            return OutputFile(path, None, name, {})
        raise InputError(f"{name}: this command writes files, not standard output; give a "
                         "file's name")
    if not path:
        raise InputError(f"{option} is empty: give a file's name")
    target = os.path.realpath(path) if os.path.islink(path) else os.path.abspath(path)
    out = OutputFile(path, target, name, input_files(inputs))
    stem = os.path.splitext(path)[0]
    ext = extension or os.path.splitext(path)[1]
    if example is None:
        example = f"{option} {stem}{ext}" if f"{stem}{ext}" != path else \
            f"{option} {stem}-out{ext}"
    example = f", e.g. {example}" if example else ""
    if _DESCRIPTOR.fullmatch(os.path.abspath(path)) or _DESCRIPTOR.match(target):
        raise InputError(f"{name} is an open descriptor, not a file: give a file's name"
                         + (f" (standard output: {option} -)" if stdout else ""))
    try:
        st = os.stat(target)
    except (FileNotFoundError, NotADirectoryError):     # said below, of its folder
        st = None
    except OSError as exc:          # a loop of links, no permission
        raise InputError(f"cannot write {path}: {exc.strerror or exc}") from None
    if st is not None:
        if stat.S_ISDIR(st.st_mode):
            raise InputError(f"{name} is a folder: give a file's name in it"
                             + (f", e.g. {option} {os.path.join(path, 'out' + ext)}"
                                if ext else ""))
        out._refuse_existing(st, product, example, option if stdout else "")
    folder = os.path.dirname(target)
    if not os.path.isdir(folder):
        above = folder
        while not os.path.lexists(above):
            above = os.path.dirname(above)
        if not os.path.isdir(above):
            raise InputError(f"{name}: cannot write it: {above} is a file, not a folder")
        raise InputError(f"{name}: cannot write it: no folder {folder}")
    why = _probe_folder(folder)
    if why:
        raise InputError(f"{name}: cannot write in {folder} ({why})")
    return out


def output_folder(path: str, *, option: str = "--out", holds: str = "the results") -> str:
    """The output folder ``path``, checked before any work: an existing folder that can be
    written, or a new one under the nearest folder that exists and can be written (it is
    created by the command when it writes). ``holds``: what it is for, for the message."""
    if not path:
        raise InputError(f"{option} is empty: give a folder for {holds}")
    if path == STDOUT:
        raise InputError(f"{option} -: give a folder for {holds} (not standard output)")
    try:
        st = os.stat(path)
    except (FileNotFoundError, NotADirectoryError):     # said below, of the folder above
        st = None
    except OSError as exc:
        raise InputError(f"{option} {path}: {exc.strerror or exc}") from None
    if st is not None:
        if not stat.S_ISDIR(st.st_mode):
            raise InputError(f"{option} {path} is a {file_kind(st.st_mode)}; give a folder "
                             f"for {holds}")
        why = _probe_folder(path)
        if why:
            raise InputError(f"{option} {path}: cannot write under {path} ({why})")
        return path
    existing = os.path.abspath(path)
    while not os.path.lexists(existing):
        existing = os.path.dirname(existing)
    if not os.path.isdir(existing):
        raise InputError(f"{option} {path}: cannot write under {existing} (a "
                         f"{_kind_of(existing)}, not a folder)")
    try:            # a folder made and removed at once: root cannot create one under /proc
        os.rmdir(tempfile.mkdtemp(dir=existing, prefix=".shlight-probe-"))
    except OSError as exc:
        raise InputError(f"{option} {path}: cannot write under {existing} "
                         f"({exc.strerror or exc})") from None
    return path


def _kind_of(path: str) -> str:
    try:
        return file_kind(os.stat(path).st_mode)
    except OSError:
        return "broken link"


def frame_inputs(texts, description: str) -> list:
    """``(path, description)`` of ``FRAME[@SECONDS]`` arguments (for :func:`output_file`)."""
    from .frames import parse_frame
    found = []
    for text in texts:
        try:
            found.append((parse_frame(text)[0], description))
        except InputError:          # said by the reading, in its words
            found.append((text, description))
    return found


#: The engine's options that name a file it reads, and how a message names each.
ENGINE_INPUT_FILES = (("camera", "the --camera file"), ("lens", "the --lens file"),
                      ("calibration", "the --calibration file"))


def engine_inputs(args) -> list:
    """``(path, description)`` of the files the engine options name (``--camera``,
    ``--lens`` where it is a file, ``--calibration``)."""
    return [(getattr(args, attr), what) for attr, what in ENGINE_INPUT_FILES
            if isinstance(getattr(args, attr, None), str)]
