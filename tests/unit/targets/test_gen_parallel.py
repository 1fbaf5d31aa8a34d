"""`mdl gen --lang all` renders the targets of a large device at once, in forked children
(mdl.targets.parallel, docs/performance.md): the files are the bytes of rendering one target after
another, and a child that fails in any way leaves its target to this process, so that errors too are
what the sequential run shows."""

from __future__ import annotations

import gc
import os
import signal

import pytest

from mdl import forks as forking
from mdl.diagnostics import MdlError
from mdl.formats.mdl.load import read_device
from mdl.resolver import resolve
from mdl.targets import parallel, render
from support.common import device_xml, fn_xml
from support.run import run_mdl

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="rendering in parallel forks: this system has no fork")

KINDS = [
    {"format": "UINT16", "multiplier": "0.1", "minimum": "0", "maximum": "500"},
    {"format": "FLOAT32"},
    {"format": "INT32", "multiplier": "0.01"},
    {"format": "UINT16", "values": {0: "Off", 1: "On"}},
]


@pytest.fixture(scope="module")
def large(tmp_path_factory):
    """A device of PARALLEL_MIN functions of a few kinds, as a file."""
    body = []
    address = 0
    for i in range(parallel.PARALLEL_MIN):
        kind = KINDS[i % len(KINDS)]
        body.append(fn_xml(f"f{i}", address, **kind))
        address += 2 if kind["format"] in ("FLOAT32", "INT32") else 1
    path = tmp_path_factory.mktemp("parallel") / "large.xml"
    path.write_text(device_xml("".join(body), name="Large Device"), encoding="ascii")
    return path


@pytest.fixture
def forks(monkeypatch):
    """The children forked (their pids), on any machine: two CPUs are said to be ours, and one thread."""
    born: list[int] = []
    fork = os.fork

    def counting_fork() -> int:
        pid = fork()
        if pid:
            born.append(pid)
        return pid

    monkeypatch.setattr(parallel, "cpus", lambda: 2)
    monkeypatch.setattr(parallel, "single_threaded", lambda: True)  # a test worker runs a thread of its own
    monkeypatch.setattr(parallel.os, "fork", counting_fork)
    return born


def test_the_files_are_those_of_the_sequential_run(large, forks, monkeypatch):
    resolved = resolve(read_device(large), str(large))
    at_once = render(resolved, large.name, "all")
    assert len(forks) == 2  # C++ and C each in a child; Python here
    monkeypatch.setattr(parallel, "cpus", lambda: 1)
    one_by_one = render(resolve(read_device(large), str(large)), large.name, "all")
    assert len(forks) == 2
    assert at_once == one_by_one
    assert sorted(at_once) == ["large_device.c", "large_device.cc", "large_device.h", "large_device.py"]


def test_a_small_device_or_one_target_forks_nothing(large, forks, write_device):
    small = write_device(fn_xml("a", 0, format="UINT16"))
    render(resolve(read_device(small), str(small)), small.name, "all")
    render(resolve(read_device(large), str(large)), large.name, "python")
    assert forks == []


def test_mdl_gen_writes_the_same_files_either_way(large, forks, tmp_path, monkeypatch):
    assert run_mdl("gen", large, "--lang", "all", "-o", tmp_path / "at_once").returncode == 0
    assert len(forks) == 2
    monkeypatch.setattr(parallel, "cpus", lambda: 1)
    assert run_mdl("gen", large, "--lang", "all", "-o", tmp_path / "one_by_one").returncode == 0
    for name in ("large_device.c", "large_device.cc", "large_device.h", "large_device.py"):
        assert (tmp_path / "at_once" / name).read_bytes() == (tmp_path / "one_by_one" / name).read_bytes()


