"""
What a kill -9 of a recording whisker_node loses, measured.

Streams foot poses at --rate into whisker_node with record.path set, kills it with SIGKILL at a
random moment, repairs the log with `vibrissa repair` and measures how long before the kill the
newest pose that did not survive was sent (the data lost). Repeats --runs times; prints the worst.

Run: python bench/bench_kill9.py [--runs 5] [--rate 1000]
"""

from __future__ import annotations

import argparse
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import rclpy

# bench/, for bench_node's driver: the imports below must follow (E402)
sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_node import Driver  # noqa: E402

from vibrissa_ros.logs.tools import decode  # noqa: E402
from vibrissa_ros.logs.mcap_log import read_log, repair  # noqa: E402
from vibrissa_ros.ros.sweep import whisker_node_executable  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def one_run(context, rate: float, workdir: Path, rng: random.Random) -> float:
    log = workdir / "killed.mcap"
    proc = subprocess.Popen([whisker_node_executable(), "--ros-args", "--params-file",
                             str(ROOT / "config" / "catenary.yaml"), "--log-level", "warn", "-p",
                             f"record.path:={log}"], start_new_session=True)
    driver = Driver(context)
    try:
        driver.handshake()
        period = 1.0 / rate
        sent = []
        kill_after = rng.uniform(2.0, 4.0)
        start = time.perf_counter()
        i = 0
        while time.perf_counter() - start < kill_after:
            deadline = start + i * period
            delay = deadline - time.perf_counter()
            if delay > 0:
                time.sleep(delay)
            stamp = time.time_ns()
            driver.pub.publish(driver.pose(0.15 - 0.3 * (i % 5000) / 5000, stamp))
            sent.append((time.monotonic(), stamp))
            i += 1
        killed_at = time.monotonic()
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    finally:
        driver.close()
    fixed = workdir / "fixed.mcap"
    repair(str(log), str(fixed))
    kept = set()
    for m in read_log(str(fixed))[3]:
        if m.topic == "/whisker_node/foot_pose":
            msg = decode(m)
            kept.add(msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec)
    lost = [killed_at - t for t, s in sent if s not in kept]
    return max(lost) if lost else 0.0


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--rate", type=float, default=1000.0)
    args = parser.parse_args(argv)
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    os.environ.setdefault("ROS_DOMAIN_ID", "58")  # away from other ROS work on the machine
    context = rclpy.Context()
    rclpy.init(context=context)
    rng = random.Random(1)
    losses = []
    try:
        with tempfile.TemporaryDirectory() as tmp:
            for run in range(args.runs):
                loss = one_run(context, args.rate, Path(tmp), rng)
                losses.append(loss)
                print(f"run {run + 1}: the oldest lost pose was sent {loss * 1e3:.0f} ms before "
                      "the kill", flush=True)
    finally:
        rclpy.try_shutdown(context=context)
    print(f"kill -9 at {args.rate:.0f} Hz: worst loss {max(losses) * 1e3:.0f} ms of data over "
          f"{args.runs} runs (median {sorted(losses)[len(losses) // 2] * 1e3:.0f} ms)")


if __name__ == "__main__":
    main()
