"""
whisker_node's recovery over real DDS: ~/reset, the event reset, its count and its log.

A step the model cannot follow to a pose where the whisker is free re-places it there (event
reset from the core); ``~/reset`` (std_srvs/Trigger) makes the next accepted pose place it (event
reset from the phase it had); /diagnostics counts both; ``vibrissa resim`` of the recording
reproduces them, each before exactly the pose it preceded.
"""

import json
import math

from ros_harness import Probe, pose_msg, start_installed_node, stop, write_params
from std_srvs.srv import Trigger

from vibrissa_ros.node.edge import decode_event, header_ns
from vibrissa_ros.logs.tools import decode, reset_requests, resimulate
from vibrissa_ros.logs.mcap_log import read_log

HALF_PI = math.pi / 2
# the catenary (p0 0.5, c 0.6 in whisker lengths of 0.1 m)
PARAMS = {
    "obstacle.type": "catenary", "obstacle.c": 0.06, "obstacle.apex_y": 0.05,
    "diagnostics.period": 0.2, "centerline.max_rate": 0.0,
}


def _events(probe, n, timeout=10.0):
    probe.spin_until(lambda: len(probe.got["events"]) >= n, timeout)
    return [decode_event(m.data) for m in probe.got["events"]]


def _diagnostics(probe):
    start = len(probe.got["diagnostics"])
    probe.spin_until(lambda: len(probe.got["diagnostics"]) > start + 1, 10.0)
    for array in reversed(probe.got["diagnostics"]):
        for status in array.status:
            if status.hardware_id == probe.prefix:
                return {kv.key: kv.value for kv in status.values}
    raise KeyError("no status of the node")


def _call_reset(probe):
    client = probe.node.create_client(Trigger, "/whisker_node/reset")
    assert client.wait_for_service(timeout_sec=10.0)
    try:
        future = client.call_async(Trigger.Request())
        assert probe.spin_until(future.done, 10.0)
        return future.result()
    finally:
        probe.node.destroy_client(client)


def test_reset_service_and_recovery_are_published_counted_recorded(installed, ros_env,
                                                                   rcl_context, tmp_path):
    log = tmp_path / "reset.mcap"
    values = dict(PARAMS, **{"record.path": str(log)})
    proc = start_installed_node(installed, write_params(tmp_path / "reset.yaml", values), ros_env)
    probe = Probe(rcl_context, "/whisker_node", name="probe_reset")
    stamp = 1_000_000_000
    try:
        probe.handshake(pose_msg(0.014, 0.027, 0.86, stamp))
        # turning from here, the whisker's side would sweep into the catenary before its tip:
        # not modelled; the new pose is free, so the whisker is re-placed there
        w = probe.step(pose_msg(0.093, 0.005, -3.02, stamp + 1))
        assert (w.wrench.force.x, w.wrench.force.y, w.wrench.torque.z) == (0.0, 0.0, 0.0)
        (recovered,) = _events(probe, 1)
        assert (recovered.kind, recovered.from_phase, recovered.to_phase) == ("reset", 0, 0)
        assert (recovered.x, recovered.y, recovered.yaw) == (0.093, 0.005, -3.02)
        probe.step(pose_msg(0.2, 0.0, HALF_PI, stamp + 2))
        probe.step(pose_msg(0.03, 0.0, HALF_PI, stamp + 3))
        phase = probe.got["phase"][-1].data
        assert phase in (1, 2)
        probe.spin_for(0.5)  # the touch's events may follow the wrench
        n_events = len(probe.got["events"])
        kinds = [e.kind for e in _events(probe, n_events)]
        assert kinds[0] == "reset" and kinds[1] == "touch" and "reset" not in kinds[1:]

        response = _call_reset(probe)
        assert response.success and "next foot pose" in response.message
        # where the unloaded whisker would cut the catenary: dropped, the reset still pending
        probe.expect_no_answer(pose_msg(0.0, 0.0, HALF_PI, stamp + 4))
        w = probe.step(pose_msg(0.15, 0.0, HALF_PI, stamp + 5))
        assert (w.wrench.force.x, w.wrench.force.y, w.wrench.torque.z) == (0.0, 0.0, 0.0)
        requested = _events(probe, n_events + 1)[-1]
        assert (requested.kind, requested.from_phase, requested.to_phase) == ("reset", phase, 0)
        assert requested.x == 0.15
        status = _diagnostics(probe)
        assert int(status["resets"]) == 2 and int(status["dropped_inside_obstacle"]) == 1
        # the whisker goes on from the new placement as a new one would
        probe.step(pose_msg(0.03, 0.0, HALF_PI, stamp + 6))
        assert probe.got["phase"][-1].data == phase
    finally:
        probe.destroy()
        assert stop(proc) == 0

    _, _, metadata, messages = read_log(str(log))
    stamps = [header_ns(decode(m)) for m in messages if m.topic == "/whisker_node/foot_pose"]
    # the request holds before the first pose sent after it (the handshake may repeat its pose)
    assert [n for n, _ in reset_requests(metadata)] == [stamps.index(stamp + 4)]
    sim = resimulate(str(log))
    assert not sim.mismatches
    assert sim.worst() <= 1e-12
    kinds = [e.kind for e in sim.events]
    assert kinds.count("reset") == 2 and sim.dropped["inside_obstacle"] == 1
    assert json.loads(json.dumps(sim.compared))["events.kind"] == len(sim.events)
