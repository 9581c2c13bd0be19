"""
MCAP logs in the rosbag2 layout: what ``ros2 bag``, Foxglove and rosbags open.

* header profile ``ros2``; one schema per message type, encoding ``ros2msg``, whose text is the
  type's .msg file followed by every dependency, each after a line of 80 ``=`` and
  ``MSG: pkg/Type`` (as rosbag2 writes it; the texts are read from the installed interface
  packages, share/<pkg>/msg);
* channels with message encoding ``cdr`` and metadata ``offered_qos_profiles`` (rosbag2's YAML) and
  ``topic_type_hash`` (the type's RIHS01 hash from share/<pkg>/msg/<Type>.json);
* a type whose interface package has no wheel here but which the logs need,
  ``tf2_msgs/msg/TFMessage`` (the transforms by which Foxglove places frames), is composed from
  installed types: its .msg text as tf2_msgs defines it, and its RIHS01 hash computed as REP 2011
  and rosidl compute it, from the installed types' type descriptions;
* zstd-compressed chunks, closed at least every ``flush_period`` seconds so that a killed writer
  loses at most that much; log and publish times in integer nanoseconds.

No rclpy here: messages arrive serialized (CDR bytes).
"""

from __future__ import annotations

import hashlib
import json
import re
import struct
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO, Dict, Iterable, Iterator, List, Optional, Tuple

from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Channel, ChunkIndex, Footer, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer

from .. import __version__
from ..core.errors import VibrissaError

PROFILE = "ros2"
SCHEMA_ENCODING = "ros2msg"
MESSAGE_ENCODING = "cdr"
CONFIGURATION_METADATA = "vibrissa_ros.configuration"
#: a ``~/reset`` request: ``poses_before`` (foot poses recorded before it) and ``log_time``
RESET_METADATA = "vibrissa_ros.reset"
_PRIMITIVES = {
    "bool",
    "byte",
    "char",
    "float32",
    "float64",
    "int8",
    "uint8",
    "int16",
    "uint16",
    "int32",
    "uint32",
    "int64",
    "uint64",
    "string",
    "wstring",
}
_DELIMITER = "=" * 80 + "\n"
#: types composed of installed ones where their own package is not installed: {pkg/Type: (the
#: .msg text, ((field, rosidl type id, nested type), ...))}; type id 145 = an unbounded sequence
#: of a nested type (rosidl's FIELD_TYPE_NESTED_TYPE_UNBOUNDED_SEQUENCE)
_COMPOSED = {
    "tf2_msgs/TFMessage": ("geometry_msgs/TransformStamped[] transforms\n",
                           (("transforms", 145, "geometry_msgs/msg/TransformStamped"),)),
}
# the infinite duration of rmw (RMW_DURATION_INFINITE), as rosbag2 writes it
_INFINITE = "\n    sec: 9223372036\n    nsec: 854775807"


class LogError(VibrissaError):
    """A log cannot be written or read."""


def _split_type(type_name: str) -> Tuple[str, str]:
    """'geometry_msgs/msg/Wrench' or 'geometry_msgs/Wrench' -> ('geometry_msgs', 'Wrench')."""
    parts = type_name.split("/")
    if len(parts) == 3 and parts[1] == "msg":
        return parts[0], parts[2]
    if len(parts) == 2:
        return parts[0], parts[1]
    raise LogError(f"not a message type name: {type_name!r}")


def _share_dir(package: str) -> Path:
    """
    Find share/<package> through the ament index, or beside this interpreter.

    A plain virtual environment has no AMENT_PREFIX_PATH, and the interface wheels install
    into <venv>/share.
    """
    try:
        from ament_index_python.packages import get_package_share_directory

        return Path(get_package_share_directory(package))
    except (ImportError, LookupError, OSError):  # no ament index, not in it, or unset
        candidate = Path(sys.prefix) / "share" / package
        if (candidate / "msg").is_dir():
            return candidate
        raise LogError(
            f"interface package {package!r} is not installed (no share/{package}/msg)"
        ) from None


def _msg_file(package: str, name: str, suffix: str = ".msg") -> Path:
    path = _share_dir(package) / "msg" / f"{name}{suffix}"
    if not path.is_file():
        raise LogError(f"no definition {path} for {package}/{name}")
    return path


