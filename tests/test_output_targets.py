"""Output targets of every kind: a device or a FIFO is written in place and stays what it was.

Every device, FIFO, socket and link here is made in a temporary folder: the tests never touch
the machine's own files (``/dev/null`` included). The character devices are new nodes with the
numbers of the null device (1, 3) and of the full device (1, 7).
"""

from __future__ import annotations

import os
import socket
import stat
import threading
from pathlib import Path
from typing import Any, Callable

import pytest

from glocal_verify.cli import main
from glocal_verify.runtime.files import (
    STDOUT,
    OutputError,
    OutputFolder,
    TargetKind,
    check_output_dir,
    check_output_file,
    target_kind,
    write_bytes_atomic,
    write_text_atomic,
)

from test_cli_outputs import _one_line, _spec


def _char_device(folder: Path, name: str = "null", minor: int = 3) -> Path:
    p = folder / name
    try:
        os.mknod(p, stat.S_IFCHR | 0o666, os.makedev(1, minor))
    except PermissionError:
        pytest.skip("making a device node needs CAP_MKNOD (root)")
    try:  # a folder on a file system mounted nodev cannot open its device nodes
        os.close(os.open(p, os.O_WRONLY))
    except PermissionError:
        pytest.skip("the temporary folder's file system does not open device nodes (nodev)")
    return p


def _is_char_device(p: Path) -> bool:
    return stat.S_ISCHR(os.lstat(p).st_mode)


class FifoReader:
    """A FIFO in ``folder`` and a thread that reads everything written into it."""

    def __init__(self, folder: Path, name: str = "pipe") -> None:
        self.path = folder / name
        os.mkfifo(self.path)
        self.data = b""
        self._thread = threading.Thread(target=self._read, daemon=True)

    def _read(self) -> None:
        with open(self.path, "rb") as f:
            self.data = f.read()

    def __enter__(self) -> "FifoReader":
        self._thread.start()
        return self

    def __exit__(self, *exc: Any) -> None:
        if exc[0] is not None:  # the writer failed, perhaps before opening: release the reader
            os.close(os.open(self.path, os.O_WRONLY | os.O_NONBLOCK))
        self._thread.join(timeout=60)
        assert not self._thread.is_alive(), "the FIFO was never closed by its writer"


#: commands with a single-file --out (argv before the target; the spec is put at {spec})
WRITERS: dict[str, list[str]] = {
    "verify": ["verify", "{spec}", "--only", "privacy.*", "--quiet", "--out"],
    "verify json": ["verify", "{spec}", "--only", "privacy.connected", "--format", "json", "--quiet", "--out"],
    "audit": ["audit", "{spec}", "--max-attackers", "1", "--quiet", "--out"],
    "audit --figure": ["audit", "{spec}", "--max-attackers", "1", "--quiet", "--figure"],
    "place-observers": ["place-observers", "{spec}", "--suspected", "interior", "--quiet", "--out"],
    "draw": ["draw", "{spec}", "--out"],
    "export": ["export", "{spec}", "--no-thresholds", "--format", "json", "--quiet", "--out"],
    "findings": ["findings", "--out"],
}


def _argv(name: str, tmp_path: Path, target: str | Path) -> list[str]:
    spec = _spec(tmp_path)
    return [a.format(spec=spec, specs=spec.parent) for a in WRITERS[name]] + [str(target)]


