"""
``vibrissa replay --rate 0`` of a 60 s, 1 kHz log into a fresh whisker_node: time and loss.

Writes a log like whisker_node records it (the catenary of config/catenary.yaml, the foot sweeping
x = 0.15 -> -0.15 -> 0.15 m every 10 s at 1 kHz, with every output computed by the node's own
pipeline), starts a fresh whisker_node that records its own log, replays the log's foot poses into
it with ``vibrissa replay --rate 0``, waits until the node has handled every pose, and compares
the two logs' wrenches stamp by stamp. Prints the replay's time, the time until the node had
answered everything, the poses lost (must be 0) and the wrenches that differ (must be 0).

Run: python bench/bench_replay.py [--seconds 60] [--rate 1000] [--repeat 1]
"""

from __future__ import annotations

import argparse
import math
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
from domain_coordinator import domain_id
from rclpy.serialization import serialize_message

from vibrissa_ros.node.edge import event_record, header_ns
from vibrissa_ros.logs.tools import decode
from vibrissa_ros.logs.mcap_log import CONFIGURATION_METADATA, LogWriter, TopicSpec, read_log
from vibrissa_ros.node.config import build_config
from vibrissa_ros.node.pipeline import PosePipeline
from vibrissa_ros.ros import messages as m
from vibrissa_ros.ros.recorder import configuration_record

ROOT = Path(__file__).resolve().parents[1]
NODE = "/whisker_node"
VALUES = {"obstacle.type": "catenary", "obstacle.c": 0.06, "obstacle.apex_y": 0.05}
TOPICS = {
    "foot_pose": "geometry_msgs/msg/PoseStamped", "wrench": "geometry_msgs/msg/WrenchStamped",
    "phase": "std_msgs/msg/UInt8", "contact_force": "geometry_msgs/msg/Vector3Stamped",
    "contact_force_magnitude": "std_msgs/msg/Float64",
    "contact_point": "geometry_msgs/msg/PointStamped", "arc_length": "std_msgs/msg/Float64",
    "events": "std_msgs/msg/String",
}


def sweep_x(t: float, period: float = 10.0, amplitude: float = 0.15) -> float:
    phase = (t / period) % 1.0
    return amplitude * (1.0 - 4.0 * phase) if phase < 0.5 else amplitude * (4.0 * phase - 3.0)


def write_log(path: Path, seconds: float, rate: float) -> int:
    """Write a log as whisker_node records it; return the number of poses."""
    cfg = build_config(VALUES)
    pipeline = PosePipeline(cfg)
    log = LogWriter(str(path), chunk_size=1 << 20)
    ids = {k: log.channel(TopicSpec(f"{NODE}/{k}", t)) for k, t in TOPICS.items()}
    log.metadata(CONFIGURATION_METADATA, configuration_record(cfg.values, NODE, 0, True))
    n = int(round(seconds * rate))
    t0 = 1_000_000_000
    for i in range(n):
        stamp = t0 + int(round(i * 1e9 / rate))
        pose = m.pose_stamped(sweep_x(i / rate), 0.0, math.pi / 2, stamp)
        state, events = pipeline.handle("world", stamp, (sweep_x(i / rate), 0.0, 0.0),
                                        (0.0, 0.0, pose.pose.orientation.z,
                                         pose.pose.orientation.w))
        reading, sensed = pipeline.reading(state)
        out = [("foot_pose", pose),
               ("wrench", m.fill_wrench(WrenchStamped(), pose.header.stamp, cfg.base_frame,
                                        sensed[:2], sensed[2])),
               ("phase", m.phase_msg(reading.phase)),
               ("contact_force",
                m.vector_stamped(pose.header.stamp, "world", reading.force_world)),
               ("contact_force_magnitude", m.float_msg(reading.force_magnitude))]
        if reading.contact_world is not None:
            out += [("contact_point", m.point_stamped(pose.header.stamp, "world",
                                                      reading.contact_world)),
                    ("arc_length", m.float_msg(reading.s1))]
        out += [("events", m.event_msg(event_record(e, cfg.units))) for e in events]
        for key, msg in out:
            log.write(ids[key], serialize_message(msg), stamp)
    log.close()
    return n


