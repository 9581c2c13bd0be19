"""
array_node at 1 kHz: ticks/s, inputs lost, latency, next to a trivial echo node (same run).

Three processes per measured node, so that neither end's Python sits on the measured path: the
node under test, a sender and a receiver (one machine, one clock: latency = arrival - stamp).

External whisking (``whisk.source: external``): the sender publishes the cosine whisk (8 Hz,
-20 to +20 deg, joint ``whisk``) as JointState at --rate for --seconds, each stamped with its
send time; array_node ticks on each one it takes (KEEP_LAST 10: when a tick is slower than the
input period the oldest waiting inputs are overwritten, never queued without bound) and the
receiver records each ~/wrenches cloud's stamp and arrival. Lost = inputs never answered.
Nodes: ``array`` (the default executor), ``events`` (rclpy.experimental.EventsExecutor),
``recording`` (the default executor, record.path set) and ``echo`` (bench/echo_node.py --array:
a PointCloud2 of the same size per JointState, no mechanics).

Built-in whisk (``builtin``): array_node's own timer at --rate in real time for --seconds; the
receiver counts the clouds and reads the node's ticks and ticks_skipped from /diagnostics.

Scenes: ``peg`` (config/rat_array_node.yaml: columns 0-2 hit the peg, the solver is the
bottleneck) and ``free`` (a ball far away: every whisker is certified free, the node's own cost).

Run: OPENBLAS_NUM_THREADS=1 python bench/bench_array_node.py [--seconds 20] [--rate 1000]
     [--scenes peg,free] [--nodes array,events,recording,echo,builtin] [--points-tolerance T]
     [--workers W]
     [--rounds K]   (K rounds in turn: each node's median over them, ratios to each round's echo)
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
TOPIC = "/array_node"
FAR = "obstacles:\n  - {type: sphere, name: far, center: [1.0, 1.0, 1.0], r: 0.01}\n"


def _qos(depth=1000):
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                      reliability=ReliabilityPolicy.RELIABLE)


def receiver(work: Path) -> None:
    """Record (stamp, arrival, whiskers in contact) of every cloud until work/stop exists."""
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from sensor_msgs.msg import PointCloud2

    from vibrissa_ros.node.edge import header_ns
    from vibrissa_ros.ros.array_messages import decode_cloud

    rclpy.init()
    node = rclpy.create_node("bench_receiver")
    got, status = [], {}

    def on_cloud(msg):
        arrival = time.time_ns()
        rows = decode_cloud(msg)
        touching = int((rows["contacts"] > 0).sum()) if "contacts" in rows.dtype.names else 0
        got.append((header_ns(msg), arrival, touching))

    def on_diag(msg):
        for s in msg.status:
            if s.hardware_id == TOPIC:
                status.update({kv.key: kv.value for kv in s.values})

    node.create_subscription(PointCloud2, f"{TOPIC}/wrenches", on_cloud, _qos())
    node.create_subscription(DiagnosticArray, "/diagnostics", on_diag, 50)
    while not (work / "stop").exists():
        rclpy.spin_once(node, timeout_sec=0.05)
        if got and not (work / "ready").exists():
            (work / "ready").touch()
    end = time.monotonic() + 2.0  # drain
    while time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
    np.save(work / "received.npy", np.array(got, dtype=np.int64).reshape(-1, 3))
    (work / "status.json").write_text(json.dumps(status))
    node.destroy_node()
    rclpy.try_shutdown()


def sender(work: Path, rate: float, seconds: float, send: bool) -> None:
    """Handshake through the receiver, then publish the whisk at ``rate`` (or only wait)."""
    import rclpy
    from sensor_msgs.msg import JointState

    from vibrissa_ros.core.arrays import CosineWhisk
    from vibrissa_ros.node.edge import set_stamp

    rclpy.init()
    node = rclpy.create_node("bench_sender")
    pub = node.create_publisher(JointState, f"{TOPIC}/whisk", _qos(10))
    whisk = CosineWhisk(8.0, -math.radians(20.0), math.radians(20.0))

    def msg_at(t):
        msg = JointState()
        set_stamp(msg.header.stamp, time.time_ns())
        msg.name = ["whisk"]
        msg.position = [whisk.angle(t)]
        return msg

    end = time.monotonic() + 60.0
    while not (work / "ready").exists() and time.monotonic() < end:
        if send:
            pub.publish(msg_at(0.0))
        time.sleep(0.1)
    if not (work / "ready").exists():  # no answer: measure nothing, but let the receiver stop
        print("the node under test does not answer", file=sys.stderr)
        (work / "sent.json").write_text(json.dumps({"sent": [], "achieved": 0.0, "start_ns": 0,
                                                    "seconds": 1.0, "silent": True}))
        (work / "stop").touch()
        return
    time.sleep(1.0)
    sent = []
    start = time.perf_counter()
    n = int(round(rate * seconds))
    for i in range(n):
        delay = start + i / rate - time.perf_counter()
        if delay > 0:
            time.sleep(delay)
        if send:
            msg = msg_at(i / rate)
            pub.publish(msg)
            sent.append(msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec)
    elapsed = time.perf_counter() - start
    (work / "sent.json").write_text(json.dumps({"sent": sent, "achieved": n / elapsed,
                                                "start_ns": time.time_ns() - int(elapsed * 1e9),
                                                "seconds": elapsed}))
    time.sleep(2.0)
    (work / "stop").touch()
    node.destroy_node()
    rclpy.try_shutdown()


def start_node(kind: str, scene: str, args, work: Path) -> subprocess.Popen:
    if kind == "echo":
        return subprocess.Popen([sys.executable, str(ROOT / "bench" / "echo_node.py"),
                                 "--array"],
                                start_new_session=True)
    exe = Path(sys.executable).with_name("array_node")
    cmd = [str(exe), "--ros-args", "--params-file", str(ROOT / "config" / "rat_array_node.yaml"),
           "--log-level", "warn", "-p", "diagnostics.period:=0.5"]
    if scene == "free":
        (work / "far.yaml").write_text(FAR)
        cmd += ["-p", f"scene.file:={work / 'far.yaml'}"]
    if kind == "builtin":
        cmd += ["-p", f"rate:={args.rate!r}", "-p", "whisk.realtime:=true"]
    else:
        cmd += ["-p", "whisk.source:=external"]
    if kind == "events":
        cmd += ["-p", "executor:=events"]
    if kind == "recording":
        cmd += ["-p", f"record.path:={work / 'run.mcap'}"]
    if args.points_tolerance is not None:
        cmd += ["-p", f"solver.points_tolerance:={args.points_tolerance!r}"]
    if args.workers is not None:
        cmd += ["-p", f"solver.workers:={args.workers}"]
    return subprocess.Popen(cmd, start_new_session=True)


def measure(kind: str, scene: str, args, work: Path) -> dict:
    work.mkdir(parents=True)
    node = start_node(kind, scene, args, work)
    me = [sys.executable, __file__, "--work", str(work)]
    rx = subprocess.Popen(me + ["--role", "receiver"])
    tx = subprocess.Popen(me + ["--role", "sender", "--rate", repr(args.rate), "--seconds",
                                repr(args.seconds), "--send", str(int(kind != "builtin"))])
    try:
        tx.wait()
        rx.wait(timeout=120)
    finally:
        node.send_signal(2)
        try:
            node.wait(timeout=20)
        except subprocess.TimeoutExpired:  # it ignored SIGINT (seen with the EventsExecutor)
            print(f"  {kind} did not stop on SIGINT within 20 s: killed", flush=True)
            node.kill()
            node.wait()
    got = np.load(work / "received.npy")
    sent = json.loads((work / "sent.json").read_text())
    status = json.loads((work / "status.json").read_text())
    out = {"kind": kind, "scene": scene, "status": status, "silent": sent.get("silent", False)}
    if kind == "builtin":
        window = got[(got[:, 1] >= sent["start_ns"])]
        out["ticks_per_s"] = len(window) / sent["seconds"]
        out["contact"] = float(np.mean(window[:, 2] > 0)) if len(window) else 0.0
        return out
    stamps = set(sent["sent"])
    mine = got[np.isin(got[:, 0], list(stamps))]
    lat = (mine[:, 1] - mine[:, 0]) / 1e6
    out.update(sent=len(stamps), answered=len(mine), lost=len(stamps) - len(mine),
               ticks_per_s=len(mine) / sent["seconds"], achieved=sent["achieved"],
               median=float(np.median(lat)) if len(lat) else math.nan,
               p99=float(np.percentile(lat, 99)) if len(lat) else math.nan,
               contact=float(np.mean(mine[:, 2] > 0)) if len(mine) else 0.0)
    if kind == "recording" and (work / "run.mcap").exists():
        out["log_bytes"] = (work / "run.mcap").stat().st_size
    return out


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--rate", type=float, default=1000.0)
    parser.add_argument("--scenes", default="peg,free")
    parser.add_argument("--points-tolerance", type=float, default=None, metavar="T",
                        help="array_node's solver.points_tolerance (default: the node's, 1e-11)")
    parser.add_argument("--workers", type=int, default=None, metavar="W",
                        help="array_node's solver.workers (default: the node's, 1)")
    parser.add_argument("--nodes", default="array,events,recording,echo,builtin")
    parser.add_argument("--rounds", type=int, default=1,
                        help="measure everything this many times, in turn (a noisy machine: "
                        "the summary gives each node's median over the rounds, and its ratios "
                        "to the echo node of the same round)")
    parser.add_argument("--role", choices=["sender", "receiver"], help=argparse.SUPPRESS)
    parser.add_argument("--work", help=argparse.SUPPRESS)
    parser.add_argument("--send", type=int, default=1, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.role == "receiver":
        return receiver(Path(args.work))
    if args.role == "sender":
        return sender(Path(args.work), args.rate, args.seconds, bool(args.send))
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    results = []
    rounds = max(1, args.rounds)
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(rounds):
            for scene in args.scenes.split(","):
                for kind in args.nodes.split(","):
                    if kind == "echo" and scene != args.scenes.split(",")[0]:
                        continue  # the echo has no scene
                    print(f"{kind} ({scene}): {args.rate:.0f} Hz for {args.seconds:.0f} s"
                          f"{f' (round {k + 1} of {rounds})' if rounds > 1 else ''} ...",
                          flush=True)
                    r = measure(kind, scene, args, Path(tmp) / f"{scene}_{kind}_{k}")
                    r["round"] = k
                    results.append(r)
    print()
    print(f"{'node':10s} {'scene':5s} {'sent':>6s} {'lost':>6s} {'ticks/s':>8s} "
          f"{'median':>9s} {'p99':>9s} {'contact':>8s}  node's diagnostics")
    echoes = {r["round"]: r for r in results if r["kind"] == "echo" and not r["silent"]}
    for r in results:
        s = r["status"]
        if r["silent"]:
            print(f"{r['kind']:10s} {r['scene']:5s} no answer within 60 s")
            continue
        diag = (f"ticks {s.get('ticks', '-')}, skipped {s.get('ticks_skipped', '-')}, "
                f"tick median {s.get('tick_ms_median', '-')} ms, p99 "
                f"{s.get('tick_ms_p99', '-')} ms")
        if r["kind"] == "builtin":
            print(f"{r['kind']:10s} {r['scene']:5s} {'-':>6s} {'-':>6s} "
                  f"{r['ticks_per_s']:8.0f} {'-':>9s} {'-':>9s} {r['contact']:7.0%}  {diag}")
            continue
        print(f"{r['kind']:10s} {r['scene']:5s} {r['sent']:6d} {r['lost']:6d} "
              f"{r['ticks_per_s']:8.0f} {r['median']:7.2f}ms {r['p99']:7.2f}ms "
              f"{r['contact']:7.0%}  {diag if r['kind'] != 'echo' else ''}")
    for r in results:
        echo = echoes.get(r["round"])
        if (echo is not None and r["kind"] in ("array", "events", "recording")
                and r.get("answered")):
            print(f"{r['kind']}/echo ({r['scene']}): median latency "
                  f"{r['median'] / echo['median']:.2f}x, p99 {r['p99'] / echo['p99']:.2f}x")
    if rounds > 1:
        print(f"over the {rounds} rounds, medians (the ratios to the echo node of each round):")
        for key in dict.fromkeys((r["kind"], r["scene"]) for r in results):
            runs = [r for r in results if (r["kind"], r["scene"]) == key and not r["silent"]
                    and r["kind"] != "builtin"]
            if not runs:
                continue
            line = (f"  {key[0]:10s} {key[1]:5s} latency median "
                    f"{np.median([r['median'] for r in runs]):.2f} ms, p99 "
                    f"{np.median([r['p99'] for r in runs]):.2f} ms (range "
                    f"{min(r['p99'] for r in runs):.2f}-{max(r['p99'] for r in runs):.2f}); "
                    f"lost {sum(r['lost'] for r in runs)} of {sum(r['sent'] for r in runs)}")
            ratios = [(r["median"] / echoes[r["round"]]["median"],
                       r["p99"] / echoes[r["round"]]["p99"])
                      for r in runs if r["round"] in echoes and r["kind"] != "echo"]
            if ratios:
                line += (f"; /echo median {np.median([a for a, _ in ratios]):.2f}x, p99 "
                         f"{np.median([b for _, b in ratios]):.2f}x")
            print(line)
    for r in results:
        if "log_bytes" in r and r.get("answered"):
            print(f"recording ({r['scene']}): {r['log_bytes'] / 1e6:.1f} MB for "
                  f"{r['answered']} ticks ({r['log_bytes'] / max(r['answered'], 1):.0f} "
                  "bytes per tick, zstd)")


if __name__ == "__main__":
    main()
