"""Safe file output: one policy for every file the toolkit writes.

Every file the toolkit writes goes through this module:

* :func:`check_output_file` / :func:`check_output_dir` validate an output location before any
  computation starts, so a bad ``--out`` fails at once with one line: the output must not be
  one of the command's inputs (by any path that resolves to it: a hard link, ``sub/../spec.toml``,
  a relative or absolute spelling), must not be a symbolic link nor lie in a folder given
  through a symbolic link (a link is never written through), no name in it may be longer than
  the file system allows, its folder must exist (a command that creates folders says so and
  asks for it: ``create_parents=True``) and be writable, and its kind must be one a report can
  be written to (:class:`TargetKind`).
* :func:`write_text_atomic` / :func:`write_bytes_atomic` write a regular file through a
  temporary file in the target's folder, ``fsync`` it, then ``os.replace`` it over the target
  (atomic on POSIX and Windows within one file system) and ``fsync`` the folder. A failure at
  any point (full disk, permissions, Ctrl-C, ``SIGTERM``) removes the temporary file and the
  folders it created, and leaves an existing target untouched.
* A target that exists and is not a regular file is never renamed over: a character device
  (``/dev/null``, a terminal) or a FIFO -- directly or through a symbolic link such as
  ``/dev/stdout`` -- is opened and written in place (a FIFO waits for its reader, saying so on
  stderr, and a stop signal ends the wait); a block device, a socket or a folder is refused.
  ``-`` (:data:`STDOUT`) writes to standard output.
* :class:`OutputFolder` stages several files in a hidden sub-folder of the destination and
  moves them into place only when every file was written (all files or none); the moves are
  renames within one file system and are shielded from stop signals. On any failure the
  staging folder, and the destination itself when the block created it, are removed: no
  ``.glocal-partial-*`` folder and no empty output folder is left.
* :func:`safe_component` turns any text from a specification (system, mode, cluster or case
  name) into one harmless file-name component, and :meth:`OutputFolder.path` asserts that every
  resolved path stays inside the destination folder: no spec field can steer where files go.

Layer: runtime; imports :mod:`glocal_verify.errors` and :mod:`.processes`.
"""

from __future__ import annotations

import errno
import fcntl
import hashlib
import os
import re
import shutil
import stat
import sys
import tempfile
import unicodedata
from enum import Enum
from pathlib import Path
from types import TracebackType
from typing import Iterable, Iterator

from glocal_verify.errors import GlocalVerifyError
from glocal_verify.runtime.processes import defer_stop_signals

__all__ = [
    "STDOUT",
    "TargetKind",
    "target_kind",
    "OutputError",
    "safe_component",
    "write_text_atomic",
    "write_bytes_atomic",
    "check_output_file",
    "check_output_dir",
    "same_file",
    "make_folders",
    "remove_empty_folders",
    "OutputFolder",
]

#: names Windows reserves for devices (a component equal to one of them, any case, any extension)
_RESERVED = frozenset({"con", "prn", "aux", "nul"} | {f"com{i}" for i in range(10)} | {f"lpt{i}" for i in range(10)})

#: prefix of staging folders and temporary files (hidden, recognisable)
_TMP_PREFIX = ".glocal-partial-"

#: the output name that means standard output (the Unix convention)
STDOUT = "-"

#: longest path the checks accept (bytes), when the system does not say (Linux's PATH_MAX)
_PATH_MAX = 4096
#: longest file name the checks accept (bytes), when the file system does not say
_NAME_MAX = 255


class TargetKind(Enum):
    """What an output location is now (:func:`target_kind`), which decides how it is written."""

    MISSING = "missing"
    FILE = "regular file"
    FOLDER = "folder"
    CHARACTER_DEVICE = "character device"
    BLOCK_DEVICE = "block device"
    FIFO = "FIFO"
    SOCKET = "socket"
    LINK = "symbolic link"
    STDOUT = "standard output"

    @property
    def in_place(self) -> bool:
        """Written in place (opened, never renamed over nor created): a character device or a FIFO."""
        return self in (TargetKind.CHARACTER_DEVICE, TargetKind.FIFO)


