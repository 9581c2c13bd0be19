"""
Writes test/data/catenary_sweep.mcap: a short run of whisker_node, recorded by the node itself.

The log the offline tests (info, resim, export, plot, reconstruct) read without DDS. Run it again
only when the log layout changes: ``python test/data/make_sweep_log.py``. The run: the catenary of
the node tests, 81 foot poses back and forth across it (both snaps), sent one at a time.
"""

import math
import os
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import rclpy
from domain_coordinator import domain_id

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))  # the test helpers: the import below must follow (E402)
from ros_harness import Probe, pose_msg, ros_env, stop, write_params  # noqa: E402

PARAMS = {
    "obstacle.type": "catenary", "obstacle.c": 0.06, "obstacle.apex_y": 0.05,
    "diagnostics.period": 0.5, "centerline.max_rate": 10.0, "centerline.points": 11,
}


def main():
    out = HERE / "catenary_sweep.mcap"
    xs = np.round(np.concatenate([np.linspace(0.15, -0.15, 41), np.linspace(-0.14, 0.15, 40)]), 10)
    with domain_id() as domain, tempfile.TemporaryDirectory() as tmp:
        env = ros_env(domain, Path(tmp))
        os.environ.update(env)
        out.unlink(missing_ok=True)
        params = write_params(Path(tmp) / "p.yaml", dict(PARAMS, **{"record.path": str(out)}))
        exe = Path(sys.executable).with_name("whisker_node")
        proc = subprocess.Popen([str(exe), "--ros-args", "--params-file", str(params)], env=env,
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        context = rclpy.Context()
        rclpy.init(context=context)
        probe = Probe(context, "/whisker_node", name="probe_make_log")
        try:
            probe.handshake(pose_msg(float(xs[0]), 0.0, math.pi / 2, 1_000_000_000))
            for i, x in enumerate(xs[1:], start=1):
                probe.step(pose_msg(float(x), 0.0, math.pi / 2, 1_000_000_000 + i * 10_000_000))
        finally:
            probe.destroy()
            rclpy.try_shutdown(context=context)
            assert stop(proc, signal.SIGINT) == 0
    print(f"{out}: {out.stat().st_size} bytes")


if __name__ == "__main__":
    main()
