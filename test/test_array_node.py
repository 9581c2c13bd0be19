"""Launch-free integration tests of array_node (the rat's right whisker pad), over real DDS."""

from collections import Counter
import json
import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from ros_harness import LATCHED, ROOT, read_params, start_installed_node, stop, write_params
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState, PointCloud2
from std_msgs.msg import String
from std_srvs.srv import Trigger
from visualization_msgs.msg import Marker, MarkerArray

from vibrissa_ros.core.arrays import ArrayTracker
from vibrissa_ros.core.rod3d import BasePose
from vibrissa_ros.logs.tools import decode, log_info, resimulate
from vibrissa_ros.node.array import build_array_config, output_rows
from vibrissa_ros.node.edge import header_ns, set_stamp
from vibrissa_ros.ros.array_messages import decode_cloud

SHIPPED = ROOT / "config" / "rat_array_node.yaml"
VIBRISSA = str(Path(sys.executable).with_name("vibrissa"))
KEEP_ALL = QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=1000,
                      reliability=ReliabilityPolicy.RELIABLE)
WRENCH = ("fx", "fy", "fz", "mx", "my", "mz")


def _shipped():
    return read_params(SHIPPED)


class ArrayProbe:
    """A test node that drives array_node and keeps what it publishes."""

    def __init__(self, context, prefix):
        self.node = rclpy.create_node("array_probe", context=context)
        self.prefix = prefix
        self.got = {"wrenches": [], "events": [], "whiskers": [], "obstacles": [],
                    "diagnostics": [], "shapes": [], "contacts": []}
        n = self.node
        n.create_subscription(PointCloud2, f"{prefix}/wrenches", self._keep("wrenches"),
                              KEEP_ALL)
        n.create_subscription(String, f"{prefix}/events", self._keep("events"), KEEP_ALL)
        n.create_subscription(String, f"{prefix}/whiskers", self._keep("whiskers"), LATCHED)
        n.create_subscription(MarkerArray, f"{prefix}/obstacles", self._keep("obstacles"),
                              LATCHED)
        n.create_subscription(MarkerArray, f"{prefix}/shapes", self._keep("shapes"), 10)
        n.create_subscription(PointCloud2, f"{prefix}/contacts", self._keep("contacts"), 10)
        n.create_subscription(DiagnosticArray, "/diagnostics", self._keep("diagnostics"), 50)
        self.whisk = n.create_publisher(JointState, f"{prefix}/whisk", KEEP_ALL)
        self.head = n.create_publisher(PoseStamped, f"{prefix}/head_pose", KEEP_ALL)
        self.reset = n.create_client(Trigger, f"{prefix}/reset")
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(n)

    def handshake(self, first, timeout=30.0):
        """Publish ``first`` until the node answers (graph matching alone loses messages)."""
        end = time.monotonic() + timeout
        while not self.got["wrenches"] and time.monotonic() < end:
            self.whisk.publish(first)
            self.spin_until(lambda: bool(self.got["wrenches"]), 0.2)
        assert self.got["wrenches"], "array_node never answered"

    def call_reset(self, timeout=20.0):
        """Call ``~/reset`` and return its response."""
        assert self.reset.wait_for_service(timeout_sec=timeout), "no ~/reset service"
        future = self.reset.call_async(Trigger.Request())
        assert self.spin_until(future.done, timeout), "~/reset did not answer"
        return future.result()

    def _keep(self, key):
        return lambda msg: self.got[key].append(msg)

    def spin_until(self, condition, timeout=20.0):
        end = time.monotonic() + timeout
        while time.monotonic() < end and not condition():
            self.executor.spin_once(timeout_sec=0.01)
        return condition()

    def send(self, msg, timeout=30.0):
        """Publish one input and wait for its tick's answer (matched by stamp)."""
        stamp = header_ns(msg)
        (self.head if isinstance(msg, PoseStamped) else self.whisk).publish(msg)
        if not self.spin_until(lambda: any(header_ns(w) == stamp
                                           for w in self.got["wrenches"][-3:]), timeout):
            raise TimeoutError(f"no answer to the input stamped {stamp}")

    def expect_no_answer(self, msg, wait=0.5):
        stamp = header_ns(msg)
        (self.head if isinstance(msg, PoseStamped) else self.whisk).publish(msg)
        end = time.monotonic() + wait
        while time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.01)
        assert not any(header_ns(w) == stamp for w in self.got["wrenches"])

    def status(self, after=0):
        """Return the node's own status of a /diagnostics array received after ``after``."""
        self.spin_until(lambda: len(self.got["diagnostics"]) > after, 10.0)
        for array in reversed(self.got["diagnostics"][after:]):
            for s in array.status:
                if s.hardware_id == self.prefix:
                    return {kv.key: kv.value for kv in s.values}
        raise KeyError(self.prefix)

    def destroy(self):
        self.executor.remove_node(self.node)
        self.node.destroy_node()


