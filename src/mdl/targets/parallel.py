"""Several targets of one large device rendered at once: `mdl gen --lang all` forks a child per target
after the first, which renders while this process renders the first (docs/performance.md).

The children inherit the resolved device (fork: nothing is copied or pickled on the way in), render
their target and send its files back through a pipe. The output is the same bytes as rendering one
target after another: a child that does not send its files (an MdlError, a crash, a signal) has its
target rendered again here, so that what the user sees, an error included, is what the sequential
run shows, and a fork the system refuses leaves its target to this process too. Used where fork
exists, more than one CPU is ours, the device is large enough (PARALLEL_MIN functions) for the fork to
pay, and this process runs one thread (`mdl gen` does): a thread holding a lock at the fork would
leave it held in the child for ever.
"""

from __future__ import annotations

import gc
import os
import pickle
import signal
import sys
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, NoReturn

if TYPE_CHECKING:
    from mdl.resolver import ResolvedDevice

Render = Callable[[str], dict[str, str]]  # target name -> file name -> text

# below this many functions a target renders in well under 0.1 s: a fork would cost more than it saves
PARALLEL_MIN = 1000


def cpus() -> int:
    """The CPUs this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def single_threaded() -> bool:
    return threading.active_count() == 1


def worth_it(device: ResolvedDevice, names: list[str]) -> bool:
    if len(names) < 2 or len(device.functions) < PARALLEL_MIN or not hasattr(os, "fork"):
        return False
    return cpus() > 1 and single_threaded()


def warm(device: ResolvedDevice) -> None:
    """Work out once, before the fork, what every target asks of the device (read plan, buffer slots,
    IR shapes, decode order), so that no child works it out again."""
    device.plan  # noqa: B018 (cached properties: reading them is the work)
    device.readable  # noqa: B018
    for f in device.functions:
        f.decode_shape  # noqa: B018
        f.encode_shape  # noqa: B018
        f.deps  # noqa: B018
        f.runs  # noqa: B018 (every target asks each function's runs)
        if f.fn.readable:
            device.slots_of(f)
        if f.deps:
            device.closure([f.name])


def render_all(device: ResolvedDevice, names: list[str], render: Render) -> list[dict[str, str]]:
    """Each named target's files, in the order of `names`."""
    if not worth_it(device, names):
        return [render(name) for name in names]
    warm(device)
    for stream in (sys.stdout, sys.stderr):  # nothing buffered is printed twice by a child
        if stream is not None:
            stream.flush()
    freeze = gc.get_freeze_count() == 0  # a caller's own frozen objects stay as the caller left them
    if freeze:
        gc.freeze()  # the children's collections, if any (mdl gen pauses them), leave the inherited pages shared
    children: dict[str, tuple[int, int]] = {}
    try:
        for name in names[1:]:
            child = _fork(name, render)
            if child is not None:
                children[name] = child
        out = [render(names[0])]
        for name in names[1:]:
            if name not in children:
                out.append(render(name))
                continue
            pid, fd = children[name]
            data = _read(fd)  # an interrupt here: the child is still listed, and is stopped below
            del children[name]
            files = _files(data, _reap(pid))
            out.append(files if files is not None else render(name))
        return out
    finally:
        if freeze:
            gc.unfreeze()
        for pid, fd in children.values():  # an error or an interrupt: the children left are stopped and waited for
            _stop(pid, fd)


def _stop(pid: int, fd: int) -> None:
    for step in (lambda: os.close(fd), lambda: os.kill(pid, signal.SIGKILL), lambda: os.waitpid(pid, 0)):
        try:
            step()
        except OSError:  # closed already, gone already, or reaped by the system (SIGCHLD ignored)
            pass


def _fork(name: str, render: Render) -> tuple[int, int] | None:
    """The child rendering `name` and the pipe its files come through; None where the system refuses a
    pipe or a process (too many open files or processes: the target is rendered here)."""
    try:
        read_end, write_end = os.pipe()
    except OSError:
        return None
    try:
        pid = os.fork()
    except OSError:
        os.close(read_end)
        os.close(write_end)
        return None
    if pid == 0:
        _child(name, render, read_end, write_end)
    os.close(write_end)
    return pid, read_end


def _child(name: str, render: Render, read_end: int, write_end: int) -> NoReturn:
    """Render, send, and leave without running the parent's exit handlers or its code after the fork."""
    status = 1
    try:
        os.close(read_end)
        files = render(name)
        with os.fdopen(write_end, "wb") as out:
            pickle.dump(files, out, protocol=pickle.HIGHEST_PROTOCOL)
        status = 0
    except BaseException:  # noqa: BLE001,S110 (whatever it was, the parent renders this target itself)
        pass
    finally:
        os._exit(status)


def _read(fd: int) -> bytes:
    with os.fdopen(fd, "rb") as pipe:
        return pipe.read()


def _reap(pid: int) -> int | None:
    """The child's exit status, once it has exited; None where the system reaped it (SIGCHLD ignored)."""
    try:
        return os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1])
    except ChildProcessError:
        return None


def _files(data: bytes, status: int | None) -> dict[str, str] | None:
    """The files a child sent, or None where it did not send them whole (it exits 0 only once they are
    written; without its status, a message cut short does not unpickle)."""
    if status not in (0, None):
        return None
    try:
        files = pickle.loads(data)
    except Exception:  # noqa: BLE001 (cut short: the child was stopped while it wrote)
        return None
    return files if isinstance(files, dict) else None
