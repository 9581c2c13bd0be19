"""
The log tools on a log recorded by whisker_node and checked in (no DDS).

info, resim, export, plot, reconstruct, repair.
"""

import csv
import shutil
from pathlib import Path

import pytest

from vibrissa_ros.cli import main
from vibrissa_ros.core import run_scan
from vibrissa_ros.node.edge import header_ns
from vibrissa_ros.logs.tools import configurations, decode, export_rows, log_info, resimulate
from vibrissa_ros.logs.mcap_log import LogError, read_log, repair
from vibrissa_ros.node.config import build_config

LOG = Path(__file__).parent / "data" / "catenary_sweep.mcap"  # made by data/make_sweep_log.py
N_POSES = 81


def _run(args, capsys):
    code = main(args)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_the_reference_log_is_small():
    assert LOG.stat().st_size < 100_000


def test_info_names_topics_counts_configuration_phases_and_events(capsys):
    info = log_info(str(LOG))
    assert info.topics["/whisker_node/foot_pose"] == ("geometry_msgs/msg/PoseStamped", N_POSES)
    assert info.topics["/whisker_node/wrench"][1] == N_POSES
    assert info.topics["/whisker_node/obstacle"][1] == 1
    assert set(info.phases) == {0, 1, 2} and sum(info.phases.values()) == N_POSES
    kinds = [e["kind"] for e in info.events]
    assert kinds.count("snap") == 2 and kinds[0] == "touch"
    assert set(info.events[0]) == {"kind", "from_phase", "to_phase", "x", "y", "yaw"}
    assert info.configurations[0][1]["obstacle.type"] == "catenary" and info.duration > 0
    code, out, _ = _run(["info", str(LOG)], capsys)
    assert code == 0
    for words in ("/whisker_node/wrench", "geometry_msgs/msg/WrenchStamped", "duration:",
                  'obstacle.type = "catenary"', "phase 2:", "snap"):
        assert words in out


def test_resim_reproduces_every_recorded_output(capsys):
    sim = resimulate(str(LOG))
    assert not sim.mismatches and sim.worst() <= 1e-12
    assert sim.compared["wrench.torque.z"] == N_POSES and sim.compared["events.kind"] == 8
    assert not sim.dropped
    code, out, _ = _run(["resim", str(LOG)], capsys)
    assert code == 0 and "OK" in out and "wrench.torque.z" in out


def test_export_is_the_scan_contract_plus_time_and_equals_a_scan(tmp_path, capsys):
    out = tmp_path / "export.csv"
    code, _, err = _run(["export", str(LOG), "--csv", str(out)], capsys)
    assert code == 0, err
    rows = list(csv.DictReader(out.open()))
    assert list(rows[0]) == ["x0", "phase", "alpha", "s1", "tip_slope", "f", "fx", "fy", "m0",
                             "contact_x", "contact_y", "time"]
    assert len(rows) == N_POSES
    cfg = build_config(configurations(read_log(str(LOG))[2])[0][1])
    scan = run_scan(cfg.profile, [float(r["x0"]) for r in rows]).states
    for row, state in zip(rows, scan):
        assert int(row["phase"]) == int(state.phase)
        assert float(row["m0"]) == pytest.approx(state.m0, rel=1e-12, abs=1e-15)
    times = [float(r["time"]) for r in rows]
    assert times == sorted(times) and times[0] == 1.0
    assert [t for t, _ in export_rows(str(LOG))[0]] == times


def test_plot_of_the_log_is_a_png(tmp_path, capsys):
    png = tmp_path / "log.png"
    code, _, err = _run(["plot", str(LOG), "-o", str(png), "--small-png"], capsys)
    assert code == 0, err
    assert png.read_bytes()[:4] == b"\x89PNG"


def test_reconstruct_recovers_the_recorded_contact_points(tmp_path, capsys):
    out = tmp_path / "profile.csv"
    code, _, err = _run(["reconstruct", str(LOG), "--csv", str(out)], capsys)
    assert code == 0, err
    rows = list(csv.DictReader(out.open()))
    truth = [decode(m) for m in read_log(str(LOG))[3] if m.topic == "/whisker_node/contact_point"]
    assert len(rows) == len(truth) == 46
    for row, point in zip(rows, truth):
        assert float(row["contact_x"]) == pytest.approx(point.point.x, abs=1e-9)
        assert float(row["contact_y"]) == pytest.approx(point.point.y, abs=1e-9)
    assert sorted({header_ns(p) for p in truth}) == [header_ns(p) for p in truth]


