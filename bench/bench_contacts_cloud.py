"""
What ~/contacts costs the node per pose, next to the scene tracker's step (same run).

Prints medians [us] of: one scene-tracker step of the shipped two-peg sweep (two contacts), the
SI contact records, building the PointCloud2 and serializing it (what the recorder does), and
their ratio to the step. Run: ``.venv/bin/python bench/bench_contacts_cloud.py``.
"""

import math
import statistics
import time
from pathlib import Path

import numpy as np
from builtin_interfaces.msg import Time
from rclpy.serialization import serialize_message

from vibrissa_ros.node.edge import contact_records
from vibrissa_ros.node.config import build_config
from vibrissa_ros.node.pipeline import PosePipeline
from vibrissa_ros.ros.messages import contacts_cloud

ROOT = Path(__file__).resolve().parents[1]
Q = (0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4))


def main() -> None:
    cfg = build_config({"whisker.length": 0.03, "obstacle.type": "scene",
                        "obstacle.scene_file": str(ROOT / "config" / "scene_two_pegs_m.yaml")})
    pipeline = PosePipeline(cfg)
    xs = np.concatenate([np.linspace(0.003, 0.0075, 400), np.linspace(0.0075, 0.003, 400)])
    pipeline.handle("world", 0, (-0.0045, 0.0, 0.0), Q)
    pipeline.handle("world", 1, (0.003, 0.0, 0.0), Q)  # both pegs touched from here on
    step, records, build, serialize = [], [], [], []
    stamp = Time(sec=1, nanosec=0)
    for i, x in enumerate(xs):
        t0 = time.perf_counter_ns()
        state, _ = pipeline.handle("world", 2 + i, (float(x), 0.0, 0.0), Q)
        t1 = time.perf_counter_ns()
        recs = contact_records(state, cfg.units)
        t2 = time.perf_counter_ns()
        cloud = contacts_cloud(stamp, "world", recs)
        t3 = time.perf_counter_ns()
        serialize_message(cloud)
        t4 = time.perf_counter_ns()
        assert len(recs) == 2
        step.append(t1 - t0)
        records.append(t2 - t1)
        build.append(t3 - t2)
        serialize.append(t4 - t3)
    med = {name: statistics.median(v) / 1e3 for name, v in
           (("step", step), ("records", records), ("cloud", build), ("serialize", serialize))}
    print(f"poses: {len(xs)} with 2 contacts each")
    for name, value in med.items():
        print(f"median {name:<10} {value:9.1f} us   ratio to the step {value / med['step']:.3f}")


if __name__ == "__main__":
    main()
