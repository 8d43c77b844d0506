"""Safe file output: one policy for every file the toolkit writes.

Every file the toolkit writes goes through this module:

* :func:`check_output_file` / :func:`check_output_dir` validate an output location before any
  computation starts, so a bad ``--out`` fails at once with one line: the output must not be
  one of the command's inputs (by any path that resolves to it: a hard link, ``sub/../spec.toml``,
  a relative or absolute spelling), must not be a symbolic link nor lie in a folder given
  through a symbolic link (a link is never written through), and the nearest existing folder
  must be writable.
* :func:`write_text_atomic` / :func:`write_bytes_atomic` write a temporary file in the target's
  folder, ``fsync`` it, then ``os.replace`` it over the target (atomic on POSIX and Windows
  within one file system) and ``fsync`` the folder. A failure at any point (full disk,
  permissions, Ctrl-C, ``SIGTERM``) removes the temporary file and the folders it created,
  and leaves an existing target untouched.
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

import hashlib
import os
import re
import shutil
import tempfile
import unicodedata
from pathlib import Path
from types import TracebackType
from typing import Iterable, Iterator

from glocal_verify.errors import GlocalVerifyError
from glocal_verify.runtime.processes import defer_stop_signals

__all__ = [
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
    """Refuse a symbolic link at ``path`` or at the folder it is written into."""
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


def check_output_file(path: str | Path, *, inputs: Iterable[str | Path] = (), what: str = "--out") -> Path:
    """Validate a file to be written, before any computation: refuse a symbolic link (or a
    file in a folder given through one), a folder, one of ``inputs`` (e.g. the spec being
    verified, by any path that resolves to it) and an unwritable folder.

    Parameters
    ----------
    path : path
        The output file.
    inputs : iterable of path
        Files the command reads; the output must not be any of them.
    what : str
        How the location is named in messages (the option).

    Returns
    -------
    Path
        ``path`` as a :class:`~pathlib.Path`.

    Raises
    ------
    OutputError
        One line naming the problem.
    """
    p = Path(path)
    if not str(path) or "\x00" in str(path):
        raise OutputError(f"{what}: {str(path)!r} is not a file name")
    _refuse_symlink(p, what)
    if p.is_dir():
        raise OutputError(f"{what}: {p} is a folder, expected a file name")
    _refuse_input(p, inputs, what)
    _check_folder_writable(p.parent if str(p.parent) else Path("."), what)
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
    if not str(path) or "\x00" in str(path):
        raise OutputError(f"{what}: {str(path)!r} is not a folder name")
    _refuse_symlink(p, what)
    _refuse_input(p, inputs, what)
    if os.path.lexists(p) and not p.is_dir():
        raise OutputError(f"{what}: {p} exists and is not a folder")
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
        for chunk in (data,) if isinstance(data, (bytes, bytearray, memoryview)) else data:
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


def write_bytes_atomic(path: str | Path, data: bytes | Iterable[bytes]) -> Path:
    """Write ``data`` to ``path`` atomically (temporary file in the same folder, fsync,
    ``os.replace``, fsync of the folder).

    Either the complete new content is in place or the previous file (if any) is untouched; on
    any failure or interrupt the temporary file, and the folders this call created for it, are
    removed. A symbolic link at ``path`` (or as the folder it is written into) is refused,
    never written through. Missing parent folders are created.

    Parameters
    ----------
    path : path
    data : bytes or iterable of bytes
        The content, or its chunks (written as the iterable yields them; an exception or stop
        signal while it runs leaves the previous file untouched).

    Returns
    -------
    Path

    Raises
    ------
    OutputError
        The file cannot be written (message names the path and the system's reason).
    """
    p = Path(path)
    _refuse_symlink(p, str(p))
    folder = p.parent if str(p.parent) else Path(".")
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


def write_text_atomic(path: str | Path, text: str | Iterable[str]) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically (:func:`write_bytes_atomic`).

    Parameters
    ----------
    path : path
    text : str or iterable of str
        The text, or its chunks (streamed: a long report is never held whole).

    Returns
    -------
    Path
    """
    return write_bytes_atomic(path, _encoded(text))


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
        try:
            for name in self._names:
                final = self.dest / name
                if final.is_dir() and not final.is_symlink():
                    raise OutputError(f"{final}: is a folder; cannot replace it with a file")
            with defer_stop_signals():
                for name in self._names:
                    os.replace(stage / name, self.dest / name)
                    self.written.append(self.dest / name)
                moved = True
                _fsync_dir(self.dest)
        except OSError as exc:
            raise _os_error(self.dest, exc) from None
        finally:
            self._discard(created_too=not moved and not self.written)