def _kind_of_mode(mode: int) -> TargetKind:
    if stat.S_ISREG(mode):
        return TargetKind.FILE
    if stat.S_ISDIR(mode):
        return TargetKind.FOLDER
    if stat.S_ISCHR(mode):
        return TargetKind.CHARACTER_DEVICE
    if stat.S_ISBLK(mode):
        return TargetKind.BLOCK_DEVICE
    if stat.S_ISFIFO(mode):
        return TargetKind.FIFO
    if stat.S_ISSOCK(mode):
        return TargetKind.SOCKET
    return TargetKind.LINK if stat.S_ISLNK(mode) else TargetKind.FILE


def target_kind(path: str | Path) -> TargetKind:
    """The kind of the output location ``path``.

    A symbolic link counts as its target's kind when that target is a character device or a
    FIFO (``/dev/stdout``, ``/dev/fd/1``: written in place, nothing is created or replaced),
    and as :attr:`TargetKind.LINK` otherwise (refused: a link is never written through).
    ``-`` is :attr:`TargetKind.STDOUT`.

    Parameters
    ----------
    path : path
    """
    if str(path) == STDOUT:
        return TargetKind.STDOUT
    try:
        mode = os.lstat(path).st_mode
    except (OSError, ValueError):  # none, a too-long name, a file in place of a folder: no such target
        return TargetKind.MISSING
    if stat.S_ISLNK(mode):
        try:
            final = _kind_of_mode(os.stat(path).st_mode)
        except (OSError, ValueError):
            return TargetKind.LINK
        return final if final.in_place else TargetKind.LINK
    return _kind_of_mode(mode)


class OutputError(GlocalVerifyError):
    """An output location that cannot or must not be written (one line, exit code 2)."""


def safe_component(text: str, max_len: int = 64) -> str:
    """One safe, readable file-name component derived from ``text``.

    The result matches ``[A-Za-z0-9][A-Za-z0-9._-]*``: no path separators (``/``, ``\\``),
    no ``..``, no NUL or control characters, no leading dot, at most ``max_len`` characters,
    and never a reserved device name. Text that already satisfies this is returned unchanged;
    otherwise the result is a slug of the text followed by ``-`` and the first 8 hex digits of
    the SHA-256 of the original text, so distinct names stay distinct and the mapping is
    stable from run to run. Empty text (or text with nothing usable) gives ``unnamed-<hash>``
    (``unnamed`` for the empty string).

    Parameters
    ----------
    text : str
        Any text (e.g. a spec's ``name``).
    max_len : int
        Largest length of the result (at least 16).

    Examples
    --------
    >>> safe_component("case-1")
    'case-1'
    >>> safe_component("../../x")[:2]
    'x-'
    """
    if max_len < 16:
        raise ValueError("max_len must be at least 16")
    if not text:
        return "unnamed"
    if _is_safe(text, max_len):
        return text
    digest = hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest()[:8]
    norm = unicodedata.normalize("NFKD", text).encode("ascii", "ignore").decode("ascii")
    slug = re.sub(r"[^A-Za-z0-9._-]+|\.{2,}", "-", norm)
    slug = re.sub(r"[-.]*-[-.]*", "-", slug).strip("-._")
    slug = slug[: max_len - 9].rstrip("-._") or "unnamed"
    return f"{slug}-{digest}"


def _is_safe(text: str, max_len: int) -> bool:
    return (
        len(text) <= max_len
        and re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9._-]*", text) is not None
        and ".." not in text
        and not text.endswith(".")
        and text.split(".")[0].lower() not in _RESERVED
    )


# --------------------------------------------------------------------------------------------
# checks before computing


def _nearest_existing(path: Path) -> Path:
    p = path
    while not os.path.lexists(p):
        if p.parent == p:
            break
        p = p.parent
    return p


