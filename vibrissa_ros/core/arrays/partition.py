"""
The whisker array across processes: a fixed partition of its whiskers, for spare cores.

:class:`PartitionedArrayTracker` has :class:`~.tracker.ArrayTracker`'s interface (``step``,
``reset``, ``centerlines``, ``state``) and its results, to the last bit: every whisker's tracker
is independent of the others, so where it runs changes nothing. The whiskers are dealt to
``workers`` parts in turn (whisker i to part i mod workers, so that a row's or a column's
whiskers, which meet an obstacle together, are spread over the parts). Part 0 is stepped in the
caller's process, each other part by an :class:`ArrayTracker` of its own living in a worker
process: this interpreter started afresh (nothing is forked from a process with DDS threads, and
the caller's main module is not imported again), talking over a socket pair with
``multiprocessing.connection``'s pickled messages.
A tick sends each worker its head pose and protraction angles, steps part 0 meanwhile, then
takes the workers' answers and merges them in the array's order: the tick costs its slowest
part plus ~0.1 ms of messages.

This is not a scheduler: the parts are fixed, each whisker's state lives in one process for the
whole run, and a tick waits for all of them (a study's many independent runs go to Dask,
:mod:`vibrissa_ros.studies`; at 1 kHz a task's overhead would be the whole tick). It pays where
the solving is the bottleneck and there are cores to spare: a whisker in contact costs ~0.2 ms a
tick and a snap milliseconds, while a free array's tick (~0.1 ms) gets slower
(doc/benchmarks.md, "The array across processes").

A worker ignores SIGINT and SIGTERM (the caller decides when the run ends) and ends when the
caller closes it (:meth:`PartitionedArrayTracker.close`) or is gone. An error of a whisker is
that whisker's, as in one process; a worker that ends otherwise makes every later tick raise
:class:`~vibrissa_ros.core.errors.ConvergenceError`, naming its whiskers.

No rclpy here.
"""

from __future__ import annotations

import signal
import socket
import subprocess
import sys
import weakref
from dataclasses import fields
from multiprocessing.connection import Connection
from typing import List, Optional, Sequence

import numpy as np

from ..errors import ConvergenceError, ParameterError
from ..rod3d.pose import BasePose
from .array import WhiskerArray
from .tracker import ArrayStep, ArrayTracker, _as_head

#: the most worker processes (parts) an array is split into
MAX_WORKERS = 64
#: ArrayStep's fields: arrays with a row per whisker, tuples with an entry per whisker
_ROWS = tuple(f.name for f in fields(ArrayStep) if f.name not in
              ("names", "head", "contact_kind", "contact_obstacle", "events", "errors"))
_TUPLES = ("names", "contact_kind", "contact_obstacle")
#: how long a worker may take to build its trackers (its first start compiles or loads the
#: kernels) [s]
_START_TIMEOUT = 600.0


# the worker process: it ignores SIGINT and SIGTERM before anything else (its imports take a
# while, and a Ctrl-C reaches the whole process group)
_WORKER_MAIN = ("import signal; signal.signal(signal.SIGINT, signal.SIG_IGN); "
                "signal.signal(signal.SIGTERM, signal.SIG_IGN); import sys; "
                "from vibrissa_ros.core.arrays.partition import serve; serve(int(sys.argv[1]))")


def serve(fd: int) -> None:
    """
    Run one part's ArrayTracker in a worker process: its set-up, then commands in, results out.

    Parameters
    ----------
    fd : int
        The worker's end of the socket pair (a ``multiprocessing.connection.Connection``).

    """
    for sig in (signal.SIGINT, signal.SIGTERM):  # the caller decides when the run ends
        signal.signal(sig, signal.SIG_IGN)
    conn = Connection(fd)
    try:
        whiskers, description, scene, head, protraction, options = conn.recv()
        tracker = ArrayTracker(WhiskerArray(whiskers, description), scene, head, protraction,
                               **options)
    except (EOFError, OSError):  # the caller is gone
        return
    except Exception as exc:  # noqa: BLE001 - the caller raises it
        conn.send(("error", exc))
        return
    conn.send(("ok", tracker.state))
    while True:
        try:
            command = conn.recv()
        except (EOFError, OSError):  # the caller is gone
            return
        kind = command[0]
        if kind == "close":
            return
        try:
            if kind == "step":
                answer = tracker.step(command[1], command[2])
            elif kind == "reset":
                answer = tracker.reset()
            else:  # "centerlines"
                answer = tracker.centerlines(command[1])
        except Exception as exc:  # noqa: BLE001 - the caller raises it, as in one process
            conn.send(("error", exc))
            continue
        conn.send(("ok", answer))


