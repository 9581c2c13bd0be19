"""
Drive a running whisker_node through a sweep of foot poses and record what it answers.

The adapter behind ``vibrissa sweep``: optionally starts ``whisker_node`` with a parameter file,
handshakes (publishes the first pose until the node answers: graph matching alone loses messages),
then publishes one pose at a time and waits for its answer, and writes a CSV in SI units. The
progress bar (tqdm) shares the terminal with the launched node's log: the node's lines are
printed through the bar, above it, never into it.
"""

from __future__ import annotations

import csv
import shutil
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import IO, List, Optional, Sequence

import rclpy
from geometry_msgs.msg import PointStamped, PoseStamped, WrenchStamped
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Float64, UInt8
from tqdm import tqdm

from ..node.edge import NS_PER_S, header_ns
from .messages import pose_stamped

SWEEP_COLUMNS = (
    "x",
    "y",
    "yaw",
    "phase",
    "force_x",
    "force_y",
    "torque_z",
    "contact_force",
    "contact_x",
    "contact_y",
    "arc_length",
)


@dataclass(frozen=True)
class SweepRow:
    """One answered pose: the base-frame wrench [N, N m] and the contact state (world frame, m)."""

    x: float
    y: float
    yaw: float
    phase: int
    force_x: float
    force_y: float
    torque_z: float
    contact_force: float
    contact_x: Optional[float]
    contact_y: Optional[float]
    arc_length: Optional[float]


def whisker_node_executable() -> str:
    """Return the installed ``whisker_node``: beside Python, on PATH or via the ament index."""
    beside = Path(sys.executable).with_name("whisker_node")
    if beside.exists():
        return str(beside)
    found = shutil.which("whisker_node")
    if found:
        return found
    from ament_index_python.packages import get_package_prefix

    return str(Path(get_package_prefix("vibrissa_ros")) / "lib" / "vibrissa_ros" / "whisker_node")


def _forward(stream: IO[str], out: IO[str]) -> None:
    """Print a child's output lines through tqdm, so that they appear above the bar."""
    for line in stream:
        tqdm.write(line.rstrip("\n"), file=out)


def launch_node(params_file: str, namespace: str = "", output: Optional[IO[str]] = None
                ) -> subprocess.Popen:
    """
    Start whisker_node with a parameter file.

    Its log lines go to ``output`` (default stderr) through tqdm.
    """
    cmd = [whisker_node_executable(), "--ros-args", "--params-file", str(params_file)]
    if namespace:
        cmd += ["-r", f"__ns:={namespace}"]
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, bufsize=1)
    threading.Thread(target=_forward, args=(proc.stdout, output or sys.stderr),
                     daemon=True).start()
    return proc