def _dependencies(text: str, package: str) -> List[str]:
    deps = set()
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        field_type = line.split()[0]
        base = re.sub(r"\[.*\]$", "", field_type)
        base = re.sub(r"<=\d+$", "", base)
        if base in _PRIMITIVES:
            continue
        if base == "Header":
            deps.add("std_msgs/Header")
        elif "/" in base:
            deps.add(base)
        else:
            deps.add(f"{package}/{base}")
    return sorted(deps)


def _msg_text(package: str, name: str) -> str:
    """Return the .msg text of package/name: installed, or composed (:data:`_COMPOSED`)."""
    try:
        return _msg_file(package, name).read_text()
    except LogError:
        composed = _COMPOSED.get(f"{package}/{name}")
        if composed is None:
            raise
        return composed[0]


def message_definition(type_name: str) -> str:
    """Return the ros2msg schema of ``type_name`` ('pkg/msg/Type'): its .msg and dependencies."""
    seen = set()

    def text_of(pkg_type: str) -> str:
        package, name = _split_type(pkg_type)
        text = _msg_text(package, name)
        out = text
        for dep in _dependencies(text, package):
            if dep in seen:
                continue
            seen.add(dep)
            out += "\n" + _DELIMITER + f"MSG: {dep}\n" + text_of(dep)
        return out

    return text_of(type_name)


def rihs01(description: dict) -> str:
    """
    Return the RIHS01 hash of a type description (REP 2011; rosidl's calculate_type_hash).

    ``description``: ``{"type_description": {...}, "referenced_type_descriptions": [...]}`` as
    the interface packages' .json files hold it (``type_description_msg``); the fields' default
    values are left out of the hash.
    """
    hashable = {
        "type_description": _without_defaults(description["type_description"]),
        "referenced_type_descriptions": [_without_defaults(d) for d in
                                         description["referenced_type_descriptions"]],
    }
    text = json.dumps(hashable, ensure_ascii=True, allow_nan=False, indent=None,
                      separators=(", ", ": "), sort_keys=False)
    return "RIHS01_" + hashlib.sha256(text.encode("utf-8")).hexdigest()


def _without_defaults(description: dict) -> dict:
    return {"type_name": description["type_name"],
            "fields": [{k: v for k, v in field.items() if k != "default_value"}
                       for field in description["fields"]]}


def _composed_hash(package: str, name: str) -> str:
    """Return the RIHS01 hash of a composed type from its fields' installed descriptions."""
    _, fields = _COMPOSED[f"{package}/{name}"]
    referenced = {}
    for _, _, nested in fields:
        nested_package, nested_name = _split_type(nested)
        data = json.loads(_msg_file(nested_package, nested_name, ".json").read_text())
        desc = data["type_description_msg"]
        for d in [desc["type_description"]] + desc["referenced_type_descriptions"]:
            referenced[d["type_name"]] = d
    own = {"type_name": f"{package}/msg/{name}",
           "fields": [{"name": field, "type": {"type_id": type_id, "capacity": 0,
                                               "string_capacity": 0,
                                               "nested_type_name": nested},
                       "default_value": ""} for field, type_id, nested in fields]}
    return rihs01({"type_description": own, "referenced_type_descriptions":
                   [referenced[k] for k in sorted(referenced)]})


def type_hash(type_name: str) -> str:
    """Return the type's RIHS01 hash as the installed interface package states it."""
    package, name = _split_type(type_name)
    try:
        data = json.loads(_msg_file(package, name, ".json").read_text())
    except LogError:
        if f"{package}/{name}" not in _COMPOSED:
            raise
        return _composed_hash(package, name)
    full = f"{package}/msg/{name}"
    for entry in data.get("type_hashes", []):
        if entry.get("type_name") == full:
            return entry["hash_string"]
    raise LogError(f"no type hash for {full}")


def qos_yaml(reliable: bool = True, transient_local: bool = False, depth: int = 1000,
             keep_all: bool = False) -> str:
    """rosbag2's ``offered_qos_profiles`` (a YAML list with one offered profile)."""
    return (
        f"- history: {'keep_all' if keep_all else 'keep_last'}\n  depth: {depth}\n"
        f"  reliability: {'reliable' if reliable else 'best_effort'}\n"
        f"  durability: {'transient_local' if transient_local else 'volatile'}\n"
        f"  deadline:{_INFINITE}\n  lifespan:{_INFINITE}\n  liveliness: automatic\n"
        f"  liveliness_lease_duration:{_INFINITE}\n  avoid_ros_namespace_conventions: false"
    )