def _joints(names, positions, stamp_ns):
    msg = JointState()
    set_stamp(msg.header.stamp, stamp_ns)
    msg.name = list(names)
    msg.position = [float(v) for v in positions]
    return msg


def _head(position, quaternion, stamp_ns, frame="world"):
    msg = PoseStamped()
    msg.header.frame_id = frame
    set_stamp(msg.header.stamp, stamp_ns)
    p, o = msg.pose.position, msg.pose.orientation
    p.x, p.y, p.z = (float(v) for v in position)
    o.x, o.y, o.z, o.w = (float(v) for v in quaternion)
    return msg


@pytest.fixture(scope="module")
def external(installed, ros_env, rcl_context, tmp_path_factory):
    """Run the shipped configuration with whisking from outside: a protraction sweep, bad input."""
    tmp = tmp_path_factory.mktemp("array_ext")
    log = tmp / "external.mcap"
    # solver.workers: every whisker's results equal one process's to the last bit, so this run,
    # its reset, display and recording go through two processes (and resim runs in one)
    values = dict(_shipped(), **{"whisk.source": "external", "record.path": str(log),
                                 "diagnostics.period": 0.3, "wrench.rate": 500.0,
                                 "solver.workers": 2})
    proc = start_installed_node(installed, write_params(tmp / "p.yaml", values), ros_env,
                                namespace="/ext", executable="array_node")
    probe = ArrayProbe(rcl_context, "/ext/array_node")
    t = 1_000_000_000
    inputs, bad = [], {}
    try:
        probe.handshake(_joints(["whisk"], [math.radians(-20.0)], t))
        probe.spin_until(lambda: False, 0.3)
        for k, theta in enumerate(np.linspace(-20.0, 20.0, 60)[1:], start=1):
            t += 1_000_000
            if k == 20:  # a head pose ticks too (external mode): the head moves 0.5 mm
                msg = _head((0.0, 0.0005, 0.0), (0, 0, 0, 1), t)
            elif k == 40:  # one row's joint: row C only moves
                msg = _joints(["row_C"], [math.radians(theta)], t)
            else:
                msg = _joints(["whisk"], [math.radians(theta)], t)
            probe.send(msg)
            inputs.append(msg)
            if k == 45:  # every whisker re-placed before the next tick
                reset = probe.call_reset()
                reset_stamp = t + 1_000_000
            if k == 30:  # bad input in contact: each dropped, the state kept
                before = len(probe.got["diagnostics"])
                for key, wrong in (
                        ("joint_names", _joints(["RZ9"], [0.0], t + 1)),
                        ("joint_lengths", _joints(["whisk", "row_A"], [0.0], t + 2)),
                        ("not_finite", _joints(["whisk"], [math.nan], t + 3)),
                        ("quaternion_not_unit", _head((0, 0, 0), (0, 0, 0, 1.01), t + 4)),
                        ("wrong_frame_id", _head((0, 0, 0), (0, 0, 0, 1), t + 5, "map"))):
                    probe.expect_no_answer(wrong, 0.3)
                    bad[key] = wrong
                probe.spin_until(lambda: len(probe.got["diagnostics"]) > before + 1, 5.0)
                status = probe.status(before + 1)
        probe.spin_until(lambda: probe.got["whiskers"] and probe.got["obstacles"], 10.0)
        got = {k: list(v) for k, v in probe.got.items()}
        alive = proc.poll() is None
        workers = _children(proc.pid)
    finally:
        probe.destroy()
        code = stop(proc)
    return dict(values=values, got=got, inputs=inputs, bad=bad, status=status, alive=alive,
                code=code, log=log, reset=reset, reset_stamp=reset_stamp, workers=workers)


def _children(pid):
    """Return (pid, command line) of a process's children (Linux's /proc)."""
    out = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
                if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                    cmdline = (entry / "cmdline").read_bytes().decode(errors="replace")
                    out.append((int(entry.name), cmdline))
            except OSError:  # (gone meanwhile)
                continue
    return out


def test_the_node_deals_the_whiskers_to_worker_processes_that_end_with_it(external):
    assert external["values"]["solver.workers"] == 2 and external["code"] == 0
    workers = [pid for pid, cmdline in external["workers"]
               if "vibrissa_ros.core.arrays.partition" in cmdline]
    assert len(workers) == 1
    assert not Path(f"/proc/{workers[0]}").exists()


def _reference(values):
    """Return the configuration and a fresh ArrayTracker, the node's at start-up."""
    cfg = build_array_config(dict(values, **{
        "scene.file": str(ROOT / "config" / "scene_peg_array_m.yaml"),
        "array.file": str(ROOT / "config" / "rat_array.yaml"), "record.path": ""}))
    tracker = ArrayTracker(cfg.array, cfg.scene, BasePose((0.0, 0.0, 0.0)),
                           math.radians(-20.0))
    return cfg, tracker


