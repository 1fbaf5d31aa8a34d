"""Devices the tests serve and wire: `mdl sim` as a process (Sim) and a socat pseudo terminal pair
(SerialLine). The fixtures that start and stop them are in tests/conftest.py."""

from __future__ import annotations

import codecs
import functools
import os
import resource
import selectors
import shutil
import signal
import subprocess
import time

from support.common import skip_or_fail
from support.run import mdl_cmd


def read_lines(stream, wanted, proc, timeout: float) -> list[str]:
    """Whole lines of `stream` until `wanted(lines)` holds, the process ends, or `timeout` seconds pass.
    Read from the file descriptor (unbuffered): a line never waits in a buffer select() cannot see."""
    fd = stream.fileno()
    decoder = codecs.getincrementaldecoder("utf-8")(errors="replace")
    deadline = time.monotonic() + timeout
    text, lines = "", []
    with selectors.DefaultSelector() as sel:
        sel.register(fd, selectors.EVENT_READ)
        while not wanted(lines) and time.monotonic() < deadline:
            if sel.select(timeout=0.5):
                data = os.read(fd, 4096)
                if not data:
                    break
                text += decoder.decode(data)
                *complete, text = text.split("\n")
                lines += [line + "\n" for line in complete]
            elif proc.poll() is not None:
                break
    return lines


def limit_files(files: int) -> None:
    """In a child before it runs: at most `files` open files (the soft limit; the hard one as it was)."""
    resource.setrlimit(resource.RLIMIT_NOFILE, (files, resource.getrlimit(resource.RLIMIT_NOFILE)[1]))


class Sim:
    """A running `mdl sim` of one device file, or of a list of them (one ready line each, at self.units);
    stops it with SIGTERM and checks it stopped cleanly.

    On a free TCP port by default, or on `port` (self.host, self.port); with `serial=DEVICE` on that serial device
    (self.device; the ready lines say `on DEVICE`). self.connection: the CLI options that reach it
    (on a serial line, `--serial` of the sim's own end: a client needs the other end of the line). With
    `files=N` it may open N files at most (and so holds fewer connections at once: sim.most_clients)."""

    def __init__(
        self, path, *extra, timeout: float = 30, serial: str | None = None, port: int = 0, files: int | None = None
    ):
        paths = list(path) if isinstance(path, (list, tuple)) else [path]
        where = ["--serial", serial] if serial else ["--port", str(port)]
        self.proc = subprocess.Popen(
            mdl_cmd("sim", *paths, *where, *extra),
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            preexec_fn=None if files is None else functools.partial(limit_files, files),
        )
        lines = read_lines(self.proc.stdout, lambda got: len(got) >= len(paths), self.proc, timeout)
        if len(lines) < len(paths) or not all(line.startswith("mdl sim: serving") for line in lines):
            self.proc.kill()
            out, err = self.proc.communicate()
            raise RuntimeError(f"mdl sim did not start: {lines!r} {out!r} {err!r}")
        self.ready_lines = [line.rstrip("\n") for line in lines]
        self.ready_line = self.ready_lines[0]
        self.units = [int(line.rsplit(" unit ", 1)[1]) for line in self.ready_lines]
        served = self.ready_line.rsplit(" unit ", 1)[0].rsplit(" on ", 1)[1]
        self.device, self.host, self.port = serial, None, None
        if serial:
            assert served == serial, (served, serial)
            self.connection = ["--serial", serial]
        else:
            host, port = served.rsplit(":", 1)
            self.host, self.port = host, int(port)
            self.connection = ["--host", self.host, "--port", str(self.port)]

    def stop(self, sig=signal.SIGTERM) -> int:
        if self.proc.stdout.closed:  # stopped before
            return self.proc.returncode
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
            try:
                self.proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
                raise AssertionError("mdl sim did not stop on a signal") from None
        self.stderr = self.proc.stderr.read()
        self.proc.stdout.close()
        self.proc.stderr.close()
        return self.proc.returncode


class SerialLine:
    """Two serial devices wired to each other: a pseudo terminal pair made by
    `socat -d -d pty,raw,echo=0 pty,raw,echo=0`, whose names socat prints on stderr (self.ends).
    Without socat the test is skipped with the reason, or fails when CI=true."""

    def __init__(self, timeout: float = 10):
        if shutil.which("socat") is None:
            skip_or_fail(
                "socat is not installed: the serial tests wire two pseudo terminals with it (apt-get install socat)"
            )
        self.proc = subprocess.Popen(
            ["socat", "-d", "-d", "pty,raw,echo=0", "pty,raw,echo=0"],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        lines = read_lines(
            self.proc.stderr,
            lambda got: (
                sum(" PTY is " in line for line in got) == 2 or any("starting data transfer" in line for line in got)
            ),
            self.proc,
            timeout,
        )
        self.ends = [line.split(" PTY is ", 1)[1].strip() for line in lines if " PTY is " in line]
        if len(self.ends) != 2:
            self.close()
            raise RuntimeError(f"socat made no pseudo terminal pair: {lines!r}")

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.proc.stderr.close()