def test_repair_of_a_cut_copy_keeps_the_complete_chunks(tmp_path, capsys):
    cut = tmp_path / "cut.mcap"
    data = LOG.read_bytes()
    cut.write_bytes(data[: len(data) // 4])  # the summary (with every schema) is the tail
    with pytest.raises(LogError, match="repair"):
        read_log(str(cut))
    kept = repair(str(cut), str(tmp_path / "fixed.mcap"))
    _, _, metadata, messages = read_log(str(tmp_path / "fixed.mcap"))
    assert 0 < kept == len(messages) < len(read_log(str(LOG))[3])
    assert metadata[0].name == "vibrissa_ros.configuration"
    shutil.copy(LOG, tmp_path / "whole.mcap")
    code, _, err = _run(["repair", str(tmp_path / "whole.mcap"), "-o", str(tmp_path / "w.mcap")],
                        capsys)
    assert code == 0 and f"{len(read_log(str(LOG))[3])} messages kept" in err


def _listwise(configs, messages, resets, has_contacts=True):
    """
    Re-simulate a whisker_node log as resim did before streaming: all outputs kept, zipped.

    The poses are re-run as resim does (tools._Rerun); only the pairing and comparison differ.
    """
    import math
    from collections import defaultdict

    from vibrissa_ros.logs import tools as T

    node = configs[0][1].get("node", "/whisker_node")
    prefix = f"{node}/"
    recorded, poses = defaultdict(list), []
    for m in messages:
        if not m.topic.startswith(prefix):
            continue
        key = m.topic[len(prefix):]
        if key == "foot_pose":
            poses.append(m)
        elif key in T.COMPARED:
            recorded[key].extend(T._recorded_values(key, m))
    result = T.Resimulation()
    rerun = T._Rerun(configs, resets, result)
    expected = defaultdict(list)
    for m in poses:
        for topic, stamp, values in rerun.pose(m):
            expected[topic].append((stamp, values))
    for topic, fields in T.COMPARED.items():
        if topic == "contacts" and not has_contacts:
            continue
        want, have = expected[topic], recorded[topic]
        if len(want) != len(have):
            result.mismatches.append(f"{topic}: {len(have)} recorded, {len(want)} re-simulated")
        for (s_want, v_want), (s_have, v_have) in zip(want, have):
            if s_want is not None and s_want != s_have:
                result.mismatches.append(
                    f"{topic}: stamp {s_have} recorded where {s_want} was expected")
                break
            for name, a, b in zip(fields, v_have, v_want):
                key = f"{topic}.{name}"
                dev = (T._relative(float(a), float(b))
                       if isinstance(a, (int, float)) and isinstance(b, (int, float))
                       else (0.0 if a == b else math.inf))
                result.deviations[key] = max(result.deviations.get(key, 0.0), dev)
                result.compared[key] += 1
    return result


def _altered(messages, topic, k, change):
    """Return the messages with the k-th of ``topic`` changed by ``change(msg)`` (None: drop)."""
    from dataclasses import replace

    from rclpy.serialization import serialize_message

    out, seen = [], 0
    for m in messages:
        if m.topic == topic:
            if seen == k:
                msg = change(decode(m))
                seen += 1
                if msg is not None:
                    out.append(replace(m, data=serialize_message(msg)))
                continue
            seen += 1
        out.append(m)
    return out


def _shift_stamp(msg):
    msg.header.stamp.nanosec += 1
    return msg


def _scale_wrench(msg):
    msg.wrench.torque.z += 1e-3
    return msg


@pytest.mark.parametrize("topic, k, change", [
    (None, 0, None),
    ("/whisker_node/wrench", 40, _scale_wrench),
    ("/whisker_node/wrench", 40, _shift_stamp),
    ("/whisker_node/wrench", 40, lambda msg: None),
    ("/whisker_node/events", 2, lambda msg: None),
    ("/whisker_node/contact_point", 5, _shift_stamp),
])
def test_the_streamed_resim_equals_the_listwise_comparison(topic, k, change):
    # the resim of a whisker_node log reads it once and compares each output as it arrives;
    # the list-wise comparison it replaced (every output kept, then zipped) gives the same
    # deviations, counts and mismatches, on the reference log and on altered copies of it
    from vibrissa_ros.logs.tools import reset_requests, resimulate_poses

    _, channels, metadata, messages = read_log(str(LOG))
    if topic is not None:
        messages = _altered(messages, topic, k, change)
    configs, resets = configurations(metadata), reset_requests(metadata)
    has_contacts = any(c.topic == "/whisker_node/contacts" for c in channels.values())
    streamed = resimulate_poses(configs, iter(messages), resets, has_contacts)
    listwise = _listwise(configs, messages, resets, has_contacts)
    assert streamed.mismatches == listwise.mismatches
    assert streamed.deviations == listwise.deviations
    assert streamed.compared == listwise.compared
    assert len(streamed.states) == len(listwise.states) == N_POSES
    if topic is None:
        assert not streamed.mismatches and streamed.worst() <= 1e-12
    elif change is _scale_wrench:
        assert not streamed.mismatches and streamed.worst() > 1e-6
        assert streamed.deviations["wrench.torque.z"] == streamed.worst()
    else:
        assert streamed.mismatches
