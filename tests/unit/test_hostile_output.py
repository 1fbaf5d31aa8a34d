"""Issue 34, finding 1: `-o` writes what it names the way SPEC section 1 says, never replaces it blindly.

A regular file is replaced whole (renamed over, never half-written); a symbolic link (a chain of them, a
dangling one) stays a link and the file it names is replaced; a FIFO, a device, a socket and a descriptor
(`/dev/stdout`, `/dev/fd/N` as bash's `>(cmd)` gives) are written to in place, never replaced. Each through
the CLI: csv2xml, import, export and gen. (Never run these against code that renames over its output: as
root that would replace /dev/stdout and /dev/null themselves.)"""

from __future__ import annotations

import contextlib
import os
import socket
import stat
import subprocess
import threading
from pathlib import Path

import pytest

from support.common import EXAMPLE
from support.run import assert_clean_error, mdl_cmd, run_mdl

TSTAT = EXAMPLE / "temco_tstat.xml"
METER_MOD = EXAMPLE.parent / "xif_meter" / "meter.mod"


def _commands(out: Path) -> dict[str, list]:
    """Each command writing one output to `out` (gen: its folder's temco_tstat.py; see _output)."""
    return {
        "csv2xml": ["csv2xml", EXAMPLE / "temco_tstat.csv", "--ini", EXAMPLE / "temco_tstat.ini", "-o", out],
        "import": ["import", METER_MOD, "-o", out],
        "export": ["export", TSTAT, "--to", "xif", "-o", out],
        "gen": ["gen", TSTAT, "--lang", "python", "-o", out.parent],
    }


COMMANDS = list(_commands(Path("x")))


def _output(command: str, folder: Path) -> Path:
    """The path the command writes in `folder`."""
    return folder / ("temco_tstat.py" if command == "gen" else "out.txt")


def _expected(command: str, tmp_path: Path) -> bytes:
    """What the command writes to a plain new file."""
    plain = tmp_path / "plain"
    plain.mkdir()
    out = _output(command, plain)
    proc = run_mdl(*_commands(out)[command])
    assert proc.returncode == 0, proc.stderr
    return out.read_bytes()


def _leftovers(*folders: Path) -> list[str]:
    return [p.name for folder in folders for p in folder.iterdir() if p.name.endswith((".tmp", ".old"))]


def _read_all(fd: int, into: list[bytes]) -> None:
    with os.fdopen(fd, "rb") as fh:
        into.append(fh.read())


@pytest.mark.parametrize("command", COMMANDS)
def test_a_chain_of_links_stays_and_the_file_it_names_is_replaced_whole(tmp_path, command):
    """out -> link -> ../real/FILE (relative links, a chain): both links stay links, FILE gets the output,
    and is replaced by a rename (a new inode), its mode kept, nothing left beside it."""
    expected = _expected(command, tmp_path)
    work, real = tmp_path / "work", tmp_path / "real"
    work.mkdir()
    real.mkdir()
    out = _output(command, work)
    final = real / "final.txt"
    final.write_text("old content\n")
    final.chmod(0o640)
    inode = final.stat().st_ino
    (work / "link").symlink_to(Path("..") / "real" / "final.txt")
    out.symlink_to("link")
    proc = run_mdl(*_commands(out)[command])
    assert proc.returncode == 0, proc.stderr
    assert out.is_symlink() and os.readlink(out) == "link"
    assert (work / "link").is_symlink()
    assert final.read_bytes() == expected
    assert final.stat().st_ino != inode, "the file a link names is replaced whole, not rewritten in place"
    assert stat.S_IMODE(final.stat().st_mode) == 0o640
    assert _leftovers(work, real) == []


@pytest.mark.parametrize("command", ["import", "export", "gen"])
def test_a_dangling_link_gets_its_file_created(tmp_path, command):
    expected = _expected(command, tmp_path)
    work = tmp_path / "work"
    work.mkdir()
    out = _output(command, work)
    out.symlink_to(Path("..") / "made" / "new.txt")  # its folder does not exist yet either
    proc = run_mdl(*_commands(out)[command])
    assert proc.returncode == 0, proc.stderr
    assert out.is_symlink()
    assert (tmp_path / "made" / "new.txt").read_bytes() == expected