def wrenches(path: Path):
    return {header_ns(w): (w.wrench.force.x, w.wrench.force.y, w.wrench.torque.z)
            for w in (decode(x) for x in read_log(str(path))[3] if x.topic == f"{NODE}/wrench")}


def handled(context, timeout: float, n: int) -> bool:
    """Wait until the node's /diagnostics says it has handled ``n`` poses."""
    node = rclpy.create_node("bench_replay_watch", context=context)
    seen = {"handled": 0}

    def on_diag(array):
        for status in array.status:
            if status.hardware_id == NODE:
                values = {kv.key: kv.value for kv in status.values}
                seen["handled"] = int(values["poses_processed"]) + int(values["poses_dropped"])

    node.create_subscription(DiagnosticArray, "/diagnostics", on_diag, 10)
    executor = rclpy.executors.SingleThreadedExecutor(context=context)
    executor.add_node(node)
    end = time.monotonic() + timeout
    while time.monotonic() < end and seen["handled"] < n:
        executor.spin_once(timeout_sec=0.05)
    executor.remove_node(node)
    node.destroy_node()
    return seen["handled"] >= n


def run_once(log: Path, n: int, tmp: Path, env, context):
    second = tmp / "second.mcap"
    second.unlink(missing_ok=True)
    exe = Path(sys.executable).with_name("whisker_node")
    args = [f"{k}:={v}" for k, v in VALUES.items()] + [f"record.path:={second}",
                                                       "diagnostics.period:=0.1"]
    cmd = [str(exe), "--ros-args", "--log-level", "warn"] + [a for p in args for a in ("-p", p)]
    node = subprocess.Popen(cmd, env=env, start_new_session=True)
    time.sleep(2.0)  # let it come up
    t0 = time.monotonic()
    replay = subprocess.run([str(Path(sys.executable).with_name("vibrissa")), "replay", str(log),
                             "--rate", "0", "--topics", f"{NODE}/foot_pose"], env=env,
                            capture_output=True, text=True, timeout=600)
    t_replay = time.monotonic() - t0
    ok = replay.returncode == 0 and handled(context, 300.0, n)
    t_done = time.monotonic() - t0
    node.send_signal(signal.SIGINT)
    node.wait(timeout=60)
    if replay.returncode != 0:
        raise RuntimeError(replay.stderr)
    first, again = wrenches(log), wrenches(second)
    lost = len(set(first) - set(again))
    differ = sum(1 for s in first if s in again and again[s] != first[s])
    return t_replay, t_done, ok, lost, differ


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--rate", type=float, default=1000.0)
    parser.add_argument("--repeat", type=int, default=1)
    args = parser.parse_args(argv)
    with domain_id() as domain, tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        env = dict(os.environ, ROS_DOMAIN_ID=str(domain),
                   ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", ROS_LOG_DIR=str(tmp / "roslog"))
        os.environ.update(env)
        log = tmp / "run.mcap"
        t = time.monotonic()
        n = write_log(log, args.seconds, args.rate)
        messages = len(read_log(str(log))[3])
        print(f"log: {args.seconds:.0f} s at {args.rate:.0f} Hz: {n} poses, {messages} messages, "
              f"{log.stat().st_size / 1e6:.1f} MB (written in {time.monotonic() - t:.1f} s)")
        context = rclpy.Context()
        rclpy.init(context=context)
        runs = []
        try:
            for _ in range(args.repeat):
                runs.append(run_once(log, n, tmp, env, context))
                t_replay, t_done, ok, lost, differ = runs[-1]
                print(f"replay --rate 0: published and acknowledged in {t_replay:.1f} s; node "
                      f"done after {t_done:.1f} s ({n / t_done:.0f} poses/s, "
                      f"{args.seconds / t_done:.1f}x real time); lost {lost}, differing wrenches "
                      f"{differ}{'' if ok else '  <- the node did not handle every pose'}")
        finally:
            rclpy.try_shutdown(context=context)
    print(f"median: replay {statistics.median(r[0] for r in runs):.1f} s, all answered "
          f"{statistics.median(r[1] for r in runs):.1f} s for {n} poses; lost "
          f"{max(r[3] for r in runs)}")


if __name__ == "__main__":
    main()
