"""
Writing a log away from the caller: in a thread (:class:`LogThread`) or a process of its own.

Both take messages already serialized (CDR bytes) and return at once; a background writer
chunks, compresses and writes them with :class:`~.mcap_log.LogWriter`. Both have the same
interface: ``channel(spec)``, ``write(channel, data, log_time)``, ``metadata(name, data)``,
``messages`` (written so far), ``close()``. A failure of any kind stops the writing, never the
caller: it is reported once through ``on_error`` (from the thread named ``vibrissa-recorder``),
the file is finished as far as it can be, and later calls do nothing.

:class:`LogProcess` keeps the writing off the caller's interpreter (its GIL): the messages are
batched in memory and sent every ``batch_period`` seconds through a pipe to a writer process
(:func:`main`, with this interpreter) that owns the file. The writer process ignores
SIGINT and SIGTERM (a Ctrl-C reaches the whole process group: the caller finishes the log through
:meth:`LogProcess.close`), and finishes the file by itself when its input ends, e.g. when the
caller was killed on its own. It stays in the caller's process group: a kill -9 of the group
leaves an unfinished log, of which ``vibrissa repair`` keeps all but the last ``flush_period``.

No rclpy here.
"""

from __future__ import annotations

import os
import pickle
import queue
import select
import signal
import struct
import subprocess
import sys
import threading
import time
from collections import deque
from typing import Callable, Deque, Dict, List, Optional, Tuple

from .mcap_log import LogError, LogWriter, TopicSpec, describe_channel

THREAD_NAME = "vibrissa-recorder"
_FRAME = struct.Struct("<I")  # the length of each pickled frame on the pipes
_META = "meta"
_CHANNEL = "channel"


def _failure(path: str, exc: BaseException) -> str:
    """Return the one-line reason of a writer's failure."""
    if isinstance(exc, LogError):
        return str(exc)
    return f"writing {path!r} failed: {type(exc).__name__}: {exc}"


class _Reporter:
    """Report the first failure once, through ``on_error``."""

    def __init__(self, on_error: Callable[[str], None]):
        self.error: Optional[str] = None
        self._on_error = on_error
        self._lock = threading.Lock()

    def fail(self, reason: str) -> None:
        with self._lock:
            if self.error is not None:
                return
            self.error = reason
        self._on_error(reason)


class LogThread:
    """
    Write a log in a thread of the caller's process.

    Parameters
    ----------
    writer : LogWriter
        The open log; the thread writes it and finishes it on :meth:`close`.
    on_error : callable, optional
        Called once with the reason when writing fails.

    """

    _STOP = object()

    def __init__(self, writer: LogWriter, on_error: Callable[[str], None] = lambda reason: None):
        self.path = writer.path
        self._writer = writer
        self._report = _Reporter(on_error)
        self._queue: "queue.SimpleQueue" = queue.SimpleQueue()
        self._thread = threading.Thread(target=self._run, name=THREAD_NAME, daemon=True)
        self._thread.start()

    @property
    def error(self) -> Optional[str]:
        """Return the reason the writing stopped, or None."""
        return self._report.error

    @property
    def messages(self) -> int:
        """Return the number of messages written to the file."""
        return self._writer.messages

    def channel(self, spec: TopicSpec) -> int:
        """Register the channel of ``spec``; LogError (in this thread) if its type is unknown."""
        return self._writer.channel(spec)

    def write(self, channel: int, data: bytes, log_time: int) -> None:
        """Queue a serialized message of ``channel``, logged at ``log_time`` [ns]."""
        self._queue.put((channel, data, log_time))

    def metadata(self, name: str, data: Dict[str, str]) -> None:
        """Queue a metadata record, in order with the messages."""
        self._queue.put((_META, name, data))

    def _run(self) -> None:
        writer = self._writer
        try:
            while True:
                try:
                    item = self._queue.get(timeout=0.1)
                except queue.Empty:
                    item = None
                if item is self._STOP:
                    return
                if item is not None:
                    if item[0] == _META:
                        writer.metadata(item[1], item[2])
                    else:
                        writer.write(item[0], item[1], item[2])
                writer.flush_if_due()
        except Exception as exc:  # noqa: BLE001 - any failure of this thread must be reported
            self._report.fail(_failure(self.path, exc))
            writer.abandon()  # finish the file as far as possible: what was written stays

    def close(self) -> None:
        """Write what is queued, then the summary (after a failure: what could be saved)."""
        if self._thread.is_alive():
            self._queue.put(self._STOP)
            self._thread.join()
        if self._report.error is None:
            try:
                self._writer.close()
            except LogError as exc:
                self._report.fail(str(exc))