def test_a_link_that_loops_is_a_clean_error(tmp_path):
    out = tmp_path / "loop.xif"
    out.symlink_to("loop.xif")
    proc = run_mdl("export", TSTAT, "--to", "xif", "-o", out)
    assert_clean_error(proc, 1, f"{out}: error: ", "symbolic links")
    assert out.is_symlink()


def _run_into_fifo(fifo: Path, args: list) -> tuple[subprocess.CompletedProcess, bytes]:
    """Run `mdl ARGS` while a thread reads `fifo` to its end. A run that puts a file where the FIFO
    was never opens it: the FIFO (kept by a second name) is then opened for writing to end the read."""
    keep = fifo.with_name(fifo.name + ".kept")
    os.link(fifo, keep)
    got: list[bytes] = []
    reader = threading.Thread(target=lambda: _read_all(os.open(keep, os.O_RDONLY), got), daemon=True)
    reader.start()
    try:
        proc = run_mdl(*args, timeout=60)
    finally:
        if reader.is_alive():
            with contextlib.suppress(OSError):  # ENXIO: the reader closed the FIFO in between (it is done)
                os.close(os.open(keep, os.O_WRONLY | os.O_NONBLOCK))  # a reader waits: this open succeeds
        reader.join(30)
        keep.unlink()
    return proc, got[0] if got else b""


@pytest.mark.parametrize("command", COMMANDS)
def test_a_fifo_is_written_in_place_not_replaced(tmp_path, command):
    expected = _expected(command, tmp_path)
    work = tmp_path / "work"
    work.mkdir()
    out = _output(command, work)
    os.mkfifo(out)
    proc, read = _run_into_fifo(out, _commands(out)[command])
    assert proc.returncode == 0, proc.stderr
    assert stat.S_ISFIFO(out.lstat().st_mode), "the FIFO was replaced by a file"
    assert read == expected
    assert _leftovers(work) == []


def test_a_link_to_a_fifo_writes_into_the_fifo(tmp_path):
    expected = _expected("export", tmp_path)
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    out = tmp_path / "out.xif"
    out.symlink_to("pipe")
    proc, read = _run_into_fifo(fifo, _commands(out)["export"])
    assert proc.returncode == 0, proc.stderr
    assert out.is_symlink() and stat.S_ISFIFO(fifo.lstat().st_mode)
    assert read == expected