def _end_workers(conns: List[Connection], procs: List[subprocess.Popen]) -> None:
    """Ask each worker to end, wait a few seconds, kill those still running; empty the lists."""
    for conn in conns:
        try:
            conn.send(("close",))
        except (OSError, ValueError):
            pass
    for proc in procs:
        try:
            proc.wait(5.0)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    for conn in conns:
        conn.close()
    conns.clear()
    procs.clear()


class PartitionedArrayTracker:
    """
    Every whisker of an array against one scene, its whiskers stepped in several processes.

    Parameters
    ----------
    array : WhiskerArray
        The whiskers (SI units, head frame).
    scene : Scene3D, sequence or None
        The obstacles, as :class:`~.tracker.ArrayTracker` takes them.
    head : BasePose, optional
        The initial head pose in the world (position [m]); default: the world's origin.
    protraction : float or array_like, optional
        The initial protraction [rad] (one for all, or one per whisker).
    workers : int, optional
        The number of parts, 1 to min(64, the number of whiskers): part 0 in this process, the
        others in a worker process each (1: none, an ArrayTracker in this process).
    **options
        :class:`~.tracker.ArrayTracker`'s other parameters (``samples``, ``max_evaluations``,
        ``adapt_points``, ``points_tolerance``), the same for every part.

    Raises
    ------
    InvalidPoseError
        When an unloaded whisker cuts an obstacle at the initial pose (naming the whisker).
    ParameterError
        When an argument is not allowed.

    """

    def __init__(self, array: WhiskerArray, scene, head: Optional[BasePose] = None,
                 protraction=0.0, workers: int = 2, **options):
        if not isinstance(array, WhiskerArray):
            raise ParameterError(f"array = {array!r} is not allowed; it is a WhiskerArray")
        k = len(array)
        if (isinstance(workers, bool) or not isinstance(workers, (int, np.integer))
                or not 1 <= workers <= min(MAX_WORKERS, k)):
            raise ParameterError(f"workers = {workers!r} is not allowed; need a whole number "
                                 f"from 1 to {min(MAX_WORKERS, k)} (the array's whiskers, at "
                                 f"most {MAX_WORKERS})")
        self.array = array
        self.names = array.names
        head = _as_head(head)
        theta = self._protraction(protraction)
        self._parts: List[np.ndarray] = [np.arange(j, k, int(workers))
                                         for j in range(int(workers))]
        self._order = np.argsort(np.concatenate(self._parts), kind="stable")
        self._rank = {n: i for i, n in enumerate(self.names)}
        self._conns: List[Connection] = []
        self._procs: List[subprocess.Popen] = []
        # the workers end with this object even when nobody closes it (a finalizer holds the
        # lists, not the object)
        self._finalizer = weakref.finalize(self, _end_workers, self._conns, self._procs)
        self._failed: Optional[str] = None
        first = self._parts[0]
        try:
            for part in self._parts[1:]:
                ours, theirs = socket.socketpair()
                try:
                    proc = subprocess.Popen([sys.executable, "-c", _WORKER_MAIN,
                                             str(theirs.fileno())], pass_fds=(theirs.fileno(),))
                except OSError as exc:
                    ours.close()
                    raise ConvergenceError(f"cannot start the array's worker process: {exc}")
                finally:
                    theirs.close()
                self._conns.append(Connection(ours.detach()))
                self._procs.append(proc)
                self._conns[-1].send((tuple(array.whiskers[i] for i in part),
                                      array.description, scene, head, theta[part], options))
            self._local = ArrayTracker(WhiskerArray(tuple(array.whiskers[i] for i in first),
                                                    array.description), scene, head,
                                       theta[first], **options)
            states = [self._local.state] + [self._answer(j, _START_TIMEOUT)
                                            for j in range(len(self._conns))]
        except BaseException:
            self.close()
            raise
        self._state = self._merge(states)

    # -- the parts ------------------------------------------------------------------------------
    def _protraction(self, protraction) -> np.ndarray:
        theta = np.asarray(protraction, dtype=float)
        k = len(self.array)
        if theta.ndim == 0:
            return np.full(k, float(theta))
        if theta.shape != (k,):
            raise ParameterError(f"protraction has shape {theta.shape}; need one angle or one "
                                 f"per whisker ({k})")
        return theta.copy()

    def _where(self, j: int) -> str:
        names = [self.names[i] for i in self._parts[j + 1]]
        return f"the array's worker process {j + 1} (whiskers {', '.join(names)})"

    def _answer(self, j: int, timeout: Optional[float] = None):
        """Return worker j's answer, or raise its error (a failure for good: ConvergenceError)."""
        conn = self._conns[j]
        try:
            if timeout is not None and not conn.poll(timeout):
                raise ConvergenceError(f"{self._where(j)} did not start within {timeout:.0f} s")
            kind, value = conn.recv()
        except (EOFError, OSError):
            try:
                code = self._procs[j].wait(1.0)
            except subprocess.TimeoutExpired:
                code = None
            self._failed = (f"{self._where(j)} ended (exit code {code}); the array cannot go "
                            "on: start it again")
            raise ConvergenceError(self._failed) from None
        if kind == "error":
            raise value
        return value

    def _ask(self, commands: Sequence[tuple], local):
        """Send each worker its command, run ``local()`` on part 0 meanwhile, gather all."""
        if self._failed is not None:
            raise ConvergenceError(self._failed)
        for j, (conn, command) in enumerate(zip(self._conns, commands)):
            try:
                conn.send(command)
            except (OSError, ValueError):
                self._failed = (f"{self._where(j)} is gone; the array cannot go on: start it "
                                "again")
                raise ConvergenceError(self._failed) from None
        error = None
        answers = []
        try:
            answers.append(local())
        except Exception as exc:  # noqa: BLE001 - raised once every worker has answered
            error = exc
        for j in range(len(self._conns)):
            try:
                answers.append(self._answer(j))
            except Exception as exc:  # noqa: BLE001 - the first error is raised
                error = error or exc
        if error is not None:
            raise error
        return answers

    def _merge(self, steps: Sequence[ArrayStep]) -> ArrayStep:
        """One ArrayStep of the parts' steps, in the array's order (the same bits as one)."""
        if len(steps) == 1:
            return steps[0]
        order, rank = self._order, self._rank
        values = {"head": steps[0].head}
        for name in _ROWS:
            merged = np.concatenate([getattr(s, name) for s in steps])[order]
            merged.flags.writeable = False
            values[name] = merged
        for name in _TUPLES:
            joined = [v for s in steps for v in getattr(s, name)]
            values[name] = tuple(joined[i] for i in order)
        for name in ("events", "errors"):
            items = [e for s in steps for e in getattr(s, name)]
            values[name] = tuple(sorted(items, key=lambda e: rank[e.whisker]))
        return ArrayStep(**values)

    # -- ArrayTracker's interface -----------------------------------------------------------
    def __len__(self) -> int:
        """Return the number of whiskers."""
        return len(self.array)

    @property
    def workers(self) -> int:
        """Return the number of parts (this process's and the worker processes')."""
        return len(self._parts)

    @property
    def state(self) -> ArrayStep:
        """Return the last tick's result (the initial state before the first step)."""
        return self._state

    def step(self, head: BasePose, protraction=0.0) -> ArrayStep:
        """
        Advance every whisker to a new head pose and protraction (:meth:`ArrayTracker.step`).

        Parameters
        ----------
        head : BasePose
            The head pose in the world (position [m]).
        protraction : float or array_like, optional
            The protraction [rad] (one for all, or one per whisker).

        Returns
        -------
        ArrayStep
            The tick, as one process gives it.

        """
        head = _as_head(head)
        theta = self._protraction(protraction)
        parts = self._parts
        steps = self._ask([("step", head, theta[p]) for p in parts[1:]],
                          lambda: self._local.step(head, theta[parts[0]]))
        self._state = self._merge(steps)
        return self._state

    def reset(self) -> ArrayStep:
        """Re-place every whisker unloaded at its last tick's pose (:meth:`ArrayTracker.reset`)."""
        steps = self._ask([("reset",)] * len(self._conns), self._local.reset)
        self._state = self._merge(steps)
        return self._state

    def centerlines(self, n: int = 21) -> np.ndarray:
        """Return every whisker's centerline (k, n, 3) [m] (:meth:`ArrayTracker.centerlines`)."""
        lines = self._ask([("centerlines", n)] * len(self._conns),
                          lambda: self._local.centerlines(n))
        return np.concatenate(lines)[self._order]

    def close(self) -> None:
        """End the worker processes (at once if they do not end within a few seconds)."""
        self._finalizer()
        if self._failed is None and len(self._parts) > 1:
            self._failed = "the array's worker processes were closed"

    def __enter__(self) -> "PartitionedArrayTracker":
        """Return self (closed on leaving the block)."""
        return self

    def __exit__(self, *exc) -> None:
        """Close the worker processes."""
        self.close()


__all__ = ["MAX_WORKERS", "PartitionedArrayTracker"]