def _check_folder_writable(folder: Path, what: str) -> None:
    anc = _nearest_existing(folder)
    if not anc.is_dir():
        raise OutputError(f"{what}: {anc} is not a folder")
    if not os.access(anc, os.W_OK | os.X_OK):
        raise OutputError(f"{what}: folder {anc} is not writable")


def _refuse_symlink(path: Path, what: str) -> None:
    """Refuse a symbolic link at ``path`` or at the folder it is written into (a link to a
    character device or a FIFO, written in place, is not refused: :func:`target_kind`)."""
    if target_kind(path).in_place:
        return
    if path.is_symlink():
        raise OutputError(f"{what}: {path} is a symbolic link (to {os.readlink(path)}); give the real path")
    parent = path.parent
    if str(parent) not in ("", ".") and parent.is_symlink():
        raise OutputError(f"{what}: folder {parent} is a symbolic link (to {os.readlink(parent)}); give the real path")


def same_file(a: str | Path, b: str | Path) -> bool:
    """Whether the paths ``a`` and ``b`` name the same file: the same inode (hard links, any
    spelling of an existing file) or the same resolved path (``sub/../x``, symbolic links, a
    file yet to be written).

    Parameters
    ----------
    a, b : path
    """
    try:
        if os.path.exists(a) and os.path.exists(b) and os.path.samefile(a, b):
            return True
    except OSError:
        pass
    try:
        return os.path.realpath(a) == os.path.realpath(b)
    except (OSError, ValueError):
        return False


def _refuse_input(path: Path, inputs: Iterable[str | Path], what: str) -> None:
    for src in inputs:
        if same_file(path, src):
            raise OutputError(f"{what}: {path} is an input of this command ({src}); refusing to overwrite it")


def _shown(path: str | Path, limit: int = 80) -> str:
    """``path`` for a message: whole when short, else its start and end (one readable line)."""
    text = str(path)
    return text if len(text) <= limit else f"{text[: limit // 2 - 2]}...{text[-(limit // 2 - 2):]}"


def _name_max(folder: Path) -> int:
    try:
        return int(os.pathconf(_nearest_existing(folder), "PC_NAME_MAX"))
    except (OSError, ValueError):
        return _NAME_MAX


def _check_lengths(path: Path, what: str) -> None:
    """Refuse a path the operating system would reject for its length (ENAMETOOLONG), before any work."""
    whole = len(os.fsencode(os.path.abspath(path)))
    if whole >= _PATH_MAX:
        raise OutputError(f"{what}: the path {_shown(path)} is {whole} bytes long; the system allows at most {_PATH_MAX - 1}")
    limit = _name_max(path.parent if str(path.parent) else Path("."))
    for part in path.parts:
        n = len(os.fsencode(part))
        if n > limit:
            raise OutputError(f"{what}: the name {_shown(part, 40)} is {n} bytes long; a file name may have at most {limit}")


def _refuse_kind(p: Path, kind: TargetKind, what: str, expected: str = "file") -> None:
    if kind is TargetKind.FOLDER and expected == "file":
        raise OutputError(f"{what}: {_shown(p)} is a folder, expected a file name")
    if kind is TargetKind.BLOCK_DEVICE:
        raise OutputError(f"{what}: {_shown(p)} is a block device (a disk); refusing to write a report over it")
    if kind is TargetKind.SOCKET:
        raise OutputError(f"{what}: {_shown(p)} is a socket; a report can be written to a file, a character device, a FIFO or - (standard output)")