def test_every_whisker_is_published_and_equals_the_array_tracker(external):
    assert external["alive"] and external["code"] == 0
    got = external["got"]
    clouds = [decode_cloud(c) for c in got["wrenches"]]
    names = json.loads(got["whiskers"][-1].data)
    assert len(names["names"]) == 30 and names["names"][0] == "RA0"
    assert names["frames"][0] == "head/RA0" and names["fields"][:3] == ["x", "y", "z"]
    assert all(len(c) == 30 and list(c["index"]) == list(range(30)) for c in clouds)
    assert all(w.header.frame_id == "world" for w in got["wrenches"])
    # every tick's values equal ArrayTracker's on the same inputs (head pose and protraction)
    cfg, tracker = _reference(external["values"])
    head = BasePose((0.0, 0.0, 0.0))
    in_contact = 0
    for i, cloud in enumerate(clouds):
        if i > 0 and cloud["y"][0] != clouds[i - 1]["y"][0]:
            head = BasePose((0.0, 0.0005, 0.0))
        if header_ns(got["wrenches"][i]) == external["reset_stamp"]:
            tracker.reset()
        step = tracker.step(head, np.array(cloud["theta"]))
        want = output_rows(step, cfg.scene)
        for name in WRENCH + ("s", "f", "cx", "cy", "cz", "x", "y", "z", "theta"):
            a, b = np.asarray(cloud[name]), np.asarray(want[name])
            assert np.all(np.abs(a - b) <= 1e-12 * np.maximum(np.abs(b), 1e-30)), name
        assert list(cloud["contacts"]) == list(want["contacts"])
        assert np.isfinite(np.array([cloud[n] for n in WRENCH])).all()
        in_contact = max(in_contact, int((cloud["contacts"] > 0).sum()))
    # whisking against the peg: columns 0-2 touch it
    assert in_contact >= 3
    touched = {json.loads(e.data)["whisker"] for e in got["events"]
               if json.loads(e.data)["kind"] == "touch"}
    assert touched and all(int(name[2]) <= 2 for name in touched)
    # the row joint moved row C only
    row_msg = external["inputs"][39]
    assert list(row_msg.name) == ["row_C"]
    stamps = [header_ns(w) for w in got["wrenches"]]
    j = stamps.index(header_ns(row_msg))
    row_c = np.array([n[1] == "C" for n in names["names"]])
    theta, before = clouds[j]["theta"], clouds[j - 1]["theta"]
    assert np.all(theta[row_c] == row_msg.position[0])
    assert np.all(theta[~row_c] == before[~row_c]) and np.all(theta[row_c] != before[row_c])


def test_bad_input_is_dropped_reported_and_the_state_kept(external):
    status = external["status"]
    for key in ("joint_names", "joint_lengths", "not_finite", "quaternion_not_unit",
                "wrong_frame_id"):
        assert status[f"dropped_{key}"] == "1", key
    assert int(status["whiskers_in_contact"]) >= 1
    statuses = [s for a in external["got"]["diagnostics"] for s in a.status]
    per_whisker = {s.hardware_id for s in statuses if s.hardware_id.startswith(
        "/ext/array_node/")}
    assert len(per_whisker) == 30
    assert any("dropped" in s.message for s in statuses if s.hardware_id == "/ext/array_node")


def test_reset_re_places_every_whisker_before_the_next_tick(external):
    reset = external["reset"]
    assert reset.success and "re-placed unloaded" in reset.message
    got = external["got"]
    stamps = [header_ns(w) for w in got["wrenches"]]
    j = stamps.index(external["reset_stamp"])
    names = json.loads(got["whiskers"][-1].data)["names"]
    # the events of that tick: a reset for every whisker re-placed; one pressed on the peg at the
    # last tick cannot be (it keeps its state and reports it in its row's error column)
    events = [json.loads(e.data) for e in got["events"]]
    resets = [e["whisker"] for e in events if e["kind"] == "reset"]
    assert len(set(resets)) >= 20
    cloud, before = decode_cloud(got["wrenches"][j]), decode_cloud(got["wrenches"][j - 1])
    pressed = {names[i] for i in np.flatnonzero(before["contacts"] > 0)}
    assert set(names) - set(resets) <= pressed
    assert all(cloud["error"][names.index(n)] for n in set(names) - set(resets))


def test_obstacles_and_display_outputs(external):
    array = external["got"]["obstacles"][-1]
    peg = array.markers[1]
    assert (peg.type, peg.text) == (Marker.CYLINDER, "peg")
    assert (peg.pose.position.x, peg.pose.position.y) == pytest.approx((0.03, -0.016))
    assert peg.scale.x == pytest.approx(0.003)
    shapes = external["got"]["shapes"]
    assert shapes and len(shapes[-1].markers) == 30
    assert all(mk.type == Marker.LINE_STRIP and len(mk.points) == 21
               for mk in shapes[-1].markers)