def run_sweep(
    poses: Sequence[tuple],
    node: str = "/whisker_node",
    frame: str = "world",
    timeout: float = 10.0,
    progress: Optional[IO[str]] = None,
) -> List[SweepRow]:
    """
    Publish ``poses`` ((x, y, yaw) in m, m, rad) to ``node`` one by one; return its answers.

    ``progress``: where to draw a progress bar (a terminal stream), or None for none.
    """
    qos = QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.RELIABLE
    )
    context = rclpy.Context()
    rclpy.init(context=context)
    driver = rclpy.create_node("vibrissa_sweep", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(driver)
    got = {"wrench": {}, "phase": [], "force": [], "contact": {}, "s1": []}
    driver.create_subscription(
        WrenchStamped, f"{node}/wrench", lambda m: got["wrench"].__setitem__(header_ns(m), m), qos
    )
    driver.create_subscription(UInt8, f"{node}/phase", lambda m: got["phase"].append(m.data), qos)
    driver.create_subscription(
        Float64, f"{node}/contact_force_magnitude", lambda m: got["force"].append(m.data), qos
    )
    driver.create_subscription(
        PointStamped,
        f"{node}/contact_point",
        lambda m: got["contact"].__setitem__(header_ns(m), m),
        qos,
    )
    driver.create_subscription(
        Float64, f"{node}/arc_length", lambda m: got["s1"].append(m.data), qos
    )
    pub = driver.create_publisher(PoseStamped, f"{node}/foot_pose", qos)

    def message(i: int, pose) -> PoseStamped:
        x, y, yaw = pose
        return pose_stamped(x, y, yaw, NS_PER_S + i * 1_000_000, frame)  # 1 ms apart

    def wait(predicate) -> bool:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if predicate():
                return True
            executor.spin_once(timeout_sec=0.01)
        return predicate()

    rows: List[SweepRow] = []
    bar = tqdm(total=len(poses), unit="pose", file=progress, disable=progress is None,
               dynamic_ncols=True, desc="sweep")
    try:
        first = message(0, poses[0])
        end = time.monotonic() + max(timeout, 30.0)
        while not got["wrench"] and time.monotonic() < end:  # handshake
            pub.publish(first)
            wait_until = time.monotonic() + 0.1
            while time.monotonic() < wait_until and not got["wrench"]:
                executor.spin_once(timeout_sec=0.01)
        if not got["wrench"]:
            raise TimeoutError(
                f"no answer from {node} (is whisker_node running in this ROS_DOMAIN_ID?)"
            )
        t_drain = time.monotonic() + 0.3
        while time.monotonic() < t_drain:
            executor.spin_once(timeout_sec=0.01)
        w = got["wrench"][
            header_ns(first)
        ].wrench  # the first pose places a straight, free whisker
        x, y, yaw = poses[0]
        rows.append(
            SweepRow(
                float(x),
                float(y),
                float(yaw),
                int(got["phase"][0]),
                w.force.x,
                w.force.y,
                w.torque.z,
                got["force"][0],
                None,
                None,
                None,
            )
        )
        for key in got:
            got[key].clear()
        bar.update(1)
        for i, pose in enumerate(poses[1:], start=1):
            msg = message(i, pose)
            stamp = header_ns(msg)
            n = len(got["phase"])
            pub.publish(msg)
            if not wait(
                lambda: stamp in got["wrench"] and len(got["phase"]) > n and len(got["force"]) > n
            ):
                raise TimeoutError(f"{node} did not answer the pose {pose} (dropped? see its log)")
            w = got["wrench"][stamp].wrench
            phase = got["phase"][n]
            contact, s1 = None, None
            if phase:
                if not wait(
                    lambda: stamp in got["contact"] and len(got["s1"]) >= len(got["contact"])
                ):
                    raise TimeoutError(f"{node} sent no contact point for the pose {pose}")
                contact, s1 = got["contact"][stamp], got["s1"][len(got["contact"]) - 1]
            rows.append(
                SweepRow(
                    x=float(pose[0]),
                    y=float(pose[1]),
                    yaw=float(pose[2]),
                    phase=int(phase),
                    force_x=w.force.x,
                    force_y=w.force.y,
                    torque_z=w.torque.z,
                    contact_force=got["force"][n],
                    contact_x=contact.point.x if contact else None,
                    contact_y=contact.point.y if contact else None,
                    arc_length=s1,
                )
            )
            bar.update(1)
    finally:
        bar.close()
        executor.remove_node(driver)
        driver.destroy_node()
        rclpy.try_shutdown(context=context)
    return rows


def write_sweep_csv(rows: Sequence[SweepRow], stream: IO[str]) -> None:
    writer = csv.writer(stream, lineterminator="\n")
    writer.writerow(SWEEP_COLUMNS)
    for r in rows:
        writer.writerow(
            ["" if getattr(r, c) is None else repr(getattr(r, c)) for c in SWEEP_COLUMNS]
        )


def stop_node(proc: subprocess.Popen, timeout: float = 10.0) -> int:
    proc.send_signal(signal.SIGINT)
    try:
        return proc.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        return proc.wait()