def check_output_file(
    path: str | Path, *, inputs: Iterable[str | Path] = (), what: str = "--out", create_parents: bool = False
) -> Path:
    """Validate a file to be written, before any computation.

    Accepted: ``-`` (standard output); a new or existing regular file in an existing,
    writable folder; an existing character device or FIFO that can be opened for writing
    (written in place, :func:`write_bytes_atomic`). Refused, in one line: an empty name; a
    name or path longer than the file system allows; a symbolic link (or a file in a folder
    given through one) unless it leads to a character device or a FIFO; a folder, a block
    device or a socket; one of ``inputs`` (e.g. the spec being verified, by any path that
    resolves to it); a read-only file; a missing folder (unless ``create_parents``: a command
    that documents that it creates folders); an unwritable folder.

    Parameters
    ----------
    path : path
        The output file.
    inputs : iterable of path
        Files the command reads; the output must not be any of them.
    what : str
        How the location is named in messages (the option).
    create_parents : bool
        Missing folders will be created by the writer (default: refused).

    Returns
    -------
    Path
        ``path`` as a :class:`~pathlib.Path`.

    Raises
    ------
    OutputError
        One line naming the problem.
    """
    if str(path) == STDOUT:
        return Path(STDOUT)
    p = Path(path)
    if not str(path) or "\x00" in str(path):
        raise OutputError(f"{what}: {_shown(repr(str(path)))} is not a file name")
    _check_lengths(p, what)
    kind = target_kind(p)
    _refuse_kind(p, kind, what)
    _refuse_symlink(p, what)
    _refuse_input(p, inputs, what)
    if kind.in_place:
        if not os.access(p, os.W_OK):
            raise OutputError(f"{what}: {_shown(p)} ({kind.value}) is not writable")
        return p
    if kind is TargetKind.FILE and not os.access(p, os.W_OK):
        raise OutputError(f"{what}: {_shown(p)} is read-only; refusing to replace it")
    folder = p.parent if str(p.parent) else Path(".")
    if not create_parents and not os.path.isdir(folder):
        anc = _nearest_existing(folder)
        if os.path.lexists(folder) or not anc.is_dir():
            raise OutputError(f"{what}: {_shown(anc)} is not a folder")
        raise OutputError(f"{what}: the folder {_shown(folder)} does not exist; create it first")
    _check_folder_writable(folder, what)
    return p


def check_output_dir(path: str | Path, *, inputs: Iterable[str | Path] = (), what: str = "--out") -> Path:
    """Validate a folder to be written into, before any computation: refuse a symbolic link
    (or a folder inside one given through a link), an existing non-folder (an input file
    among them) and a location whose nearest existing folder is not writable.

    Parameters
    ----------
    path : path
    inputs : iterable of path
        Files the command reads (named in the message when the folder is one of them).
    what : str
        How the location is named in messages.

    Returns
    -------
    Path

    Raises
    ------
    OutputError
    """
    p = Path(path)
    if str(path) == STDOUT:
        raise OutputError(f"{what}: this output is a folder of several files; - (standard output) takes one file only")
    if not str(path) or "\x00" in str(path):
        raise OutputError(f"{what}: {_shown(repr(str(path)))} is not a folder name")
    _check_lengths(p, what)
    _refuse_symlink(p, what)
    _refuse_input(p, inputs, what)
    if os.path.lexists(p) and not p.is_dir():
        raise OutputError(f"{what}: {_shown(p)} exists and is not a folder")
    _check_folder_writable(p, what)
    return p


def make_folders(folder: Path) -> list[Path]:
    """Create ``folder`` and its missing parents; return those created, deepest first (for
    :func:`remove_empty_folders` when the work they were made for fails).

    Parameters
    ----------
    folder : Path
    """
    missing: list[Path] = []
    p = folder
    while not os.path.lexists(p) and p.parent != p:
        missing.append(p)
        p = p.parent
    folder.mkdir(parents=True, exist_ok=True)
    return missing


def remove_empty_folders(folders: Iterable[Path]) -> None:
    """Remove each folder (deepest first) if it is empty; stop at the first that is not.

    Parameters
    ----------
    folders : iterable of Path
    """
    for f in folders:
        try:
            f.rmdir()
        except OSError:
            return


# --------------------------------------------------------------------------------------------
# atomic files


