"""Pose -> wrench latency and loss of whisker_node at a fixed rate, next to a trivial echo node.

For each node (whisker_node on config/catenary.yaml, then bench/echo_node.py): stream foot poses
for --seconds at --rate (the paper's catenary sweep, back and forth: x runs 0.15 -> -0.15 -> 0.15 m
every 10 s), each stamped with its send time; the answer's arrival time minus that stamp is the
latency. Then ramp the rate (--ramp) for --ramp-seconds each and report the highest rate that
loses nothing. Prints medians and ratios against the echo baseline measured in the same run.

A third run measures whisker_node recording to MCAP (record.path) at --rate, and the log's size.

Run: python bench/bench_node.py [--seconds 60] [--rate 1000] [--ramp 1000,2000,3000,4000]
"""

from __future__ import annotations

import argparse
import math
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import rclpy
from geometry_msgs.msg import PoseStamped, WrenchStamped
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

from vibrissa_ros.ros.sweep import stop_node, whisker_node_executable

ROOT = Path(__file__).resolve().parents[1]
QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.RELIABLE)


def sweep_x(t: float, period: float = 10.0, amplitude: float = 0.15) -> float:
    """Triangle wave: +amplitude -> -amplitude -> +amplitude every ``period`` seconds."""
    phase = (t / period) % 1.0
    return amplitude * (1.0 - 4.0 * phase) if phase < 0.5 else amplitude * (4.0 * phase - 3.0)


class Driver:
    def __init__(self, context):
        self.node = rclpy.create_node("bench_driver", context=context)
        self.pub = self.node.create_publisher(PoseStamped, "/whisker_node/foot_pose", QOS)
        self.received = {}
        self.node.create_subscription(WrenchStamped, "/whisker_node/wrench", self._on_wrench, QOS)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self._spinning = True
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _spin(self):
        while self._spinning:
            self.executor.spin_once(timeout_sec=0.01)

    def _on_wrench(self, msg):
        now = time.time_ns()
        self.received[msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec] = now

    def pose(self, x: float, stamp_ns: int) -> PoseStamped:
        msg = PoseStamped()
        msg.header.frame_id = "world"
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
        msg.pose.position.x = x
        msg.pose.orientation.z = math.sin(math.pi / 4)
        msg.pose.orientation.w = math.cos(math.pi / 4)
        return msg

    def handshake(self, timeout=30.0):
        end = time.monotonic() + timeout
        while not self.received and time.monotonic() < end:
            self.pub.publish(self.pose(0.2, time.time_ns()))
            time.sleep(0.1)
        if not self.received:
            raise TimeoutError("the node under test does not answer")
        time.sleep(0.5)
        self.received.clear()

    def stream(self, rate: float, seconds: float, t_offset: float = 0.0):
        """Publish at ``rate`` Hz for ``seconds``; return (sent stamps, latencies [us], lost)."""
        period = 1.0 / rate
        n = int(round(rate * seconds))
        sent = []
        start = time.perf_counter()
        for i in range(n):
            deadline = start + i * period
            delay = deadline - time.perf_counter()
            if delay > 0:
                time.sleep(delay)
            stamp = time.time_ns()
            self.pub.publish(self.pose(sweep_x(t_offset + i * period), stamp))
            sent.append(stamp)
        achieved = n / (time.perf_counter() - start)
        time.sleep(2.0)  # drain
        lat = np.array([self.received[s] - s for s in sent if s in self.received], dtype=float) / 1e3
        lost = sum(1 for s in sent if s not in self.received)
        self.received.clear()
        return achieved, lat, lost

    def close(self):
        self._spinning = False
        self._thread.join()
        self.executor.remove_node(self.node)
        self.node.destroy_node()


def start(kind: str, log_path: str) -> subprocess.Popen:
    if kind in ("whisker", "recording"):
        cmd = [whisker_node_executable(), "--ros-args", "--params-file", str(ROOT / "config" / "catenary.yaml"),
               "--log-level", "warn"]
        if kind == "recording":
            cmd += ["-p", f"record.path:={log_path}"]
    else:
        cmd = [sys.executable, str(ROOT / "bench" / "echo_node.py")]
    return subprocess.Popen(cmd, start_new_session=True)


def measure(kind, context, args):
    proc = start(kind, args.log)
    driver = Driver(context)
    try:
        driver.handshake()
        achieved, lat, lost = driver.stream(args.rate, args.seconds)
        result = {"achieved": achieved, "lat": lat, "lost": lost, "sent": int(round(args.rate * args.seconds))}
        sustained = 0
        for rate in ([] if kind == "recording" else args.ramp):  # the recording run stays at --rate: its log size
            achieved_r, lat_r, lost_r = driver.stream(rate, args.ramp_seconds)
            ok = lost_r == 0 and achieved_r >= 0.97 * rate and np.percentile(lat_r, 99) < 50_000
            print(f"  {kind:7s} ramp {rate:6.0f} Hz: sent at {achieved_r:7.0f} Hz, lost {lost_r}, "
                  f"p99 {np.percentile(lat_r, 99) / 1e3 if len(lat_r) else float('nan'):.2f} ms"
                  f"{'' if ok else '  <- not sustained'}")
            if not ok:
                break
            sustained = rate
        result["sustained"] = sustained
        return result
    finally:
        driver.close()
        stop_node(proc)
        if kind == "recording" and os.path.exists(args.log):
            result["log_bytes"] = os.path.getsize(args.log)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--rate", type=float, default=1000.0)
    parser.add_argument("--ramp", type=lambda s: [float(v) for v in s.split(",")], default=[1000, 2000, 3000, 4000, 5000])
    parser.add_argument("--ramp-seconds", type=float, default=5.0)
    parser.add_argument("--log", default="/tmp/vibrissa_bench.mcap", help="where the recording run writes its log")
    parser.add_argument("--nodes", default="whisker,recording,echo",
                        help="which to measure: whisker, recording (whisker_node with record.path), echo")
    args = parser.parse_args(argv)
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    context = rclpy.Context()
    rclpy.init(context=context)
    results = {}
    try:
        for kind in args.nodes.split(","):
            print(f"{kind}: {args.rate:.0f} Hz for {args.seconds:.0f} s ...", flush=True)
            results[kind] = measure(kind, context, args)
    finally:
        rclpy.try_shutdown(context=context)
    print()
    print(f"{'node':9s} {'sent':>7s} {'lost':>5s} {'median':>9s} {'p99':>9s} {'max':>9s} {'sustained':>10s}")
    for kind, r in results.items():
        lat = r["lat"]
        print(f"{kind:9s} {r['sent']:7d} {r['lost']:5d} {np.median(lat) / 1e3:7.3f}ms {np.percentile(lat, 99) / 1e3:7.3f}ms "
              f"{lat.max() / 1e3:7.2f}ms {(str(int(r['sustained'])) + 'Hz') if kind != 'recording' else '-':>10s}")
    for kind in ("whisker", "recording"):
        if kind in results and "echo" in results:
            w, e = results[kind]["lat"], results["echo"]["lat"]
            print(f"{kind}/echo: median {np.median(w) / np.median(e):.2f}x, "
                  f"p99 {np.percentile(w, 99) / np.percentile(e, 99):.2f}x")
    if "recording" in results and "log_bytes" in results["recording"]:
        size = results["recording"]["log_bytes"]
        print(f"recording: a {args.seconds:.0f} s log at {args.rate:.0f} Hz is {size / 1e6:.1f} MB "
              f"({size / args.seconds / args.rate:.0f} bytes per pose, zstd)")


if __name__ == "__main__":
    main()