def _send_frame(fd: int, obj) -> None:
    data = pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
    view = memoryview(_FRAME.pack(len(data)) + data)
    while view:
        view = view[os.write(fd, view):]


def _read_exact(fd: int, n: int) -> Optional[bytes]:
    parts, left = [], n
    while left:
        part = os.read(fd, left)
        if not part:
            return None
        parts.append(part)
        left -= len(part)
    return b"".join(parts)


def _read_frame(fd: int):
    """Return the next frame, or None when the pipe has ended."""
    head = _read_exact(fd, _FRAME.size)
    if head is None:
        return None
    body = _read_exact(fd, _FRAME.unpack(head)[0])
    return None if body is None else pickle.loads(body)


# the writer process: it ignores SIGINT and SIGTERM before anything else (its imports take a
# while, and a Ctrl-C reaches the whole process group)
_WRITER_MAIN = ("import signal; signal.signal(signal.SIGINT, signal.SIG_IGN); "
                "signal.signal(signal.SIGTERM, signal.SIG_IGN); "
                "from vibrissa_ros.logs.background import main; main()")


class LogProcess:
    """
    Write a log in a process of its own, fed with serialized messages through a pipe.

    Parameters
    ----------
    path : str or path-like
        The log file, created or overwritten (opened here: LogError at once when it cannot be).
    on_error : callable, optional
        Called once with the reason when writing fails (the writer process's reason).
    chunk_size : int, optional
        The MCAP chunk size [bytes] (chunks are ZSTD-compressed).
    flush_period : float, optional
        The longest time [s] a written message waits in the open chunk (what a crash can lose,
        with ``batch_period``).
    batch_period : float, optional
        How often [s] the messages queued are sent to the writer process.

    Raises
    ------
    LogError
        When the file cannot be opened, with the OS's reason.

    """

    def __init__(self, path: str, on_error: Callable[[str], None] = lambda reason: None,
                 chunk_size: int = 1 << 20, flush_period: float = 0.5,
                 batch_period: float = 0.02):
        self.path = str(path)
        self._report = _Reporter(on_error)
        self._pending: Deque[tuple] = deque()  # append and popleft are atomic: no lock
        self._channels: Dict[str, int] = {}
        self._written = 0
        self._batch_period = batch_period
        self._closing = threading.Event()
        try:
            fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o666)
        except OSError as exc:
            raise LogError(
                f"cannot open {self.path!r} for writing: {exc.strerror or exc}") from None
        try:
            self._proc = subprocess.Popen(
                [sys.executable, "-c", _WRITER_MAIN, str(fd)],
                stdin=subprocess.PIPE, stdout=subprocess.PIPE, pass_fds=(fd,))
        except OSError as exc:
            raise LogError(f"cannot start the writer of {self.path!r}: {exc}") from None
        finally:
            os.close(fd)
        self._to_child = self._proc.stdin.fileno()
        self._from_child = self._proc.stdout.fileno()
        self._pending.append(("open", self.path, chunk_size, flush_period))
        self._thread = threading.Thread(target=self._run, name=THREAD_NAME, daemon=True)
        self._thread.start()

    @property
    def error(self) -> Optional[str]:
        """Return the reason the writing stopped, or None."""
        return self._report.error

    @property
    def messages(self) -> int:
        """Return the number of messages the writer process has written to the file."""
        return self._written

    def channel(self, spec: TopicSpec) -> int:
        """Register the channel of ``spec``; LogError (at once) if its type is not installed."""
        if spec.topic not in self._channels:
            index = len(self._channels)
            self._pending.append((_CHANNEL, index, spec, describe_channel(spec)))
            self._channels[spec.topic] = index
        return self._channels[spec.topic]

    def write(self, channel: int, data: bytes, log_time: int) -> None:
        """Queue a serialized message of ``channel``, logged at ``log_time`` [ns]."""
        self._pending.append((channel, data, log_time))

    def metadata(self, name: str, data: Dict[str, str]) -> None:
        """Queue a metadata record, in order with the messages."""
        self._pending.append((_META, name, data))

    def _take(self) -> List[tuple]:
        pending = self._pending
        return [pending.popleft() for _ in range(len(pending))]

    def _replies(self, timeout: float) -> bool:
        """Read the writer's replies; return True once it has closed the log."""
        while select.select([self._from_child], [], [], timeout)[0]:
            timeout = 0.0
            reply = _read_frame(self._from_child)
            if reply is None:
                if self._report.error is None:
                    self._report.fail(f"writing {self.path!r} failed: the writer process ended "
                                      f"(exit status {self._proc.wait()})")
                return True
            kind, value = reply
            if kind == "error":
                self._report.fail(value)
            else:
                self._written = value
                if kind == "closed":
                    return True
        return False

    def _run(self) -> None:
        try:
            while self._report.error is None:
                closing = self._closing.wait(self._batch_period)
                batch = self._take()
                if batch:
                    _send_frame(self._to_child, ("batch", batch))
                if closing:
                    _send_frame(self._to_child, ("close", None))
                    deadline = time.monotonic() + 60.0
                    while not self._replies(0.1) and time.monotonic() < deadline:
                        pass
                    return
                if self._replies(0.0):
                    return
        except OSError:  # the pipe broke: the writer process is gone; say why if it told
            self._replies(1.0)
            self._report.fail(self._report.error or f"writing {self.path!r} failed: the writer "
                              "process ended")
        except Exception as exc:  # noqa: BLE001 - any failure of this thread must be reported
            self._report.fail(_failure(self.path, exc))

    def close(self) -> None:
        """Send what is queued, let the writer finish the file, wait for it to end."""
        self._closing.set()
        self._thread.join()
        for stream in (self._proc.stdin, self._proc.stdout):
            try:
                stream.close()
            except OSError:
                pass
        try:
            self._proc.wait(timeout=60.0)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait()