def _os_error(path: Path, exc: OSError) -> OutputError:
    return OutputError(f"{path}: cannot write ({exc.strerror or exc})")


def _fsync_dir(folder: Path) -> None:
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def _write_file(path: Path, data: bytes | Iterable[bytes]) -> None:
    """Write ``data`` (bytes, or chunks of bytes written as they come) to a new file ``path`` (which must not exist) and fsync it."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        for chunk in _chunks(data):
            view = memoryview(chunk)
            while view:
                n = os.write(fd, view)
                view = view[n:]
        os.fsync(fd)
    finally:
        os.close(fd)


def _encoded(text: str | Iterable[str]) -> bytes | Iterator[bytes]:
    """UTF-8 of ``text``, or of each chunk of it as it comes (a long report is never held twice)."""
    if isinstance(text, str):
        return text.encode("utf-8")
    return (chunk.encode("utf-8") for chunk in text)


def _chunks(data: bytes | Iterable[bytes]) -> Iterable[bytes | bytearray | memoryview]:
    return (data,) if isinstance(data, (bytes, bytearray, memoryview)) else data


def _write_stdout(data: bytes | Iterable[bytes]) -> None:
    """Write ``data`` to standard output (its bytes when it has them: a figure or a .mat file)."""
    stream = sys.stdout
    buffer = getattr(stream, "buffer", None)
    stream.flush()
    for chunk in _chunks(data):
        if buffer is not None:
            buffer.write(bytes(chunk))
        else:  # a captured text stream
            stream.write(bytes(chunk).decode("utf-8", "replace"))
    (buffer if buffer is not None else stream).flush()


def _open_in_place(path: Path, kind: TargetKind) -> int:
    """Open an existing character device or FIFO for writing, without creating or truncating.

    A FIFO without a reader is waited for (one line on stderr says so); a stop signal ends the
    wait as it ends any other work (the open is retried after a signal whose handler returns,
    PEP 475, and interrupted by one whose handler raises)."""
    flags = os.O_WRONLY | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_CLOEXEC", 0)
    if kind is TargetKind.FIFO:
        try:
            fd = os.open(path, flags | os.O_NONBLOCK)
        except OSError as exc:
            if exc.errno != errno.ENXIO:  # ENXIO: no reader yet
                raise
            from glocal_verify.runtime.lines import write_line

            write_line(f"waiting for a reader of the FIFO {_shown(path)} (Ctrl-C stops)")
            return os.open(path, flags)
        fcntl.fcntl(fd, fcntl.F_SETFL, fcntl.fcntl(fd, fcntl.F_GETFL) & ~os.O_NONBLOCK)
        return fd
    return os.open(path, flags)


def _write_in_place(path: Path, kind: TargetKind, data: bytes | Iterable[bytes]) -> Path:
    """Write ``data`` into the existing character device or FIFO ``path`` (never replaced)."""
    try:
        fd = _open_in_place(path, kind)
    except OSError as exc:
        raise _os_error(path, exc) from None
    try:
        for chunk in _chunks(data):
            view = memoryview(chunk)
            while view:
                n = os.write(fd, view)
                view = view[n:]
    except BrokenPipeError:
        raise OutputError(f"{_shown(path)}: the reader of the FIFO went away before the report was written") from None
    except OSError as exc:
        raise _os_error(path, exc) from None
    finally:
        os.close(fd)
    return path


def write_bytes_atomic(path: str | Path, data: bytes | Iterable[bytes], *, create_parents: bool = False) -> Path:
    """Write ``data`` to ``path``: a regular file atomically, a device or FIFO in place.

    A regular file (new or existing) is written as a temporary file in the same folder,
    fsynced, moved over the target with ``os.replace`` and the folder fsynced: either the
    complete new content is in place or the previous file (if any) is untouched; on any
    failure or interrupt the temporary file, and the folders this call created for it, are
    removed. An existing character device or FIFO (:attr:`TargetKind.in_place`) is opened and
    written in place, never replaced. ``-`` writes to standard output. A symbolic link at
    ``path`` (or as the folder it is written into) that does not lead to a device or FIFO, a
    folder, a block device and a socket are refused, never written through.

    Parameters
    ----------
    path : path
    data : bytes or iterable of bytes
        The content, or its chunks (written as the iterable yields them; an exception or stop
        signal while it runs leaves the previous file untouched).
    create_parents : bool
        Create missing folders (for commands that document it); default: a missing folder is
        refused.

    Returns
    -------
    Path

    Raises
    ------
    OutputError
        The file cannot be written (message names the path and the system's reason).
    """
    if str(path) == STDOUT:
        _write_stdout(data)
        return Path(STDOUT)
    p = Path(path)
    kind = target_kind(p)
    _refuse_kind(p, kind, str(p))
    if kind.in_place:
        return _write_in_place(p, kind, data)
    _refuse_symlink(p, str(p))
    folder = p.parent if str(p.parent) else Path(".")
    if not create_parents and not os.path.isdir(folder):
        raise OutputError(f"{_shown(p)}: the folder {_shown(folder)} does not exist")
    created: list[Path] = []
    try:
        created = make_folders(folder)
        fd, tmp_name = tempfile.mkstemp(prefix=_TMP_PREFIX + p.name[:32] + ".", suffix=".tmp", dir=folder)
    except OSError as exc:
        remove_empty_folders(created)
        raise _os_error(p, exc) from None
    except BaseException:
        remove_empty_folders(created)
        raise
    tmp = Path(tmp_name)
    try:
        os.close(fd)
        os.unlink(tmp)
        _write_file(tmp, data)
        os.replace(tmp, p)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        remove_empty_folders(created)
        raise _os_error(p, exc) from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        remove_empty_folders(created)
        raise
    _fsync_dir(folder)
    return p


def write_text_atomic(path: str | Path, text: str | Iterable[str], *, create_parents: bool = False) -> Path:
    """Write ``text`` (UTF-8) to ``path`` (:func:`write_bytes_atomic`: a regular file
    atomically, a character device or FIFO in place, ``-`` to standard output).

    Parameters
    ----------
    path : path
    text : str or iterable of str
        The text, or its chunks (streamed: a long report is never held whole).
    create_parents : bool
        Create missing folders (default: refused).

    Returns
    -------
    Path
    """
    return write_bytes_atomic(path, _encoded(text), create_parents=create_parents)


# --------------------------------------------------------------------------------------------
# all-or-nothing folders


class OutputFolder:
    """Write several files into ``dest`` with all-or-nothing semantics.

    Use as a context manager::

        with OutputFolder("glocal-out/paper19") as out:
            out.write_text("simulation-case-2.json", text)
            out.write_bytes("simulation-case-2.png", png)
        out.written  # the final paths, once every file is in place

    Files are staged in a hidden folder ``dest/.glocal-partial-*``; on leaving the block
    without an exception they are renamed into ``dest`` (replacing files of the same name,
    shielded from stop signals), otherwise the staging folder is deleted and ``dest`` is
    exactly as before (removed again if the block created it). File names must be single safe
    components (:func:`safe_component` of any text that comes from a spec) or one of
    ``names`` (chosen on the command line); the resolved target of every name is checked to
    lie inside ``dest`` and not to be one of ``inputs``.

    Parameters
    ----------
    dest : path
        The destination folder (created if missing; a symbolic link is refused).
    inputs : iterable of path
        Files the command reads: no output may replace one of them.
    names : iterable of str
        File names the user chose (e.g. the name of ``--out``), accepted although they are
        not :func:`safe_component` text; each must still be one path component.
    """

    def __init__(self, dest: str | Path, *, inputs: Iterable[str | Path] = (), names: Iterable[str] = ()) -> None:
        self.dest = Path(dest)
        self.inputs = tuple(inputs)
        self.user_names = frozenset(names)
        self.written: list[Path] = []
        self._names: list[str] = []
        self._stage: Path | None = None
        self._created: list[Path] = []

    def __enter__(self) -> "OutputFolder":
        check_output_dir(self.dest, inputs=self.inputs, what=str(self.dest))
        try:
            self._created = make_folders(self.dest)
            self._stage = Path(tempfile.mkdtemp(prefix=_TMP_PREFIX, dir=self.dest))
        except OSError as exc:
            remove_empty_folders(self._created)
            raise _os_error(self.dest, exc) from None
        except BaseException:
            remove_empty_folders(self._created)
            raise
        return self

    def path(self, name: str) -> Path:
        """The final path of file ``name`` in the destination (checked to stay inside it).

        Parameters
        ----------
        name : str
            A single file-name component, unchanged by ``safe_component(name, 255)``, or one
            of the ``names`` given to the constructor.

        Raises
        ------
        ValueError
            ``name`` is not a safe component or resolves outside the folder.
        OutputError
            ``name`` is one of the command's inputs.
        """
        if name in self.user_names:
            if not name or name in (".", "..") or os.sep in name or (os.altsep and os.altsep in name) or "\x00" in name:
                raise ValueError(f"output file name {name!r} is not one path component")
        elif safe_component(name, 255) != name:
            raise ValueError(f"unsafe output file name {name!r}; pass it through safe_component")
        root = self.dest.resolve()
        # the final component is not resolved: an existing symbolic link there is replaced
        # by the rename (never written through)
        target = Path(os.path.normpath(root / name))
        if target.parent != root:
            raise ValueError(f"output file {name!r} would leave the folder {root}")
        _refuse_input(self.dest / name, self.inputs, str(self.dest / name))
        return self.dest / name

    def write_bytes(self, name: str, data: bytes | Iterable[bytes]) -> Path:
        """Stage ``data`` as file ``name``; return its final path.

        Parameters
        ----------
        name : str
        data : bytes or iterable of bytes
            The content, or its chunks (streamed).
        """
        final = self.path(name)
        if self._stage is None:
            raise RuntimeError("OutputFolder used outside its with block")
        staged = self._stage / name
        try:
            staged.unlink(missing_ok=True)
            _write_file(staged, data)
        except OSError as exc:
            raise _os_error(final, exc) from None
        if name not in self._names:
            self._names.append(name)
        return final

    def write_text(self, name: str, text: str | Iterable[str]) -> Path:
        """Stage ``text`` (UTF-8) as file ``name``; return its final path.

        Parameters
        ----------
        name : str
        text : str or iterable of str
            The text, or its chunks (streamed).
        """
        return self.write_bytes(name, _encoded(text))

    def _discard(self, *, created_too: bool) -> None:
        if self._stage is not None:
            shutil.rmtree(self._stage, ignore_errors=True)
            self._stage = None
        if created_too:
            remove_empty_folders(self._created)

    def __exit__(self, et: type[BaseException] | None, ev: BaseException | None, tb: TracebackType | None) -> None:
        if et is not None or self._stage is None:
            self._discard(created_too=True)
            return
        stage = self._stage
        moved = False
        kinds = {name: target_kind(self.dest / name) for name in self._names}
        try:
            for name, kind in kinds.items():
                _refuse_kind(self.dest / name, kind, str(self.dest / name))
            with defer_stop_signals():
                for name in self._names:
                    if not kinds[name].in_place:
                        os.replace(stage / name, self.dest / name)
                        self.written.append(self.dest / name)
                moved = True
                _fsync_dir(self.dest)
            for name in self._names:  # outside the deferred block: a FIFO may wait for its reader
                if kinds[name].in_place:
                    with open(stage / name, "rb") as staged:
                        _write_in_place(self.dest / name, kinds[name], iter(lambda: staged.read(1 << 20), b""))
                    self.written.append(self.dest / name)
        except OSError as exc:
            raise _os_error(self.dest, exc) from None
        finally:
            self._discard(created_too=not moved and not self.written)