@dataclass(frozen=True)
class TopicSpec:
    topic: str
    type_name: str  # pkg/msg/Type
    reliable: bool = True
    transient_local: bool = False
    depth: int = 1000
    keep_all: bool = False


#: what a channel needs besides its TopicSpec: the schema text and the channel's metadata
ChannelDescription = Tuple[bytes, Dict[str, str]]


def describe_channel(spec: TopicSpec) -> ChannelDescription:
    """
    Return what a channel of ``spec`` is registered with: its schema's text and its metadata.

    Parameters
    ----------
    spec : TopicSpec
        The channel's topic, type and offered QoS.

    Returns
    -------
    text : bytes
        The ros2msg schema of the type (:func:`message_definition`).
    metadata : dict
        ``offered_qos_profiles`` (rosbag2's YAML) and ``topic_type_hash``.

    Raises
    ------
    LogError
        When the type's interface package is not installed.

    """
    text = message_definition(spec.type_name).encode()
    metadata = {
        "offered_qos_profiles": qos_yaml(spec.reliable, spec.transient_local, spec.depth,
                                         spec.keep_all),
        "topic_type_hash": type_hash(spec.type_name),
    }
    return text, metadata


def open_log(path: str) -> BinaryIO:
    """
    Open a log file for writing, created or overwritten.

    Parameters
    ----------
    path : str or path-like
        The log file.

    Returns
    -------
    BinaryIO
        The open file.

    Raises
    ------
    LogError
        When it cannot be opened, with the OS's reason.

    """
    try:
        return open(path, "wb")
    except OSError as exc:
        raise LogError(f"cannot open {str(path)!r} for writing: {exc.strerror or exc}") from None


class LogWriter:
    """
    Writes one MCAP log; raises :class:`LogError` (with the OS's reason) when it cannot.

    Parameters
    ----------
    path : str or path-like
        The log file, created or overwritten.
    chunk_size : int, optional
        The MCAP chunk size [bytes] (chunks are ZSTD-compressed).
    flush_period : float, optional
        The longest time [s] a written message waits in the open chunk before it is flushed
        (:meth:`flush_if_due`): what a crash can lose.
    stream : binary file, optional
        Write to this stream, already open (``path`` then only names it in messages), instead of
        opening ``path``.

    Raises
    ------
    LogError
        When the file cannot be opened or written, with the OS's reason.

    """

    def __init__(self, path: str, chunk_size: int = 1 << 20, flush_period: float = 0.5,
                 stream: Optional[BinaryIO] = None):
        self.path = str(path)
        self._stream = stream if stream is not None else open_log(self.path)
        self._writer = Writer(
            self._stream, chunk_size=chunk_size, compression=CompressionType.ZSTD
        )
        self._schemas: Dict[str, int] = {}
        self._channels: Dict[str, int] = {}
        self._flush_period = flush_period
        self._last_flush = time.monotonic()
        self._pending = False
        self._closed = False
        self.messages = 0
        self._guard(
            lambda: self._writer.start(profile=PROFILE, library=f"vibrissa_ros {__version__}")
        )

    def _guard(self, action):
        try:
            return action()
        except OSError as exc:
            self._closed = True
            try:
                self._stream.close()
            except OSError:
                pass
            raise LogError(f"writing {self.path!r} failed: {exc.strerror or exc}") from None

    def channel(self, spec: TopicSpec, description: Optional["ChannelDescription"] = None) -> int:
        """Register the channel of ``spec`` (once per topic); return its id."""
        if spec.topic in self._channels:
            return self._channels[spec.topic]
        text, metadata = description if description is not None else describe_channel(spec)
        if spec.type_name not in self._schemas:
            self._schemas[spec.type_name] = self._guard(
                lambda: self._writer.register_schema(spec.type_name, SCHEMA_ENCODING, text)
            )
        cid = self._guard(
            lambda: self._writer.register_channel(
                spec.topic, MESSAGE_ENCODING, self._schemas[spec.type_name], metadata
            )
        )
        self._channels[spec.topic] = cid
        return cid

    def write(
        self, channel_id: int, data: bytes, log_time: int, publish_time: Optional[int] = None
    ) -> None:
        if self._closed:
            raise LogError(f"{self.path!r} is closed")
        self._guard(lambda: self._writer.add_message(
            channel_id=channel_id, log_time=int(log_time), data=data,
            publish_time=int(publish_time if publish_time is not None else log_time),
        ))
        self.messages += 1
        self._pending = True
        self.flush_if_due()

    def metadata(self, name: str, data: Dict[str, str]) -> None:
        self._guard(
            lambda: self._writer.add_metadata(name, {str(k): str(v) for k, v in data.items()})
        )

    def flush_if_due(self, now: Optional[float] = None) -> None:
        """Close the open chunk if it is older than the flush period (bounded loss on a crash)."""
        now = time.monotonic() if now is None else now
        if self._pending and now - self._last_flush >= self._flush_period:
            self.flush()

    def flush(self) -> None:
        if self._closed:
            return
        self._guard(self._writer.flush)
        self._last_flush = time.monotonic()
        self._pending = False

    def close(self) -> None:
        """Write the summary and close the file: a finished, indexed MCAP."""
        if self._closed:
            return
        self._guard(self._writer.finish)
        self._closed = True
        self._guard(self._stream.close)

    def abandon(self) -> None:
        """
        Finish the file as far as possible after a failure, and never raise.

        What was written stays readable where the disk allows it.
        """
        if self._closed:
            return
        self._closed = True
        try:
            self._writer.finish()
        except (OSError, McapError, ValueError, AttributeError):
            pass  # the disk is full or gone, or the writer is broken: the chunks on disk remain
        try:
            self._stream.close()
        except OSError:
            pass