def test_a_child_that_dies_leaves_its_target_to_the_parent(large, forks):
    resolved = resolve(read_device(large), str(large))
    parent = os.getpid()
    done_here: list[str] = []

    def render_one(name: str) -> dict[str, str]:
        if os.getpid() != parent and name == "c":
            os._exit(7)  # killed, say, by the kernel for memory
        if os.getpid() == parent:
            done_here.append(name)
        return {f"{name}.txt": name * 3}

    files = parallel.render_all(resolved, ["python", "cpp", "c"], render_one)
    assert files == [{"python.txt": "pythonpythonpython"}, {"cpp.txt": "cppcppcpp"}, {"c.txt": "ccc"}]
    assert done_here == ["python", "c"]  # cpp came from its child; c was rendered again here


def test_an_error_in_a_child_is_the_error_of_the_sequential_run(large, forks):
    resolved = resolve(read_device(large), str(large))

    def render_one(name: str) -> dict[str, str]:
        if name == "cpp":
            raise MdlError("cpp cannot print this device")
        return {name: name}

    with pytest.raises(MdlError, match="cpp cannot print this device"):
        parallel.render_all(resolved, ["python", "cpp", "c"], render_one)
    for pid in forks:  # every child was waited for: none is left behind
        with pytest.raises(ChildProcessError):
            os.waitpid(pid, os.WNOHANG)


def test_a_fork_the_system_refuses_leaves_the_target_here(large, monkeypatch):
    resolved = resolve(read_device(large), str(large))
    monkeypatch.setattr(parallel, "cpus", lambda: 2)
    monkeypatch.setattr(parallel, "single_threaded", lambda: True)

    def refused() -> int:
        raise BlockingIOError(11, "Resource temporarily unavailable")

    monkeypatch.setattr(parallel.os, "fork", refused)
    files = parallel.render_all(resolved, ["python", "cpp", "c"], lambda name: {name: name})
    assert files == [{"python": "python"}, {"cpp": "cpp"}, {"c": "c"}]


def test_a_process_with_threads_renders_one_target_after_another(large, monkeypatch):
    """A library user's program may hold locks in other threads: it is never forked."""
    resolved = resolve(read_device(large), str(large))
    monkeypatch.setattr(parallel, "cpus", lambda: 2)
    monkeypatch.setattr(forking.threading, "active_count", lambda: 2)
    assert not parallel.worth_it(resolved, ["python", "cpp", "c"])
    monkeypatch.setattr(forking.threading, "active_count", lambda: 1)
    assert parallel.worth_it(resolved, ["python", "cpp", "c"])


def test_children_reaped_by_the_system_still_send_their_files(large, forks):
    """A library user's program may ignore SIGCHLD (the system then reaps children at once): what each
    child sent is used all the same, and no error comes of it."""
    resolved = resolve(read_device(large), str(large))
    before = signal.signal(signal.SIGCHLD, signal.SIG_IGN)
    try:
        files = parallel.render_all(resolved, ["python", "cpp", "c"], lambda name: {name: name * 2})
    finally:
        signal.signal(signal.SIGCHLD, before)
    assert files == [{"python": "pythonpython"}, {"cpp": "cppcpp"}, {"c": "cc"}]


def test_a_callers_frozen_objects_stay_frozen(large, forks, monkeypatch):
    """render_all freezes the heap for its children only where nothing is frozen, and thaws only what
    it froze. (Calls are recorded: a freeze count moves as frozen objects die, whatever render_all does.)"""
    resolved = resolve(read_device(large), str(large))
    calls: list[str] = []
    monkeypatch.setattr(gc, "freeze", lambda: calls.append("freeze"))
    monkeypatch.setattr(gc, "unfreeze", lambda: calls.append("unfreeze"))
    monkeypatch.setattr(gc, "get_freeze_count", lambda: 5)  # the caller froze objects of its own
    parallel.render_all(resolved, ["python", "cpp", "c"], lambda name: {name: name})
    assert calls == []
    monkeypatch.setattr(gc, "get_freeze_count", lambda: 0)
    parallel.render_all(resolved, ["python", "cpp", "c"], lambda name: {name: name})
    assert calls == ["freeze", "unfreeze"]
