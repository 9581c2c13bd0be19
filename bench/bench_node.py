"""
Pose -> wrench latency and loss of whisker_node at a fixed rate, next to a trivial echo node.

Three processes per measured node, so that neither end's Python sits on the measured path: the
node under test, a sender (publishes foot poses, each stamped with its send time) and a receiver
(records when each answer arrives; the latency is arrival minus stamp, one machine, one clock).
For each node (whisker_node on config/catenary.yaml, whisker_node recording to MCAP, then
bench/echo_node.py): stream poses for --seconds at --rate (the paper's catenary sweep, back and
forth: x runs 0.15 -> -0.15 -> 0.15 m every 10 s), then ramp the rate (--ramp) for --ramp-seconds
each; report the highest rate that loses nothing. Prints medians and p99 with the ratios to the
echo node measured in the same run, the CPU time each node (with its log writer) used per pose,
and the recording's log size. ``--rounds K`` measures the nodes K times in turn and adds each
node's median over the rounds (its p99 varies between runs on a shared machine as much as
between nodes), with the ratios to the echo node of the same round.

Run: python bench/bench_node.py [--seconds 60] [--rate 1000] [--ramp 1000,2000,3000,4000]
     [--rounds K]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
TOPIC = "/whisker_node"


def sweep_x(t: float, period: float = 10.0, amplitude: float = 0.15) -> float:
    """Triangle wave: +amplitude -> -amplitude -> +amplitude every ``period`` seconds."""
    phase = (t / period) % 1.0
    return amplitude * (1.0 - 4.0 * phase) if phase < 0.5 else amplitude * (4.0 * phase - 3.0)


def _qos():
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

    return QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=1000,
                      reliability=ReliabilityPolicy.RELIABLE)


class Driver:
    """An in-process pose publisher and wrench listener (bench_kill9.py's driver)."""

    def __init__(self, context):
        import rclpy
        from geometry_msgs.msg import PoseStamped, WrenchStamped
        from rclpy.executors import SingleThreadedExecutor

        from vibrissa_ros.node.edge import header_ns

        self.node = rclpy.create_node("bench_driver", context=context)
        self.pub = self.node.create_publisher(PoseStamped, f"{TOPIC}/foot_pose", _qos())
        self.received = {}
        self.node.create_subscription(
            WrenchStamped, f"{TOPIC}/wrench",
            lambda m: self.received.__setitem__(header_ns(m), time.time_ns()), _qos())
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self._spinning = True
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _spin(self):
        while self._spinning:
            self.executor.spin_once(timeout_sec=0.01)

    def pose(self, x: float, stamp_ns: int):
        """Return the foot pose at x [m] on the paper's line (yaw 90 degrees)."""
        from vibrissa_ros.ros.messages import pose_stamped

        return pose_stamped(x, 0.0, math.pi / 2, stamp_ns)

    def handshake(self, timeout: float = 30.0) -> None:
        """Publish a pose every 0.1 s until the node answers."""
        end = time.monotonic() + timeout
        while not self.received and time.monotonic() < end:
            self.pub.publish(self.pose(0.2, time.time_ns()))
            time.sleep(0.1)
        if not self.received:
            raise TimeoutError("the node under test does not answer")
        time.sleep(0.5)
        self.received.clear()

    def close(self) -> None:
        """Stop spinning and destroy the node."""
        self._spinning = False
        self._thread.join()
        self.executor.remove_node(self.node)
        self.node.destroy_node()


def receiver(work: Path) -> None:
    """Record (stamp, arrival) of every wrench until work/stop exists; then write them."""
    import rclpy
    from geometry_msgs.msg import WrenchStamped

    from vibrissa_ros.node.edge import header_ns

    rclpy.init()
    node = rclpy.create_node("bench_receiver")
    got = []
    node.create_subscription(WrenchStamped, f"{TOPIC}/wrench",
                             lambda m: got.append((header_ns(m), time.time_ns())), _qos())
    while not (work / "stop").exists():
        rclpy.spin_once(node, timeout_sec=0.05)
        if got and not (work / "ready").exists():
            (work / "ready").touch()
    end = time.monotonic() + 2.0  # drain
    while time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
    np.save(work / "received.npy", np.array(got, dtype=np.int64).reshape(-1, 2))
    node.destroy_node()
    rclpy.try_shutdown()


def sender(work: Path, segments, amplitude: float = 0.15) -> None:
    """Handshake through the receiver, then publish each (rate, seconds) segment on time."""
    import rclpy
    from geometry_msgs.msg import PoseStamped

    from vibrissa_ros.ros.messages import pose_stamped

    rclpy.init()
    node = rclpy.create_node("bench_sender")
    pub = node.create_publisher(PoseStamped, f"{TOPIC}/foot_pose", _qos())
    end = time.monotonic() + 30.0
    while not (work / "ready").exists() and time.monotonic() < end:
        pub.publish(pose_stamped(0.2, 0.0, math.pi / 2, time.time_ns()))
        time.sleep(0.1)
    if not (work / "ready").exists():
        raise TimeoutError("the node under test does not answer")
    time.sleep(1.0)
    out, t_offset = [], 0.0
    for rate, seconds in segments:
        period, n = 1.0 / rate, int(round(rate * seconds))
        sent = []
        start = time.perf_counter()
        for i in range(n):
            delay = start + i * period - time.perf_counter()
            if delay > 0:
                time.sleep(delay)
            stamp = time.time_ns()
            x = sweep_x(t_offset + i * period, amplitude=amplitude)
            pub.publish(pose_stamped(x, 0.0, math.pi / 2, stamp))
            sent.append(stamp)
        out.append({"rate": rate, "achieved": n / (time.perf_counter() - start), "sent": sent})
        t_offset += seconds
        time.sleep(2.0)  # let the node drain between segments
    (work / "sent.json").write_text(json.dumps(out))
    (work / "stop").touch()
    node.destroy_node()
    rclpy.try_shutdown()


def cpu_seconds(pid: int) -> float:
    """Return the CPU time [s] used so far by a process and its children (the log writer)."""
    import psutil

    try:
        proc = psutil.Process(pid)
        total = 0.0
        for p in [proc] + proc.children(recursive=True):
            times = p.cpu_times()
            total += times.user + times.system
        return total
    except psutil.Error:
        return math.nan


def start_node(kind: str, log_path: str, params: str) -> subprocess.Popen:
    if kind in ("whisker", "recording"):
        exe = Path(sys.executable).with_name("whisker_node")
        cmd = [str(exe), "--ros-args", "--params-file", params,
               "--log-level", "warn"]
        if kind == "recording":
            cmd += ["-p", f"record.path:={log_path}"]
    else:
        cmd = [sys.executable, str(ROOT / "bench" / "echo_node.py")]
    return subprocess.Popen(cmd, start_new_session=True)


def measure(kind: str, args, work: Path):
    work.mkdir()
    segments = [(args.rate, args.seconds)]
    if kind != "recording":  # the recording run stays at --rate: its log size
        segments += [(rate, args.ramp_seconds) for rate in args.ramp]
    node = start_node(kind, args.log, args.params)
    me = [sys.executable, __file__, "--work", str(work),
          "--amplitude", repr(args.amplitude)]
    rx = subprocess.Popen(me + ["--role", "receiver"])
    tx = subprocess.Popen(me + ["--role", "sender", "--segments", json.dumps(segments)])
    try:
        while tx.poll() is None and not (work / "ready").exists():
            time.sleep(0.05)
        cpu_start = cpu_seconds(node.pid)  # the sender starts streaming 1 s after ready
        tx.wait()
        cpu_used = cpu_seconds(node.pid) - cpu_start
        rx.wait(timeout=120)
    finally:
        node.send_signal(2)
        node.wait(timeout=30)
    arrival = dict(map(tuple, np.load(work / "received.npy")))
    results = []
    for seg in json.loads((work / "sent.json").read_text()):
        lat = np.array([arrival[s] - s for s in seg["sent"] if s in arrival], dtype=float) / 1e3
        results.append({"rate": seg["rate"], "achieved": seg["achieved"], "lat": lat,
                        "lost": sum(1 for s in seg["sent"] if s not in arrival),
                        "sent": len(seg["sent"])})
    main_run, sustained = results[0], 0
    main_run["cpu_per_pose"] = cpu_used / sum(r["sent"] for r in results)
    for r in results[1:]:
        p99 = np.percentile(r["lat"], 99) if len(r["lat"]) else math.inf
        ok = r["lost"] == 0 and r["achieved"] >= 0.97 * r["rate"] and p99 < 50_000
        print(f"  {kind:9s} ramp {r['rate']:6.0f} Hz: sent at {r['achieved']:7.0f} Hz, lost "
              f"{r['lost']}, p99 {p99 / 1e3:.2f} ms{'' if ok else '  <- not sustained'}")
        if not ok:
            break
        sustained = r["rate"]
    main_run["sustained"] = sustained
    if kind == "recording" and os.path.exists(args.log):
        main_run["log_bytes"] = os.path.getsize(args.log)
    return main_run


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--rate", type=float, default=1000.0)
    parser.add_argument("--ramp", type=lambda s: [float(v) for v in s.split(",") if v],
                        default=[1000, 2000, 3000, 4000, 5000],
                        help="rates [Hz] of the ramp after the main run, comma-separated; '' "
                        "for none")
    parser.add_argument("--ramp-seconds", type=float, default=5.0)
    parser.add_argument("--log",
                        default=os.path.join(tempfile.gettempdir(), "vibrissa_bench.mcap"),
                        help="where the recording run writes its log")
    parser.add_argument("--nodes", default="whisker,recording,echo",
                        help="which to measure: whisker, recording (record.path), echo")
    parser.add_argument("--params", default=str(ROOT / "config" / "catenary.yaml"),
                        help="whisker_node's parameter file (e.g. config/rat_pole.yaml)")
    parser.add_argument("--amplitude", type=float, default=0.15,
                        help="the foot sweeps x between +-amplitude [m] (0.15 for the catenary; "
                        "0.012 for rat_pole.yaml)")
    parser.add_argument("--rounds", type=int, default=1,
                        help="measure the nodes this many times, in turn (a noisy machine: the "
                        "summary gives each node's median over the rounds, and its ratios to "
                        "the echo node of the same round)")
    parser.add_argument("--role", choices=["sender", "receiver"], help=argparse.SUPPRESS)
    parser.add_argument("--work", help=argparse.SUPPRESS)
    parser.add_argument("--segments", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.role == "receiver":
        return receiver(Path(args.work))
    if args.role == "sender":
        return sender(Path(args.work), json.loads(args.segments), args.amplitude)
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    os.environ.setdefault("ROS_DOMAIN_ID", "57")  # away from other ROS work on the machine
    kinds = args.nodes.split(",")
    rounds = []
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(max(1, args.rounds)):
            results = {}
            for kind in kinds:
                print(f"{kind}: {args.rate:.0f} Hz for {args.seconds:.0f} s"
                      f"{f' (round {k + 1} of {args.rounds})' if args.rounds > 1 else ''} ...",
                      flush=True)
                results[kind] = measure(kind, args, Path(tmp) / f"{kind}_{k}")
            rounds.append(results)
    print()
    print(f"{'node':9s} {'sent':>7s} {'lost':>5s} {'median':>9s} {'p99':>9s} {'max':>9s} "
          f"{'sustained':>10s} {'CPU/pose':>9s}")
    for results in rounds:
        for kind, r in results.items():
            lat = r["lat"]
            sustained = f"{int(r['sustained'])}Hz" if kind != "recording" and args.ramp else "-"
            print(f"{kind:9s} {r['sent']:7d} {r['lost']:5d} {np.median(lat) / 1e3:7.3f}ms "
                  f"{np.percentile(lat, 99) / 1e3:7.3f}ms {lat.max() / 1e3:7.2f}ms "
                  f"{sustained:>10s} {r['cpu_per_pose'] * 1e6:7.0f}us")
    for kind in ("whisker", "recording"):
        if kind not in kinds or "echo" not in kinds:
            continue
        median = [np.median(r[kind]["lat"]) / np.median(r["echo"]["lat"]) for r in rounds]
        p99 = [np.percentile(r[kind]["lat"], 99) / np.percentile(r["echo"]["lat"], 99)
               for r in rounds]
        print(f"{kind}/echo: median {np.median(median):.2f}x, p99 {np.median(p99):.2f}x"
              + (f" (medians over {len(rounds)} rounds; p99 ratios {min(p99):.2f}-"
                 f"{max(p99):.2f}x)" if len(rounds) > 1 else ""))
    if len(rounds) > 1:
        print(f"over the {len(rounds)} rounds, each node's median of:")
        for kind in kinds:
            runs = [r[kind] for r in rounds]
            print(f"  {kind:9s} latency median "
                  f"{np.median([np.median(r['lat']) for r in runs]) / 1e3:.3f} ms, p99 "
                  f"{np.median([np.percentile(r['lat'], 99) for r in runs]) / 1e3:.3f} ms "
                  f"(range {min(np.percentile(r['lat'], 99) for r in runs) / 1e3:.2f}-"
                  f"{max(np.percentile(r['lat'], 99) for r in runs) / 1e3:.2f}); lost "
                  f"{sum(r['lost'] for r in runs)} of {sum(r['sent'] for r in runs)}; CPU "
                  f"{np.median([r['cpu_per_pose'] for r in runs]) * 1e6:.0f} us per pose")
    last = rounds[-1]
    if "recording" in last and "log_bytes" in last["recording"]:
        size = last["recording"]["log_bytes"]
        print(f"recording: a {args.seconds:.0f} s log at {args.rate:.0f} Hz is "
              f"{size / 1e6:.1f} MB ({size / args.seconds / args.rate:.0f} bytes per pose, zstd)")


if __name__ == "__main__":
    main()