# -- reading ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class LogMessage:
    topic: str
    type_name: str
    log_time: int
    publish_time: int
    data: bytes


#: what a damaged or cut file raises in the mcap reader
_READ_ERRORS = (McapError, struct.error, ValueError, EOFError)


def _damaged(path, exc) -> LogError:
    return LogError(
        f"cannot read {path}: {exc}; if it was not finished, 'vibrissa repair' rewrites it"
    )


class LogReader:
    """
    A finished MCAP log, open for reading: its summary and metadata at once, its messages streamed.

    Opening reads the summary (schemas, channels) and the metadata records (the recorded
    configuration), not the messages: :meth:`messages` yields them one at a time, in log-time
    order, decompressing one chunk after another, so that a long log never has to fit in
    memory. Use it as a context manager (or call :meth:`close`).

    Parameters
    ----------
    path : str or path-like
        The log file.

    Attributes
    ----------
    schemas : dict
        The MCAP schemas by id.
    channels : dict
        The MCAP channels by id.
    metadata : list
        The MCAP metadata records, in file order.

    Raises
    ------
    FileNotFoundError
        When there is no such file.
    LogError
        When the file has no summary (not finished: ``vibrissa repair`` rewrites it) or is
        damaged.

    """

    def __init__(self, path: str):
        if not Path(path).is_file():
            raise FileNotFoundError(2, "no such file", str(path))
        self.path = str(path)
        self._stream = open(path, "rb")
        try:
            self._reader = make_reader(self._stream)
            summary = self._reader.get_summary()
            if summary is None:
                raise LogError(
                    f"{path} has no summary (not finished?): run 'vibrissa repair' on it"
                )
            self.schemas, self.channels = summary.schemas, summary.channels
            self.metadata = list(self._reader.iter_metadata())
            self._statistics = summary.statistics
        except _READ_ERRORS as exc:
            self._stream.close()
            raise _damaged(path, exc) from None
        except BaseException:
            self._stream.close()
            raise

    def messages(self, topics: Optional[Iterable[str]] = None) -> Iterator[LogMessage]:
        """
        Yield the log's messages in log-time order, one at a time.

        Parameters
        ----------
        topics : iterable of str, optional
            Only these topics (default: all). The others are skipped before a message object
            is made.

        Yields
        ------
        LogMessage
            The messages, as :func:`read_log` lists them (ties in log time in file order).

        Raises
        ------
        LogError
            When a chunk is damaged (raised where the iteration reaches it).

        """
        wanted = None if topics is None else list(topics)
        try:
            for schema, channel, message in self._reader.iter_messages(
                    topics=wanted, log_time_order=True):
                yield LogMessage(
                    channel.topic,
                    schema.name if schema else "",
                    message.log_time,
                    message.publish_time,
                    message.data,
                )
        except _READ_ERRORS as exc:
            raise _damaged(self.path, exc) from None

    def counts(self) -> Dict[str, int]:
        """
        Return the number of messages of each topic, from the summary (or one pass over them).

        Returns
        -------
        dict
            ``{topic: messages}``, every channel's topic (0 for a channel without messages).

        """
        out = {c.topic: 0 for c in self.channels.values()}
        stats = self._statistics
        if stats is not None and stats.channel_message_counts:
            for channel_id, n in stats.channel_message_counts.items():
                out[self.channels[channel_id].topic] += n
            return out
        for m in self.messages():  # a log written without statistics: count them
            out[m.topic] += 1
        return out

    def close(self) -> None:
        """Close the file (a message iteration still running then stops with an error)."""
        self._stream.close()

    def __enter__(self) -> "LogReader":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def read_log(path: str):
    """
    Read a finished MCAP: (schemas, channels by id, metadata, messages in log-time order).

    Every message is in the returned list: a long log is better streamed with
    :class:`LogReader`.

    Parameters
    ----------
    path : str or path-like
        The log file.

    Returns
    -------
    schemas : dict
        The MCAP schemas by id.
    channels : dict
        The MCAP channels by id.
    metadata : list
        The MCAP metadata records, in file order.
    messages : list of LogMessage
        The messages in log-time order.

    Raises
    ------
    FileNotFoundError
        When there is no such file.
    LogError
        When the file has no summary (not finished: ``vibrissa repair`` rewrites it) or is
        damaged.

    """
    with LogReader(path) as log:
        return log.schemas, log.channels, log.metadata, list(log.messages())


