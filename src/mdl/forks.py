"""Work split over forked children, for the few commands that have large enough work to pay for a
fork: `mdl gen --lang all` renders one target per child (targets/parallel.py), csv2xml lays out the
pages of a long PDF manual in two halves (formats/table/readers/pdf.py).

`each(jobs, work)` gives `[work(job) for job in jobs]`, the same values in the same order, with the
first job done in this process and each other job in a child forked for it. The children inherit what
this process holds (fork: nothing is copied or pickled on the way in) and send their result back
pickled through a pipe. A child that does not send its result (an MdlError, a crash, a signal) has its
job done again here, so that what the user sees, an error included, is what the sequential run shows;
a fork the system refuses leaves its job to this process too. Callers ask `possible()` first: fork
exists, more than one CPU is ours, and this process runs one thread (a thread holding a lock at the
fork would leave it held in the child for ever).
"""

from __future__ import annotations

import gc
import os
import pickle
import signal
import sys
import threading
from collections.abc import Callable, Hashable
from typing import NoReturn, TypeVar, cast

Job = TypeVar("Job", bound=Hashable)
Result = TypeVar("Result")


def cpus() -> int:
    """The CPUs this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def single_threaded() -> bool:
    return threading.active_count() == 1


def possible() -> bool:
    return hasattr(os, "fork") and cpus() > 1 and single_threaded()


def each(jobs: list[Job], work: Callable[[Job], Result]) -> list[Result]:
    """`[work(job) for job in jobs]`, the jobs after the first in forked children (jobs distinct)."""
    if len(jobs) < 2:
        return [work(job) for job in jobs]
    for stream in (sys.stdout, sys.stderr):  # nothing buffered is printed twice by a child
        if stream is not None:
            stream.flush()
    freeze = gc.get_freeze_count() == 0  # a caller's own frozen objects stay as the caller left them
    if freeze:
        gc.freeze()  # the children's collections, if any, leave the inherited pages shared
    children: dict[Job, tuple[int, int]] = {}
    try:
        for job in jobs[1:]:
            child = _fork(job, work)
            if child is not None:
                children[job] = child
        out = [work(jobs[0])]
        for job in jobs[1:]:
            if job not in children:
                out.append(work(job))
                continue
            pid, fd = children[job]
            data = _read(fd)  # an interrupt here: the child is still listed, and is stopped below
            del children[job]
            sent = _result(data, _reap(pid))
            out.append(cast(Result, sent[0]) if sent is not None else work(job))
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


def _fork(job: Job, work: Callable[[Job], Result]) -> tuple[int, int] | None:
    """The child doing `job` and the pipe its result comes through; None where the system refuses a
    pipe or a process (too many open files or processes: the job is done here)."""
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
        _child(job, work, read_end, write_end)
    os.close(write_end)
    return pid, read_end


def _child(job: Job, work: Callable[[Job], Result], read_end: int, write_end: int) -> NoReturn:
    """Work, send, and leave without running the parent's exit handlers or its code after the fork."""
    status = 1
    try:
        os.close(read_end)
        result = work(job)
        with os.fdopen(write_end, "wb") as out:
            pickle.dump((result,), out, protocol=pickle.HIGHEST_PROTOCOL)
        status = 0
    except BaseException:  # noqa: BLE001,S110 (whatever it was, the parent does this job itself)
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


def _result(data: bytes, status: int | None) -> tuple[object] | None:
    """(the result a child sent,), or None where it did not send it whole (it exits 0 only once it is
    written; without its status, a message cut short does not unpickle)."""
    if status not in (0, None):
        return None
    try:
        sent = pickle.loads(data)
    except Exception:  # noqa: BLE001 (cut short: the child was stopped while it wrote)
        return None
    return sent if isinstance(sent, tuple) and len(sent) == 1 else None