def test_the_external_run_is_reproduced_by_resim(external):
    sim = resimulate(str(external["log"]))
    assert not sim.mismatches and sim.worst() <= 1e-12
    assert sim.dropped == {"joint_names": 1, "joint_lengths": 1, "not_finite": 1,
                           "quaternion_not_unit": 1, "wrong_frame_id": 1}
    assert sim.compared["wrenches.fx"] >= 30 * len(external["inputs"])


#: tf2_msgs/msg/TFMessage's RIHS01 hash as ROS 2 Jazzy publishes it (ros2 topic info -v /tf)
TF_HASH = "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087"


def test_the_recording_places_the_frames_and_keeps_every_whiskers_wrench(external):
    # /tf (recorded only: no tf2_msgs wheel) carries the head's and each whisker's base frame
    # at the display rate, decoded from the log's own schema by two independent readers; each
    # ~/<name>/wrench published is recorded too, in its base frame
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    from rosbags.rosbag2 import Reader as RosbagsReader
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    from vibrissa_ros.logs.mcap_log import read_log

    whiskers = json.loads(external["got"]["whiskers"][-1].data)
    _, channels, _, messages = read_log(str(external["log"]))
    tf = [c for c in channels.values() if c.topic == "/tf"]
    assert len(tf) == 1 and tf[0].metadata["topic_type_hash"] == TF_HASH
    clouds = {header_ns(msg): decode_cloud(msg) for msg in
              (decode(m) for m in messages if m.topic == "/ext/array_node/wrenches")}
    with open(external["log"], "rb") as stream:
        frames = [m for _, c, _, m in make_reader(stream, decoder_factories=[DecoderFactory()])
                  .iter_decoded_messages(topics=["/tf"], log_time_order=True)]
    store = get_typestore(Stores.EMPTY)
    with RosbagsReader(Path(external["log"])) as reader:
        conn = [c for c in reader.connections if c.topic == "/tf"]
        store.register(get_types_from_msg(conn[0].msgdef.data, conn[0].msgtype))
        again = [store.deserialize_cdr(raw, c.msgtype) for c, _, raw in reader.messages(conn)]
    assert len(frames) == len(again) >= 5
    for msg, other in zip(frames, again):
        stamps = {t.header.stamp.sec * 10**9 + t.header.stamp.nanosec for t in msg.transforms}
        assert len(stamps) == 1
        rows = clouds[stamps.pop()]
        assert [t.child_frame_id for t in msg.transforms] == ["head"] + whiskers["frames"]
        assert {t.header.frame_id for t in msg.transforms} == {"world"}
        for t, row in zip(msg.transforms[1:], rows):
            p, q = t.transform.translation, t.transform.rotation
            assert (p.x, p.y, p.z) == (row["x"], row["y"], row["z"])
            assert max(abs(q.x - row["qx"]), abs(q.y - row["qy"]), abs(q.z - row["qz"]),
                       abs(q.w - row["qw"])) <= 1e-15
        for t, u in zip(msg.transforms, other.transforms):
            assert (t.child_frame_id, t.transform.translation.x, t.transform.rotation.w) == (
                u.child_frame_id, u.transform.translation.x, u.transform.rotation.w)
    for i, name in enumerate(whiskers["names"]):
        recorded = [decode(m) for m in messages if m.topic == f"/ext/array_node/{name}/wrench"]
        assert len(recorded) >= 10
        for w in recorded:
            row = clouds[header_ns(w)][i]
            assert w.header.frame_id == whiskers["frames"][i]
            assert (w.wrench.force.x, w.wrench.force.y, w.wrench.torque.z) == (
                row["fx"], row["fy"], row["mz"])


def _listwise_resim(configs, messages, resets=()):
    """Re-simulate an array log as resim did before streaming: all ticks kept, zipped at last."""
    from vibrissa_ros.logs.array_resim import COMPARED, _relative
    from vibrissa_ros.logs.tools import Resimulation
    from vibrissa_ros.node.array import ARRAY_TEXT, SCENE_TEXT, ArrayPipeline
    from vibrissa_ros.node.edge import BadInput

    result = Resimulation()
    values = dict(configs[0][1])
    node = values.pop("node", "/array_node")
    recorded = {ARRAY_TEXT: values.pop(ARRAY_TEXT), SCENE_TEXT: values.pop(SCENE_TEXT, "")}
    values = {k: v for k, v in values.items() if k not in ("vibrissa_ros_version", "resets")}
    config = build_array_config(values, recorded)
    pipeline = ArrayPipeline(config)
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
        if any(before == len(result.states) for before, _ in resets):
            pipeline.request_reset()
        step = pipeline.tick()
        stamp = header_ns(msg)
        result.states.append((stamp, step))
        expected.append((stamp, output_rows(step, config.scene)))
    if len(expected) == len(got) + 1:
        expected.pop()
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


def _streamed_resim(configs, messages, **options):
    """Re-simulate with resim's streaming comparison, the messages given one at a time."""
    from vibrissa_ros.logs.array_resim import resimulate_array
    from vibrissa_ros.logs.tools import Resimulation

    sim = resimulate_array(configs, iter(messages), Resimulation(), **options)
    assert sim.states == []  # no tick kept
    return sim