def test_gen_check_with_a_fifo_output_says_it_would_change_and_never_reads_it(tmp_path):
    """--check compares a regular file's content; a FIFO is not read (that would wait for a writer)."""
    os.mkfifo(tmp_path / "temco_tstat.py")
    proc = subprocess.run(
        mdl_cmd("gen", TSTAT, "--lang", "python", "-o", tmp_path, "--check"),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert_clean_error(proc, 1, "would change")
    assert stat.S_ISFIFO((tmp_path / "temco_tstat.py").lstat().st_mode)


def test_a_failed_run_writes_no_stream_and_changes_no_file(tmp_path):
    """gen --lang all with a FIFO for the Python driver, a link for the C header and a folder where the
    C++ source goes (its rename fails): nothing reaches the FIFO, the linked file and the rest stay."""
    os.mkfifo(tmp_path / "temco_tstat.py")
    real = tmp_path / "real.h"
    real.write_text("// old header\n")
    (tmp_path / "temco_tstat.h").symlink_to("real.h")
    (tmp_path / "temco_tstat.cc").mkdir()
    proc, read = _run_into_fifo(tmp_path / "temco_tstat.py", ["gen", TSTAT, "-o", tmp_path])
    assert_clean_error(proc, 1, "temco_tstat.cc: error: cannot write")
    assert read == b""
    assert real.read_text() == "// old header\n" and (tmp_path / "temco_tstat.h").is_symlink()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["real.h", "temco_tstat.cc", "temco_tstat.h", "temco_tstat.py"]


def test_a_listening_socket_gets_the_output(tmp_path):
    expected = _expected("export", tmp_path)
    out = tmp_path / "out.sock"
    got: list[bytes] = []
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as server:
        server.bind(str(out))
        server.listen(1)
        server.settimeout(60)

        def serve() -> None:
            conn, _ = server.accept()
            with conn:
                got.append(b"".join(iter(lambda: conn.recv(65536), b"")))

        reader = threading.Thread(target=serve, daemon=True)
        reader.start()
        proc = run_mdl(*_commands(out)["export"])
        reader.join(30)
    assert proc.returncode == 0, proc.stderr
    assert stat.S_ISSOCK(out.lstat().st_mode)
    assert got == [expected]


def test_a_failed_write_in_place_puts_back_the_files(tmp_path):
    """gen --lang all with a socket nobody accepts on for the Python driver: the C and C++ files renamed
    into place before it are put back (the header as it was, the new ones gone), exit 1."""
    header = tmp_path / "temco_tstat.h"
    header.write_text("// old header\n")
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as bound:  # bound, not listening: refused
        bound.bind(str(tmp_path / "temco_tstat.py"))
        proc = run_mdl("gen", TSTAT, "-o", tmp_path)
    assert_clean_error(proc, 1, "temco_tstat.py: error: cannot write: Connection refused")
    assert header.read_text() == "// old header\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["temco_tstat.h", "temco_tstat.py"]


def _run_with_pipe(args: list, stdout_name: str | None) -> tuple[int, bytes, str]:
    """Run `mdl ARGS` as a process whose output goes to a pipe: `-o /dev/stdout` (its stdout is the pipe),
    or, stdout_name None, `-o /dev/fd/N` with N the pipe's write end passed to it (bash's `>(cmd)`)."""
    read_end, write_end = os.pipe()
    got: list[bytes] = []
    reader = threading.Thread(target=_read_all, args=(read_end, got), daemon=True)
    reader.start()
    target = stdout_name or f"/dev/fd/{write_end}"
    try:
        proc = subprocess.run(
            mdl_cmd(*args, "-o", target),
            stdout=write_end if stdout_name else subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            pass_fds=() if stdout_name else (write_end,),
            text=True,
            timeout=60,
        )
    finally:
        os.close(write_end)
        reader.join(30)
    return proc.returncode, got[0] if got else b"", proc.stderr


@pytest.mark.parametrize("command", ["csv2xml", "import", "export"])
def test_a_descriptor_is_written_to_as_it_is(tmp_path, command):
    """/dev/fd/N (a pipe passed as `>(cmd)` passes it), /proc/self/fd/1 and /dev/stdout with stdout a pipe,
    in that order: code that renames over its output fails at the first, before /dev/stdout is at stake."""
    expected = _expected(command, tmp_path)
    args = _commands(Path("-"))[command][:-2]  # without its -o
    for target in (None, "/proc/self/fd/1", "/dev/stdout"):
        code, read, err = _run_with_pipe(args, target)
        assert code == 0, (target, err)
        assert "Traceback" not in err
        assert read == expected, target
    assert stat.S_ISLNK(os.lstat("/dev/stdout").st_mode)


@pytest.mark.parametrize("command", ["csv2xml", "export"])
def test_dev_null_stays_a_device(tmp_path, command):
    """-o /dev/null writes into the device (exit 0), as `> /dev/null` does; it is never replaced. (A FIFO
    first: code that replaces its output fails there, before /dev/null is at stake.)"""
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    args = _commands(fifo)[command]
    proc, _read = _run_into_fifo(fifo, args)
    assert proc.returncode == 0 and stat.S_ISFIFO(fifo.lstat().st_mode), proc.stderr
    proc = run_mdl(*args[:-1], "/dev/null")
    assert proc.returncode == 0, proc.stderr
    assert stat.S_ISCHR(os.lstat("/dev/null").st_mode)
    assert _leftovers(Path("/dev")) == []