def repair(path: str, output: str) -> int:
    """
    Rewrite a log that was not finished (e.g. after kill -9) into a valid one.

    Reads the records in order until the data stops making sense (a chunk cut off by the crash);
    every complete chunk's messages, all schemas, channels and metadata are kept.

    Parameters
    ----------
    path : str or path-like
        The unfinished log.
    output : str or path-like
        The valid log written, created or overwritten.

    Returns
    -------
    int
        The number of messages kept.

    Raises
    ------
    LogError
        When nothing is recoverable (not an MCAP file?).

    """
    schemas: Dict[int, Schema] = {}
    channels: Dict[int, Channel] = {}
    metadata: List[Metadata] = []
    messages: List[Message] = []
    with open(path, "rb") as stream:
        reader = StreamReader(stream, skip_magic=False, emit_chunks=False)
        try:
            for record in reader.records:
                if isinstance(record, Schema):
                    schemas[record.id] = record
                elif isinstance(record, Channel):
                    channels[record.id] = record
                elif isinstance(record, Message):
                    messages.append(record)
                elif isinstance(record, Metadata):
                    metadata.append(record)
                elif isinstance(record, (ChunkIndex, Footer)):
                    break
        except (McapError, struct.error, ValueError, EOFError):
            pass  # the truncated tail: stop where the data ends
    if not schemas and not messages:
        raise LogError(f"{path}: nothing recoverable (not an MCAP file?)")
    with open(output, "wb") as out:
        writer = Writer(out, compression=CompressionType.ZSTD)
        writer.start(profile=PROFILE, library=f"vibrissa_ros {__version__} (repaired)")
        schema_ids = {
            sid: writer.register_schema(s.name, s.encoding, s.data) for sid, s in schemas.items()
        }
        channel_ids = {
            cid: writer.register_channel(
                c.topic, c.message_encoding, schema_ids.get(c.schema_id, 0), dict(c.metadata)
            )
            for cid, c in channels.items()
        }
        for m in metadata:
            writer.add_metadata(m.name, dict(m.metadata))
        kept = 0
        for m in sorted(messages, key=lambda m: m.log_time):
            if m.channel_id in channel_ids:
                writer.add_message(
                    channel_ids[m.channel_id], m.log_time, m.data, m.publish_time, m.sequence
                )
                kept += 1
        writer.finish()
    return kept