def _assert_same(streamed, listwise):
    assert streamed.mismatches == listwise.mismatches
    assert streamed.deviations == listwise.deviations
    assert streamed.compared == listwise.compared
    assert streamed.dropped == listwise.dropped
    assert streamed.ticks == len(listwise.states)


def _recorded(external):
    from vibrissa_ros.logs.mcap_log import read_log
    from vibrissa_ros.logs.tools import configurations, reset_requests

    _, _, metadata, messages = read_log(str(external["log"]))
    return configurations(metadata), messages, reset_requests(metadata)


def _is_wrenches(m):
    return m.topic == "/ext/array_node/wrenches"


def _is_input(m):
    return m.topic in ("/ext/array_node/whisk", "/ext/array_node/head_pose")


def _changed_cloud(m, change):
    """Return a recorded ``~/wrenches`` message with its rows changed by ``change(rows)``."""
    from rclpy.serialization import serialize_message

    from vibrissa_ros.logs.mcap_log import LogMessage

    cloud = decode(m)
    rows = decode_cloud(cloud).copy()
    change(rows)
    cloud.data = rows.tobytes()
    return LogMessage(m.topic, m.type_name, m.log_time, m.publish_time, serialize_message(cloud))


def _lagging(messages, lag):
    """Return the messages with every ``~/wrenches`` moved after the next ``lag`` inputs."""
    out, late = [], []  # late: [inputs still to pass, message]
    for m in messages:
        if _is_wrenches(m):
            late.append([lag, m])
            continue
        out.append(m)
        if _is_input(m):
            for item in late:
                item[0] -= 1
            out += [item[1] for item in late if item[0] == 0]
            late = [item for item in late if item[0] > 0]
    return out + [item[1] for item in late]


