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
caller closes it (:meth:`PartitionedArrayTracker.close`), the tracker is garbage, or the
caller is gone. An error of a whisker is that whisker's, as in one process; a worker that ends
otherwise, or does not answer within two minutes, makes every later tick raise
:class:`~vibrissa_ros.core.errors.ConvergenceError`, naming its whiskers, until
:meth:`PartitionedArrayTracker.restart` starts the parts afresh (every whisker unloaded at the
pose it is given, in new worker processes; array_node's ``~/reset`` does it). The protraction is
checked before any part moves. A Ctrl-C during a tick leaves the parts at different ticks, as
it leaves an ArrayTracker's whiskers (every command's answer carries its tag, so an answer left
unread is skipped); one that comes while an answer is being read (a few microseconds of a tick)
ends the array as a worker's end does.

No rclpy here.
"""

from __future__ import annotations

import signal
import socket
import subprocess
import sys
import time
import weakref
from dataclasses import fields, replace
from multiprocessing.connection import Connection
from typing import List, Optional, Sequence, Tuple

import numpy as np

from ..errors import ConvergenceError, InvalidPoseError, ParameterError
from ..rod3d.pose import BasePose
from ..rod3d.tracker import RodTracker
from .array import WhiskerArray
from .tracker import ArrayStep, ArrayTracker, WhiskerEvent, _as_head, _scene_in_metres
from .whisking import protraction_angles

#: the most worker processes (parts) an array is split into
MAX_WORKERS = 64
#: ArrayStep's fields: arrays with a row per whisker, tuples with an entry per whisker
_ROWS = tuple(f.name for f in fields(ArrayStep) if f.name not in
              ("names", "head", "contact_kind", "contact_obstacle", "events", "errors"))
_TUPLES = ("names", "contact_kind", "contact_obstacle")
#: how long a worker may take to build its trackers (its first start compiles or loads the
#: kernels) [s]
_START_TIMEOUT = 600.0
#: how long a worker may take to answer a tick (each whisker's step is bounded by its budget
#: of evaluations: ~seconds at the very worst) [s]
_ANSWER_TIMEOUT = 120.0
#: the ArrayTracker methods a worker answers (a command names one)
_METHODS = frozenset(("step", "reset", "centerlines", "whisker_poses", "clearance"))
#: what a failed array's error says can be done
_RESTART = "restart() it (every whisker unloaded, in fresh worker processes) or start it again"


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
        try:
            whiskers, description, scene, head, protraction, options = conn.recv()
            tracker = ArrayTracker(WhiskerArray(whiskers, description), scene, head,
                                   protraction, **options)
        except (EOFError, OSError):  # the caller is gone
            return
        except Exception as exc:  # noqa: BLE001 - the caller raises it
            _send_error(conn, 0, exc)
            return
        conn.send((0, "ok", tracker.state))
        while True:
            command = conn.recv()
            tag, kind = command[0], command[1]
            if kind == "close":
                return
            try:
                if kind not in _METHODS:
                    raise ValueError(f"the array's worker has no command {kind!r}")
                answer = getattr(tracker, kind)(*command[2:])  # (this part's arguments)
            except Exception as exc:  # noqa: BLE001 - the caller raises it, as in one process
                _send_error(conn, tag, exc)
                continue
            conn.send((tag, "ok", answer))
    except (EOFError, OSError):  # the caller is gone (closed, or killed): end quietly
        return


def _send_error(conn: Connection, tag: int, exc: Exception) -> None:
    """Send an error to the caller; one that cannot be pickled as a ConvergenceError saying it."""
    try:
        conn.send((tag, "error", exc))
    except (OSError, EOFError):
        raise
    except Exception:  # noqa: BLE001 - not picklable: its type and message
        conn.send((tag, "error", ConvergenceError(f"{type(exc).__name__}: {exc}")))


def _end_workers(conns: List[Connection], procs: List[subprocess.Popen]) -> None:
    """Ask each worker to end, wait a few seconds, kill those still running; empty the lists."""
    for conn in conns:
        try:
            conn.send((0, "close"))
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
        scene = _scene_in_metres(scene)  # (once: an iterable of obstacles is taken as one)
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
        self._options = options
        self._tag = 0  # the last command's tag (0: the start)
        self._reading = False  # inside a connection's recv
        self._closed = False
        try:
            self._local, conns, procs, states = self._spawn(scene, head, theta)
        except BaseException:
            self.close()
            raise
        self._conns.extend(conns)
        self._procs.extend(procs)
        self._scene = scene
        self._state = self._merge(states)

    def _spawn(self, scene, head: BasePose, theta: np.ndarray):
        """
        Start the parts at a pose: part 0's ArrayTracker here, a worker process for each other.

        Returns (part 0's tracker, the workers' connections and processes, the parts' initial
        states); on any failure the workers started are ended and the error raised (a whisker
        cutting an obstacle: the first in the array's order, as one process names it).
        """
        array, first = self.array, self._parts[0]
        conns: List[Connection] = []
        procs: List[subprocess.Popen] = []
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
                conns.append(Connection(ours.detach()))
                procs.append(proc)
                conns[-1].send((tuple(array.whiskers[i] for i in part),
                                array.description, scene, head, theta[part], self._options))
            failures, states = [], []
            local = None
            try:
                local = ArrayTracker(
                    WhiskerArray(tuple(array.whiskers[i] for i in first), array.description),
                    scene, head, theta[first], **self._options)
                states.append(local.state)
            except InvalidPoseError as exc:
                failures.append(exc)
            for j, conn in enumerate(conns):
                try:
                    states.append(self._answer(j, _START_TIMEOUT, conn=conn, proc=procs[j]))
                except InvalidPoseError as exc:
                    failures.append(exc)
            if failures:  # the whisker nearest the array's start, as one process names it
                raise min(failures, key=self._first_named)
        except BaseException:
            _end_workers(conns, procs)
            raise
        return local, conns, procs, states

    # -- the parts ------------------------------------------------------------------------------
    def _protraction(self, protraction) -> np.ndarray:
        """Return the angles, one per whisker, checked before any part moves."""
        return protraction_angles(protraction, len(self.array))

    def _first_named(self, exc: Exception) -> int:
        """Return the index of the whisker an error names ("whisker RC2: ..."), else the end."""
        text = str(exc)
        for i, name in enumerate(self.names):
            if text.startswith(f"whisker {name}:"):
                return i
        return len(self.names)

    def _where(self, j: int) -> str:
        names = [self.names[i] for i in self._parts[j + 1]]
        return f"the array's worker process {j + 1} (whiskers {', '.join(names)})"

    def _failure(self) -> str:
        """Return the error of a failed array: why, and what can be done."""
        if self._closed:
            return f"{self._failed}; the array cannot go on: start it again"
        return f"{self._failed}; the array cannot go on: {_RESTART}"

    def _lost(self, why: str, starting: bool) -> str:
        """Return the error of a worker lost for good; a running array's fails the array."""
        if starting:
            return f"{why} while it was being started; nothing was started"
        self._failed = why
        return self._failure()

    def _answer(self, j: int, timeout: float, tag: int = 0, conn: Optional[Connection] = None,
                proc: Optional[subprocess.Popen] = None):
        """
        Return worker j's answer to the command ``tag``, or raise its error.

        Answers to earlier commands (left unread by an interrupt) are skipped. A failure for
        good (the worker gone, or silent for ``timeout`` s) is a ConvergenceError, and fails
        the array. ``conn`` and ``proc``: a worker being started (its failure is only the
        start's: the running array, if any, goes on).
        """
        starting = conn is not None
        conn = self._conns[j] if conn is None else conn
        proc = self._procs[j] if proc is None else proc
        deadline = time.monotonic() + timeout
        try:
            while True:
                if not conn.poll(max(0.0, deadline - time.monotonic())):
                    raise ConvergenceError(self._lost(
                        f"{self._where(j)} did not answer within {timeout:.0f} s", starting))
                self._reading = True  # (an interrupt inside recv leaves half a message)
                got, kind, value = conn.recv()
                self._reading = False
                if got == tag:
                    break
        except (EOFError, OSError):
            try:
                code = proc.wait(1.0)
            except subprocess.TimeoutExpired:
                code = None
            raise ConvergenceError(self._lost(f"{self._where(j)} ended (exit code {code})",
                                              starting)) from None
        if kind == "error":
            raise value
        return value

    def _ask(self, commands: Sequence[tuple], local):
        """
        Send each worker its command, run ``local()`` on part 0 meanwhile, gather all.

        The first error is raised once every answer is read. Every command carries a tag
        that its answer repeats: answers left unread by an interrupt (Ctrl-C) are skipped by
        the next call. An interrupt while an answer is being read leaves its connection
        unusable: the array then fails for good (ConvergenceError), as when a worker is gone.
        """
        if self._failed is not None:
            raise ConvergenceError(self._failure())
        self._tag += 1
        tag = self._tag
        self._reading = False
        error = None
        answers = []
        try:
            for j, (conn, command) in enumerate(zip(self._conns, commands)):
                try:
                    conn.send((tag,) + tuple(command))
                except (OSError, ValueError):
                    self._failed = f"{self._where(j)} is gone"
                    raise ConvergenceError(self._failure()) from None
            try:
                answers.append(local())
            except Exception as exc:  # noqa: BLE001 - raised once every worker has answered
                error = exc
            for j in range(len(self._conns)):
                try:
                    answers.append(self._answer(j, _ANSWER_TIMEOUT, tag))
                except Exception as exc:  # noqa: BLE001 - the first error is raised
                    error = error or exc
        except BaseException:
            if self._reading and self._failed is None:
                self._failed = ("a tick was interrupted while reading a worker process's "
                                "answer")
            raise
        if error is not None:
            raise error
        return answers

    def _each(self, method: str, args=lambda part: ()) -> list:
        """
        Call an ArrayTracker method on every part, part 0 here: the answers in the parts' order.

        ``args(part)`` gives a part's arguments from its whiskers' indices (:meth:`_ask`: the
        first error is raised once every part has answered).
        """
        parts = self._parts
        return self._ask([(method,) + tuple(args(part)) for part in parts[1:]],
                         lambda: getattr(self._local, method)(*args(parts[0])))

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
        self._state = self._merge(self._each("step", lambda part: (head, theta[part])))
        return self._state

    def reset(self) -> ArrayStep:
        """Re-place every whisker unloaded at its last tick's pose (:meth:`ArrayTracker.reset`)."""
        self._state = self._merge(self._each("reset"))
        return self._state

    def centerlines(self, n: int = 21) -> np.ndarray:
        """Return every whisker's centerline (k, n, 3) [m] (:meth:`ArrayTracker.centerlines`)."""
        return np.concatenate(self._each("centerlines", lambda part: (n,)))[self._order]

    @property
    def failed(self) -> Optional[str]:
        """
        Return why the array cannot go on (a worker ended, or it was closed), or None.

        While it is not None, :meth:`step`, :meth:`reset`, :meth:`centerlines`,
        :meth:`whisker_poses` and :meth:`clearance` raise a ConvergenceError that says it
        (``state`` and :meth:`tracker` still give the last tick's).
        """
        return self._failed

    def restart(self, head: BasePose, protraction=0.0,
                reason: str = "the array restarted") -> ArrayStep:
        """
        Start every part afresh, each whisker unloaded at a pose: after a worker process ended.

        Fresh worker processes take the place of the old ones, which are ended once the new
        parts are placed. Every whisker forgets its history, as :meth:`reset` forgets it, but is
        placed at the pose given (the last tick's pose is where a failed array stopped, and the
        whisking has gone on since).

        Parameters
        ----------
        head : BasePose
            The head pose in the world (position [m]).
        protraction : float or array_like, optional
            The protraction [rad] (one for all, or one per whisker).
        reason : str
            Why, carried by each whisker's event ``reset``.

        Returns
        -------
        ArrayStep
            The unloaded array at that pose, with an event ``reset`` per whisker (its contacts
            before: the last tick's).

        Raises
        ------
        InvalidPoseError
            When an unloaded whisker would cut an obstacle there (the first in the array's
            order is named); the array stays as it was (failed, if it had failed).
        ConvergenceError
            When the array was closed, or a new worker process could not be started.

        """
        if self._closed:
            raise ConvergenceError("the array was closed; it cannot be restarted: start it "
                                   "again")
        head = _as_head(head)
        theta = self._protraction(protraction)
        failed = self._failed
        try:
            local, conns, procs, states = self._spawn(self._scene, head, theta)
        except BaseException:
            self._failed = failed  # (a new worker's failure is not the running array's)
            raise
        before = self._state.contacts.tolist()
        events = tuple(WhiskerEvent(name, "reset", None, None, int(before[i]), 0, str(reason))
                       for i, name in enumerate(self.names))
        state = replace(self._merge(states), events=events)
        # the new parts in place first, then the old workers ended: an interrupt while they end
        # leaves the new array whole (an old worker not ended then ends when its connection,
        # left to the garbage collector, is closed)
        old_conns, old_procs = list(self._conns), list(self._procs)
        self._conns[:], self._procs[:] = conns, procs  # (the lists the finalizer holds)
        self._local, self._state, self._failed = local, state, None
        _end_workers(old_conns, old_procs)
        return self._state

    def whisker_poses(self, head: BasePose, protraction=0.0) -> Tuple[BasePose, ...]:
        """
        Return every whisker's base pose in its own units (:meth:`ArrayTracker.whisker_poses`).

        Parameters
        ----------
        head : BasePose
            The head pose (position [m]).
        protraction : float or array_like, optional
            [rad], one for all or one per whisker.

        Returns
        -------
        tuple of BasePose
            Position [L of that whisker], world orientation.

        """
        head = _as_head(head)
        theta = self._protraction(protraction)
        poses = self._each("whisker_poses", lambda part: (head, theta[part]))
        joined = [pose for part in poses for pose in part]
        return tuple(joined[i] for i in self._order)

    def clearance(self, R: np.ndarray, p: np.ndarray) -> np.ndarray:
        """
        Return each unloaded whisker's sampled distance to the scene (as ArrayTracker's).

        Parameters
        ----------
        R : numpy.ndarray
            (k, 3, 3) base frames in the world.
        p : numpy.ndarray
            (k, 3) base points in the world [m].

        Returns
        -------
        numpy.ndarray
            (k,) the smallest signed distance of the samples [m].

        """
        R = np.asarray(R, dtype=float)
        p = np.asarray(p, dtype=float)
        k = len(self.array)
        if R.shape != (k, 3, 3) or p.shape != (k, 3):
            raise ParameterError(f"R of shape {R.shape} and p of shape {p.shape} are not "
                                 f"allowed; need ({k}, 3, 3) and ({k}, 3)")
        d = self._each("clearance", lambda part: (R[part], p[part]))
        return np.concatenate(d)[self._order]

    def tracker(self, name: str) -> RodTracker:
        """
        Return the single-whisker tracker of a whisker stepped in this process (part 0).

        Parameters
        ----------
        name : str
            The whisker's name.

        Returns
        -------
        RodTracker
            Its tracker (:meth:`ArrayTracker.tracker`).

        Raises
        ------
        KeyError
            When no whisker has that name.
        ParameterError
            When it is stepped in a worker process (whose tracker is not in this one).

        """
        i = self._state.index(name)
        part = i % len(self._parts)
        if part:
            raise ParameterError(f"whisker {name} is stepped in {self._where(part - 1)}: its "
                                 "tracker is not in this process (workers=1 keeps every one "
                                 "here)")
        return self._local.tracker(name)

    def close(self) -> None:
        """End the worker processes (at once if they do not end within a few seconds)."""
        self._finalizer()
        self._closed = True
        if self._failed is None and len(self._parts) > 1:
            self._failed = "the array's worker processes were closed"

    def __enter__(self) -> "PartitionedArrayTracker":
        """Return self (closed on leaving the block)."""
        return self

    def __exit__(self, *exc) -> None:
        """Close the worker processes."""
        self.close()


__all__ = ["MAX_WORKERS", "PartitionedArrayTracker"]