@pytest.mark.parametrize("name", sorted(WRITERS))
def test_every_output_into_a_character_device_leaves_it_a_device(name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    dev = _char_device(tmp_path)
    if name == "audit --figure":
        dev = dev.rename(tmp_path / "null.svg")
    assert main(_argv(name, tmp_path, dev)) == 0, capsys.readouterr().err
    assert _is_char_device(dev) and sorted(p.name for p in tmp_path.iterdir()) == sorted([dev.name, "specs"])
    assert f"wrote {dev}" in capsys.readouterr().err


@pytest.mark.parametrize("name", sorted(WRITERS))
def test_every_output_into_a_fifo_reaches_its_reader_and_leaves_it_a_fifo(name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    reader = FifoReader(tmp_path, "pipe.svg" if name == "audit --figure" else "pipe")
    with reader:
        rc = main(_argv(name, tmp_path, reader.path))
        assert rc == 0, capsys.readouterr().err
    assert stat.S_ISFIFO(os.lstat(reader.path).st_mode)
    assert len(reader.data) > 100
    if name in ("verify", "findings"):
        assert reader.data.startswith(b"# ")


def test_a_full_device_is_one_line_and_stays_a_device(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    full = _char_device(tmp_path, "full", minor=7)
    assert main(_argv("verify", tmp_path, full)) == 2
    assert "No space left on device" in _one_line(capsys.readouterr().err)
    assert _is_char_device(full)


def test_a_link_to_a_character_device_is_written_through_and_stays_a_link(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    dev = _char_device(tmp_path)
    link = tmp_path / "stdout-like"
    link.symlink_to(dev)
    assert main(_argv("verify", tmp_path, link)) == 0, capsys.readouterr().err
    assert link.is_symlink() and os.readlink(link) == str(dev) and _is_char_device(dev)


def test_a_fifo_without_a_reader_waits_for_one_and_says_so(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    fifo = tmp_path / "late"
    os.mkfifo(fifo)
    got: dict[str, bytes] = {}

    def late_reader() -> None:
        import time

        time.sleep(0.5)
        with open(fifo, "rb") as f:
            got["data"] = f.read()

    t = threading.Thread(target=late_reader, daemon=True)
    t.start()
    write_text_atomic(fifo, "report\n")
    t.join(10)
    assert got["data"] == b"report\n" and stat.S_ISFIFO(os.lstat(fifo).st_mode)
    assert "waiting for a reader of the FIFO" in capsys.readouterr().err


def test_standard_output_is_dash_for_every_single_file_output(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for name in ("verify", "draw", "place-observers", "export"):
        assert main(_argv(name, tmp_path, STDOUT)) == 0
        out, err = capsys.readouterr()
        assert len(out) > 100 and "wrote" not in err, name
    assert not (Path.cwd() / "-").exists()


def test_export_to_standard_output_needs_a_format(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["export", str(_spec(tmp_path)), "--out", "-"]) == 2
    assert "give --format" in _one_line(capsys.readouterr().err)


@pytest.mark.parametrize("kind", ["block device", "socket"])
def test_a_block_device_or_a_socket_is_refused_before_any_work(kind: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    target = tmp_path / "target"
    if kind == "socket":
        s = socket.socket(socket.AF_UNIX)
        s.bind(str(target))
    else:
        try:  # device numbers with no driver: even a wrong open could not reach a disk
            os.mknod(target, stat.S_IFBLK | 0o600, os.makedev(0, 0))
        except PermissionError:
            pytest.skip("making a device node needs CAP_MKNOD (root)")
    assert main(_argv("verify", tmp_path, target)) == 2
    assert kind in _one_line(capsys.readouterr().err)
    assert target_kind(target).value == kind


def test_a_missing_folder_is_refused_before_any_work(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "nope" / "r.md"
    assert main(_argv("verify", tmp_path, out)) == 2
    assert "does not exist" in _one_line(capsys.readouterr().err)
    assert not out.parent.exists()
    with pytest.raises(OutputError, match="does not exist"):
        write_text_atomic(out, "x")
    write_text_atomic(out, "x", create_parents=True)  # a command that documents it creates folders
    assert out.read_text() == "x"


@pytest.mark.parametrize("argv_of", [
    lambda d: ["verify", str(d / "specs" / "tiny.toml"), "--out", str(d / ("x" * 300))],
    lambda d: ["verify", str(d / "specs" / "tiny.toml"), "--out", str(d / ("x" * 300) / "r.md")],
    lambda d: ["draw", str(d / "specs" / "tiny.toml"), "--out", "y" * 5000],
    lambda d: ["export", str(d / "specs" / "tiny.toml"), "--out", str(d / ("z" * 300 + ".json"))],
    lambda d: ["simulate", str(d / "specs" / "tiny.toml"), "--out", str(d / ("w" * 300))],
])
def test_a_too_long_name_is_one_line_exit_2(argv_of: Callable[[Path], list[str]], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    _spec(tmp_path)
    assert main(argv_of(tmp_path)) == 2
    line = _one_line(capsys.readouterr().err)
    assert "long" in line and len(line) < 300


@pytest.mark.parametrize("command", ["verify", "export", "draw", "place-observers", "audit", "design", "simulate"])
def test_an_empty_out_is_refused_before_any_work(command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    import glocal_verify.cli.common as common

    def no_work(*a: Any, **k: Any) -> Any:
        raise AssertionError("the spec was loaded before --out was checked")

    monkeypatch.setattr(common, "load_system", no_work)
    for mod in ("verify", "export", "draw", "placement", "audit", "design", "simulate"):
        monkeypatch.setattr(f"glocal_verify.cli.{mod}.load_system", no_work, raising=False)
    assert main([command, str(_spec(tmp_path)), "--out", ""]) == 2
    assert "is not a" in _one_line(capsys.readouterr().err)


@pytest.mark.parametrize("option,value", [("--require", ","), ("--require", ""), ("--require", " , "), ("--require-holds", ""), ("--only", ""), ("--only", ",,")])
def test_an_empty_gate_or_filter_is_refused(option: str, value: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["verify", str(_spec(tmp_path)), option, value]) == 2
    assert "the list is empty" in _one_line(capsys.readouterr().err)


def test_kinds_of_targets_are_named(tmp_path: Path) -> None:
    (tmp_path / "f").write_text("x")
    (tmp_path / "d").mkdir()
    os.mkfifo(tmp_path / "p")
    (tmp_path / "l").symlink_to(tmp_path / "f")
    (tmp_path / "lp").symlink_to(tmp_path / "p")
    kinds = {n: target_kind(tmp_path / n) for n in ("f", "d", "p", "l", "lp", "none")}
    assert kinds == {"f": TargetKind.FILE, "d": TargetKind.FOLDER, "p": TargetKind.FIFO, "l": TargetKind.LINK,
                     "lp": TargetKind.FIFO, "none": TargetKind.MISSING}
    assert target_kind("-") is TargetKind.STDOUT


def test_a_folder_output_refuses_standard_output_and_a_device(tmp_path: Path) -> None:
    dev = _char_device(tmp_path)
    with pytest.raises(OutputError, match="standard output"):
        check_output_dir("-")
    with pytest.raises(OutputError, match="not a folder"):
        check_output_dir(dev)


def test_an_output_folder_writes_a_fifo_inside_it_in_place(tmp_path: Path) -> None:
    dest = tmp_path / "out"
    dest.mkdir()
    reader = FifoReader(dest, "summary.json")
    with reader:
        with OutputFolder(dest) as folder:
            folder.write_text("summary.json", "{}\n")
            folder.write_text("other.md", "x\n")
    assert reader.data == b"{}\n" and stat.S_ISFIFO(os.lstat(dest / "summary.json").st_mode)
    assert (dest / "other.md").read_text() == "x\n"
    assert sorted(p.name for p in dest.iterdir()) == ["other.md", "summary.json"]


def test_a_read_only_file_is_refused_not_replaced(tmp_path: Path) -> None:
    if os.geteuid() == 0:
        pytest.skip("root may write any file: no read-only file to refuse")
    p = tmp_path / "r.md"
    p.write_text("keep")
    p.chmod(0o444)
    with pytest.raises(OutputError, match="read-only"):
        check_output_file(p)


def test_bytes_to_standard_output_keep_their_bytes(capfdbinary: pytest.CaptureFixture[bytes]) -> None:
    write_bytes_atomic(STDOUT, [b"\x00\x01", b"\xff"])
    assert capfdbinary.readouterr().out == b"\x00\x01\xff"