def test_the_streaming_resim_equals_the_listwise_comparison(external):
    configs, messages, resets = _recorded(external)
    assert len(resets) == 1
    listwise = _listwise_resim(configs, messages, resets)
    streamed = _streamed_resim(configs, messages, resets=resets)
    _assert_same(streamed, listwise)
    assert not streamed.mismatches and streamed.worst() <= 1e-12
    # every input ticked but the five bad ones, the last one with its recorded output
    inputs = [m for m in messages if _is_input(m)]
    assert streamed.ticks == len(inputs) - 5 == sum(map(_is_wrenches, messages))
    assert streamed.compared["wrenches.fx"] == 30 * streamed.ticks
    # the command line says how many ticks, from the log streamed
    proc = subprocess.run([VIBRISSA, "resim", str(external["log"])], capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert proc.stdout.startswith(f"{streamed.ticks} ticks re-simulated, 5 dropped as recorded")


def test_wrenches_recorded_out_of_step_are_reported_as_before(external):
    configs, messages, resets = _recorded(external)
    clouds = [i for i, m in enumerate(messages) if _is_wrenches(m)]
    stamps = [header_ns(decode(messages[i])) for i in clouds]
    k = len(clouds) // 2

    def check(changed, mismatches, **options):
        streamed = _streamed_resim(configs, changed, resets=resets, **options)
        if not options:
            _assert_same(streamed, _listwise_resim(configs, changed, resets))
        assert streamed.mismatches == mismatches
        return streamed

    # outputs recorded after the next input, or three inputs late: compared all the same
    for lag in (1, 3):
        late = _lagging(messages, lag)
        assert late != messages and sorted(late, key=id) == sorted(messages, key=id)
        sim = check(late, [])
        assert sim.worst() == 0.0 and sim.compared["wrenches.fx"] == 30 * len(clouds)
    # a tick's output missing in the middle: its successor's stamp where its own was expected
    check(messages[:clouds[k]] + messages[clouds[k] + 1:],
          [f"wrenches: stamp {stamps[k + 1]} recorded where {stamps[k]} was expected"])
    # the last output missing (the run stopped during its last tick): no mismatch; two: one
    check(messages[:clouds[-1]] + messages[clouds[-1] + 1:], [])
    check([m for i, m in enumerate(messages) if i not in clouds[-2:]],
          [f"wrenches: {len(clouds) - 2} recorded, {len(clouds)} re-simulated"])
    # an output recorded twice: the counts (first), then the stamps differ
    check(messages[:clouds[k]] + [messages[clouds[k]]] + messages[clouds[k]:],
          [f"wrenches: {len(clouds) + 1} recorded, {len(clouds)} re-simulated",
           f"wrenches: stamp {stamps[k]} recorded where {stamps[k + 1]} was expected"])

    # a deviation injected into one whisker's force in contact
    def push(rows):
        i = int(np.flatnonzero(rows["fx"])[0])
        rows["fx"][i] *= 1.0 + 1e-9

    touching = next(i for i in clouds if np.any(decode_cloud(decode(messages[i]))["fx"]))
    changed = list(messages)
    changed[touching] = _changed_cloud(messages[touching], push)
    sim = check(changed, [])
    assert sim.deviations["wrenches.fx"] == pytest.approx(1e-9, rel=1e-3)
    assert max(v for key, v in sim.deviations.items() if key != "wrenches.fx") == 0.0
    # outputs further from their inputs than the window: reported, not compared (three inputs
    # late: four ticks wait for their outputs)
    late = _lagging(messages, 3)
    assert check(late, [], window=4).compared["wrenches.fx"] == 30 * len(clouds)
    sim = check(late, [f"wrenches: the recorded tick stamped {stamps[0]} comes more than 3 "
                       "ticks after its input in the log: not compared"], window=3)
    assert sim.ticks == len(clouds) and sim.compared["wrenches.fx"] == 0


def test_export_refuses_an_array_log(external, tmp_path):
    proc = subprocess.run([VIBRISSA, "export", str(external["log"]), "--csv",
                           str(tmp_path / "x.csv")], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 1 and "a run of array_node" in proc.stderr, proc.stderr


def test_vibrissa_info_summarizes_an_array_log(external):
    info = log_info(str(external["log"]))
    kinds = Counter(e["kind"] for e in info.events)
    assert kinds["touch"] >= 3 and all(set(e) == {"whisker", "kind", "obstacle", "s",
                                                  "contacts_before", "contacts_after", "reason"}
                                       for e in info.events)
    proc = subprocess.run([VIBRISSA, "info", str(external["log"])], capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    out = proc.stdout
    assert "/ext/array_node/wrenches" in out and f"events:    {len(info.events)}" in out
    assert f"touch {kinds['touch']}" in out.splitlines()[out.splitlines().index(
        f"events:    {len(info.events)}") + 1]
    for name in {e["whisker"] for e in info.events}:
        assert any(line.split()[:1] == [name] for line in out.splitlines())


def test_builtin_whisk_skips_ticks_in_real_time_and_resim_reproduces_it(
        installed, ros_env, rcl_context, tmp_path):
    log = tmp_path / "builtin.mcap"
    # no obstacle (whisking in the air), so that a tick is cheap, and a timer faster than any
    # tick: ticks are skipped
    values = dict(_shipped(), **{"whisk.realtime": True, "record.path": str(log),
                                 "diagnostics.period": 0.5, "scene.file": "", "rate": 5000.0})
    proc = start_installed_node(installed, write_params(tmp_path / "p.yaml", values), ros_env,
                                namespace="/builtin", executable="array_node")
    probe = ArrayProbe(rcl_context, "/builtin/array_node")
    try:
        assert probe.spin_until(lambda: len(probe.got["wrenches"]) >= 100, 20.0)
        before = len(probe.got["diagnostics"])
        status = probe.status(before)
        alive = proc.poll() is None
    finally:
        probe.destroy()
        code = stop(proc)
    assert alive and code == 0
    assert int(status["ticks"]) >= 1 and int(status["ticks_skipped"]) > 0
    sim = resimulate(str(log))
    assert not sim.mismatches and sim.worst() <= 1e-12
    assert sim.compared["wrenches.mz"] >= 30 * 100
    proc = subprocess.run([VIBRISSA, "resim", str(log)], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "wrenches.fx" in proc.stdout and "OK" in proc.stdout


# -- without DDS: the configuration, the joint names, the layout ---------------------------------
def test_joint_names_rows_and_whisk_map_to_whiskers():
    from vibrissa_ros.node.array import JointMap
    from vibrissa_ros.node.edge import BadInput

    cfg, _ = _reference(_shipped())
    joints = JointMap(cfg.array)
    theta = np.zeros(30)
    out = joints.angles(["whisk", "row_B", "RB2"], [0.1, 0.2, 0.3], theta)
    rows = np.array([n[1] for n in cfg.array.names])
    assert np.all(out[rows == "A"] == 0.1) and out[cfg.array.names.index("RB2")] == 0.3
    assert np.all(out[(rows == "B") & (np.array(cfg.array.names) != "RB2")] == 0.2)
    for names, positions, reason in ((["RZ9"], [0.0], "joint_names"),
                                     (["whisk", "whisk"], [0.0, 0.0], "joint_names"),
                                     (["whisk"], [], "joint_lengths"),
                                     ([], [], "joint_lengths"),
                                     (["whisk"], [math.inf], "not_finite"),
                                     (["whisk"], [2.0], "out_of_range")):
        with pytest.raises(BadInput) as err:
            joints.angles(names, positions, theta)
        assert err.value.reason == reason and "\n" not in str(err.value)


@pytest.mark.parametrize("change, words", [
    ({"scene.file": "/nonexistent/scene.yaml"}, "scene.file = '/nonexistent"),
    ({"array.side": "top"}, "array.side = 'top'"),
    ({"array.file": "/nonexistent/array.yaml"}, "cannot read"),
    ({"head.qw": 2.0}, "quaternion"),
    ({"whisk.protraction": -0.5}, "protraction"),
    ({"rate": 0.0}, "rate = 0.0"),
    ({"solver.adapt_points": "yes"}, "solver.adapt_points"),
    ({"solver.points_tolerance": 1e-3}, "solver.points_tolerance"),
    ({"solver.points_tolerance": 0.0}, "solver.points_tolerance"),
    ({"solver.workers": 0}, "solver.workers"),
    ({"solver.workers": 61}, "solver.workers = 61 is not allowed; the array has"),
    ({"solver.workers": 1.5}, "solver.workers"),
])
def test_a_bad_configuration_is_one_line_naming_the_parameter(change, words):
    from vibrissa_ros.core.errors import ParameterError

    values = dict(_shipped(), **{"scene.file": str(ROOT / "config" / "scene_peg_array_m.yaml")})
    with pytest.raises(ParameterError) as err:
        build_array_config(dict(values, **change))
    assert words in str(err.value) and "\n" not in str(err.value)


def test_solver_adapt_points_reaches_every_whiskers_tracker():
    from vibrissa_ros.node.array import ArrayPipeline

    values = dict(_shipped(), **{"scene.file": str(ROOT / "config" / "scene_peg_array_m.yaml"),
                                 "array.side": "right"})
    assert build_array_config(values).values["solver.adapt_points"] is True
    for flag in (True, False):
        tracker = ArrayPipeline(build_array_config(
            dict(values, **{"solver.adapt_points": flag}))).tracker
        assert {tracker.tracker(name).adapt_points for name in tracker.names} == {flag}


def test_solver_points_tolerance_reaches_every_whiskers_solver():
    from vibrissa_ros.node.array import ArrayPipeline

    values = dict(_shipped(), **{"scene.file": str(ROOT / "config" / "scene_peg_array_m.yaml"),
                                 "array.side": "right"})
    assert build_array_config(values).values["solver.points_tolerance"] == 1e-11
    tracker = ArrayPipeline(build_array_config(
        dict(values, **{"solver.points_tolerance": 1e-8}))).tracker
    assert {tracker.tracker(name).solver.points_tolerance for name in tracker.names} == {1e-8}


def test_the_cloud_layout_round_trips_by_field_name():
    from vibrissa_ros.node.array import ARRAY_DTYPE
    from vibrissa_ros.ros.array_messages import wrenches_cloud

    rows = np.zeros(3, dtype=ARRAY_DTYPE)
    rows["fx"], rows["index"], rows["kind"] = (1.5, -2.0, 3e-9), (0, 1, 2), (0, 1, 2)
    cloud = wrenches_cloud(PointCloud2(), PoseStamped().header.stamp, "world", rows)
    back = decode_cloud(cloud)
    assert cloud.point_step == ARRAY_DTYPE.itemsize and cloud.width == 3
    assert [f.name for f in cloud.fields] == list(ARRAY_DTYPE.names)
    for name in ARRAY_DTYPE.names:
        assert np.array_equal(back[name], rows[name]), name


def test_finite_checks_every_float_field_of_every_row_and_no_other():
    from vibrissa_ros.node.array import ARRAY_DTYPE, ARRAY_FIELDS, finite

    rows = np.zeros(30, dtype=ARRAY_DTYPE)
    rows["index"], rows["kind"], rows["contacts"] = 2**32 - 1, 255, 7  # no float: ignored
    assert finite(rows) and finite(rows[:0]) and finite(rows[::3])
    floats = [name for name, kind, _, _ in ARRAY_FIELDS if kind == "<f8"]
    assert len(floats) == 19
    for name in floats:
        for bad in (math.nan, math.inf, -math.inf):
            for i in (0, 13, 29):
                broken = rows.copy()
                broken[name][i] = bad
                assert not finite(broken), (name, bad, i)
                # as a received cloud's rows are: read-only, from the message's bytes
                assert not finite(np.frombuffer(broken.tobytes(), dtype=ARRAY_DTYPE))
                assert not finite(broken[i:i + 1]) and finite(np.delete(broken, i))


def test_reset_starts_the_array_again_after_a_worker_process_ended(monkeypatch):
    import os
    import signal

    from vibrissa_ros.core.errors import ConvergenceError, InvalidPoseError
    from vibrissa_ros.node.array import ArrayPipeline

    values = dict(_shipped(), **{"scene.file": str(ROOT / "config" / "scene_peg_array_m.yaml"),
                                 "array.side": "right", "solver.workers": 2})
    config = build_array_config(values)
    pipeline = ArrayPipeline(config)
    one = ArrayTracker(config.array, config.scene, config.head, pipeline.theta)
    try:
        whisk = config.whisk
        for k in range(1, 6):
            pipeline.theta = np.full(len(config.array), whisk.angle(k * 1e-3))
            pipeline.tick()
        os.kill(pipeline.tracker._procs[0].pid, signal.SIGKILL)
        pipeline.tracker._procs[0].wait()
        for k in (6, 7):  # every tick fails, saying what to do
            pipeline.theta = np.full(len(config.array), whisk.angle(k * 1e-3))
            with pytest.raises(ConvergenceError, match="whiskers RA1, .*~/reset starts it again"):
                pipeline.tick()
        # a restart that fails (a whisker on an obstacle) is said, and the request is done
        real = pipeline.tracker.restart

        def cut(*args, **kwargs):
            raise InvalidPoseError("whisker RB1: cuts the peg")

        monkeypatch.setattr(pipeline.tracker, "restart", cut)
        pipeline.request_reset()
        with pytest.raises(InvalidPoseError, match="RB1"):
            pipeline.tick()
        with pytest.raises(ConvergenceError, match="~/reset starts it again"):
            pipeline.tick()
        monkeypatch.setattr(pipeline.tracker, "restart", real)
        pipeline.request_reset()
        placed = pipeline.tick()  # every whisker unloaded at this tick's pose
        # a reset requested before any tick saw the worker end: the same tick starts it again
        os.kill(pipeline.tracker._procs[0].pid, signal.SIGKILL)
        pipeline.tracker._procs[0].wait()
        assert pipeline.tracker.failed is None
        pipeline.request_reset()
        placed = pipeline.tick()
        assert pipeline.tracker.failed is None
        assert {e.kind for e in placed.events} == {"reset"} and len(placed.events) == 30
        assert "the array started again (the array's worker process 1" in placed.events[0].reason
        one.reset()
        want = one.step(config.head, pipeline.theta)
        assert np.array_equal(want.force, placed.force) and not placed.in_contact
        for k in range(8, 60):  # and on as one process goes
            pipeline.theta = np.full(len(config.array), whisk.angle(k * 1e-3))
            got, want = pipeline.tick(), one.step(config.head, pipeline.theta)
            assert np.array_equal(got.force, want.force)
            assert np.array_equal(got.moment, want.moment)
    finally:
        pipeline.close()


def test_a_worker_process_that_ends_is_reported_and_reset_starts_the_array_again(
        installed, ros_env, rcl_context, tmp_path):
    import os
    import signal

    values = dict(_shipped(), **{"whisk.source": "external", "diagnostics.period": 0.3,
                                 "solver.workers": 2})
    proc = start_installed_node(installed, write_params(tmp_path / "p.yaml", values), ros_env,
                                namespace="/dead", executable="array_node")
    probe = ArrayProbe(rcl_context, "/dead/array_node")
    t = 1_000_000_000
    try:
        probe.handshake(_joints(["whisk"], [math.radians(-20.0)], t))
        for k in range(1, 4):
            t += 1_000_000
            probe.send(_joints(["whisk"], [math.radians(-20.0 + k)], t))
        (worker, _), = [c for c in _children(proc.pid) if "partition" in c[1]]
        os.kill(worker, signal.SIGKILL)
        before = len(probe.got["diagnostics"])
        for k in range(4, 6):  # every tick dropped, saying what to do; the node goes on
            t += 1_000_000
            probe.expect_no_answer(_joints(["whisk"], [math.radians(-20.0 + k)], t), 0.3)
        status = probe.status(before + 1)
        assert int(status["dropped_not_converged"]) >= 2
        assert "whiskers RA1, " in status["last_drop"]
        assert "~/reset starts it again" in status["last_drop"]
        reset = probe.call_reset()
        assert reset.success and "worker processes start again" in reset.message
        # at -14 degrees RB2 would cut the peg unloaded: that tick is dropped saying so, and
        # the request is done
        before = len(probe.got["diagnostics"])
        t += 1_000_000
        probe.expect_no_answer(_joints(["whisk"], [math.radians(-14.0)], t), 5.0)
        status = probe.status(before + 1)
        assert int(status["dropped_inside_obstacle"]) == 1
        assert status["last_drop"].startswith("tick dropped (inside_obstacle): whisker RB2:")
        t += 1_000_000
        probe.expect_no_answer(_joints(["whisk"], [math.radians(-19.0)], t), 0.3)
        probe.call_reset()
        t += 1_000_000
        probe.send(_joints(["whisk"], [math.radians(-19.0)], t), timeout=60.0)

        def restarted():
            events = [json.loads(m.data) for m in probe.got["events"]]
            return [e for e in events if e["kind"] == "reset"]

        probe.spin_until(lambda: len(restarted()) >= 30, 10.0)
        resets = restarted()
        assert len(resets) == 30
        assert "the array started again (the array's worker process 1" in resets[0]["reason"]
        for k in range(2, 5):  # and on
            t += 1_000_000
            probe.send(_joints(["whisk"], [math.radians(-20.0 + k)], t))
        new = [c for c in _children(proc.pid) if "partition" in c[1]]
        assert len(new) == 1 and new[0][0] != worker
    finally:
        probe.destroy()
        code = stop(proc)
    assert code == 0
    assert not Path(f"/proc/{new[0][0]}").exists()
