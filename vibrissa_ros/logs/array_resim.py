"""
``vibrissa resim`` of a log recorded by array_node: every tick again, every whisker compared.

The log's configuration record carries every parameter and the array and scene files' text, so
the array is rebuilt whatever became of the files. The recorded inputs (``~/head_pose``,
``~/whisk`` or the built-in whisk's ``~/protraction``) are taken in log order through the node's
own :class:`~vibrissa_ros.node.array.ArrayPipeline` (bad ones dropped as the node dropped them),
each tick's rows are compared with the recorded ``~/wrenches`` field by field: the six wrench
components, the contact and the base frame of every whisker.
"""

from __future__ import annotations

from typing import Dict, List, Tuple

import numpy as np

from ..node.array import ARRAY_TEXT, SCENE_TEXT, ArrayPipeline, build_array_config, output_rows
from ..node.edge import BadInput, header_ns
from .mcap_log import LogError

#: the compared fields of each whisker's row of ``~/wrenches``
COMPARED = ("fx", "fy", "fz", "mx", "my", "mz", "theta", "s", "f", "cx", "cy", "cz", "x", "y",
            "z", "qx", "qy", "qz", "qw", "contacts", "kind", "obstacle", "error")


def is_array_log(values: Dict[str, object]) -> bool:
    """
    Return whether a recorded configuration is array_node's.

    Parameters
    ----------
    values : dict
        A configuration record's values.

    Returns
    -------
    bool
        True when it carries the array file's text.

    """
    return ARRAY_TEXT in values


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    scale = np.maximum(np.abs(a), np.abs(b))
    diff = np.abs(a - b)
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.where(diff == 0.0, 0.0, diff / scale)
    return float(np.max(rel, initial=0.0))


def resimulate_array(configs: List[Tuple[int, Dict[str, object]]], messages, result):
    """
    Re-run an array_node log's ticks and fill ``result`` (a :class:`~.tools.Resimulation`).

    Parameters
    ----------
    configs : list of (int, dict)
        The log's configuration records (the first one is used: every parameter is read-only).
    messages : list of LogMessage
        The log's messages in log-time order.
    result : Resimulation
        Filled: ``states`` (stamp, ArrayStep) per tick, ``dropped``, ``deviations``,
        ``compared``, ``mismatches``.

    Returns
    -------
    Resimulation
        ``result``.

    Raises
    ------
    LogError
        When the recorded configuration cannot be rebuilt.

    """
    from ..ros.array_messages import decode_cloud
    from .tools import decode

    values = dict(configs[0][1])
    node = values.pop("node", "/array_node")
    recorded = {ARRAY_TEXT: values.pop(ARRAY_TEXT), SCENE_TEXT: values.pop(SCENE_TEXT, "")}
    values = {k: v for k, v in values.items() if k not in ("vibrissa_ros_version", "resets")}
    try:
        config = build_array_config(values, recorded)
        pipeline = ArrayPipeline(config)
    except Exception as exc:  # noqa: BLE001 - any failure to rebuild is the log's problem
        raise LogError(f"the recorded array configuration cannot be rebuilt: {exc}") from None
    prefix = f"{node}/"
    expected, got = [], []
    for m in messages:
        if not m.topic.startswith(prefix):
            continue
        key = m.topic[len(prefix):]
        if key == "wrenches":
            cloud = decode(m)
            got.append((header_ns(cloud), decode_cloud(cloud)))
            continue
        if key not in ("head_pose", "whisk", "protraction"):
            continue
        msg = decode(m)
        try:
            if key == "head_pose":
                p, q = msg.pose.position, msg.pose.orientation
                pipeline.set_head(msg.header.frame_id, (p.x, p.y, p.z), (q.x, q.y, q.z, q.w))
                if config.builtin:
                    continue
            else:
                pipeline.set_joints(msg.name, msg.position)
        except BadInput as exc:
            result.dropped[exc.reason] += 1
            continue
        step = pipeline.tick()
        stamp = header_ns(msg)
        result.states.append((stamp, step))
        expected.append((stamp, output_rows(step, config.scene)))
    if len(expected) == len(got) + 1:
        expected.pop()  # the run stopped during its last tick: that input has no output
    if len(expected) != len(got):
        result.mismatches.append(f"wrenches: {len(got)} recorded, {len(expected)} re-simulated")
    for (s_want, want), (s_have, have) in zip(expected, got):
        if s_want != s_have:
            result.mismatches.append(f"wrenches: stamp {s_have} recorded where {s_want} was "
                                     "expected")
            break
        if len(want) != len(have):
            result.mismatches.append(f"wrenches: {len(have)} whiskers recorded, {len(want)} "
                                     "re-simulated")
            break
        for name in COMPARED:
            key = f"wrenches.{name}"
            dev = _relative(have[name], want[name])
            result.deviations[key] = max(result.deviations.get(key, 0.0), dev)
            result.compared[key] += len(want)
    return result