def _serve(fd: int, commands: int, replies: int) -> None:
    """Write the log on ``fd`` from the frames on ``commands``; report on ``replies``."""
    writer: Optional[LogWriter] = None
    channels: Dict[int, int] = {}
    path = "the log"
    try:
        while True:
            if writer is None or select.select([commands], [], [], 0.1)[0]:
                frame = _read_frame(commands)
                if frame is None or frame[0] == "close":  # closed, or the caller is gone
                    if writer is not None:
                        writer.close()
                        _send_frame(replies, ("closed", writer.messages))
                    return
                for item in frame[1]:
                    head = item[0]
                    if head == "open":
                        path = item[1]
                        writer = LogWriter(path, item[2], item[3], stream=os.fdopen(fd, "wb"))
                    elif head == _CHANNEL:
                        channels[item[1]] = writer.channel(item[2], item[3])
                    elif head == _META:
                        writer.metadata(item[1], item[2])
                    else:
                        writer.write(channels[head], item[1], item[2])
                _send_frame(replies, ("written", writer.messages))
            writer.flush_if_due()
    except Exception as exc:  # noqa: BLE001 - report any failure, keep what was written
        try:
            _send_frame(replies, ("error", _failure(path, exc)))
        except OSError:
            pass
        if writer is not None:
            writer.abandon()


def main(argv: Optional[Tuple[str, ...]] = None) -> None:
    """
    Run the writer process of a :class:`LogProcess`: commands on standard input, replies out.

    Parameters
    ----------
    argv : tuple of str, optional
        The open log file's descriptor (default: the command line's first argument).

    """
    args = sys.argv[1:] if argv is None else list(argv)
    for sig in (signal.SIGINT, signal.SIGTERM):  # the caller decides when the log ends
        signal.signal(sig, signal.SIG_IGN)
    replies = os.dup(sys.stdout.fileno())
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())  # stray prints must not reach the pipe
    _serve(int(args[0]), sys.stdin.fileno(), replies)
