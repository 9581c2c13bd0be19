"""
Launch-free ROS 2 test harness: build with colcon, start installed nodes, probe their topics.

Isolation: every test session reserves its own ROS_DOMAIN_ID (domain_coordinator), discovery is
limited to this machine, logs go to a temporary folder, and ROS_PYTHON_CHECK_FIELDS=1 makes a wrong
field type an error instead of silent garbage.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Dict, List, Optional

import rclpy
import yaml
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PointStamped, PoseStamped, Vector3Stamped, WrenchStamped
from nav_msgs.msg import Path as PathMsg
from sensor_msgs.msg import PointCloud2
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Float64, String, UInt8
from visualization_msgs.msg import Marker, MarkerArray

from vibrissa_ros.node.edge import header_ns
from vibrissa_ros.ros.messages import pose_stamped

ROOT = Path(__file__).resolve().parents[1]
RELIABLE = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000,
                      reliability=ReliabilityPolicy.RELIABLE)
LATCHED = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                     reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)


def ros_env(domain: int, log_dir: Path) -> Dict[str, str]:
    env = dict(os.environ)
    env.update(
        ROS_DOMAIN_ID=str(domain),
        ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
        ROS_LOG_DIR=str(log_dir),
        ROS_PYTHON_CHECK_FIELDS="1",
        PYTHONUNBUFFERED="1",
        RCUTILS_COLORIZED_OUTPUT="0",
    )
    return env


def colcon_build(workdir: Path, env: Dict[str, str]) -> Path:
    """``colcon build`` of this package into ``workdir``; returns the install folder."""
    colcon = Path(sys.executable).with_name("colcon")
    cmd = [str(colcon), "build", "--paths", str(ROOT), "--build-base", str(workdir / "build"),
           "--install-base", str(workdir / "install")]
    proc = subprocess.run(cmd, cwd=workdir, env=env, capture_output=True, text=True, timeout=600)
    if proc.returncode != 0:
        raise RuntimeError(f"colcon build failed:\n{proc.stdout}\n{proc.stderr}")
    return workdir / "install"


def read_params(path: Path, node: str = "/**") -> Dict[str, object]:
    """Read a ROS 2 parameter file's values with dotted names (the inverse of write_params)."""
    def flatten(tree, prefix=""):
        out: Dict[str, object] = {}
        for key, value in tree.items():
            if isinstance(value, dict):
                out.update(flatten(value, f"{prefix}{key}."))
            else:
                out[f"{prefix}{key}"] = value
        return out

    return flatten(yaml.safe_load(Path(path).read_text())[node]["ros__parameters"])


def write_params(path: Path, values: Dict[str, object], node: str = "/**") -> Path:
    """Write a ROS 2 parameter file (JSON is YAML) with nested keys for the dotted names."""
    tree: Dict[str, object] = {}
    for name, value in values.items():
        parts = name.split(".")
        leaf = tree
        for part in parts[:-1]:
            leaf = leaf.setdefault(part, {})
        leaf[parts[-1]] = value
    path.write_text(json.dumps({node: {"ros__parameters": tree}}, indent=1))
    return path


def start_installed_node(install: Path, params_file: Optional[Path], env: Dict[str, str],
                         namespace: str = "", executable: str = "whisker_node",
                         extra: str = "") -> subprocess.Popen:
    """
    Start an installed executable the way ``ros2 run vibrissa_ros <exe>`` finds it.

    Source the workspace, ask the ament index for the package prefix, exec
    <prefix>/lib/vibrissa_ros/<exe>.
    """
    lookup = (f'"{sys.executable}" -c "from ament_index_python.packages import get_package_prefix '
              'as g; print(g(\'vibrissa_ros\'))"')
    args = "--ros-args"
    if params_file is not None:
        args += f" --params-file {params_file}"
    if namespace:
        args += f" -r __ns:={namespace}"
    cmd = (f'. "{install}/local_setup.bash" && exec "$({lookup})/lib/vibrissa_ros/{executable}" '
           f'{args} {extra}')
    return subprocess.Popen(["bash", "-c", cmd], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, start_new_session=True)


def stop(proc: subprocess.Popen, sig=signal.SIGINT, timeout: float = 10.0) -> int:
    """Stop a started node; on a non-zero exit its output is printed (pytest shows it)."""
    if proc.poll() is None:
        proc.send_signal(sig)
    try:
        code = proc.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
        code = -9
    if code != 0 and proc.stdout is not None and not proc.stdout.closed:
        print(f"--- exit status {code}, output:\n{proc.stdout.read()}")
    return code


def pose_msg(x: float, y: float, yaw: float, stamp_ns: int, frame: str = "world",
             z: float = 0.0) -> PoseStamped:
    return pose_stamped(x, y, yaw, stamp_ns, frame, z)


stamp_of = header_ns


class Probe:
    """A test node that drives one whisker node and records everything it publishes."""

    TOPICS = {
        "wrench": (WrenchStamped, RELIABLE),
        "phase": (UInt8, RELIABLE),
        "contact_force": (Vector3Stamped, RELIABLE),
        "contact_force_magnitude": (Float64, RELIABLE),
        "contact_point": (PointStamped, RELIABLE),
        "arc_length": (Float64, RELIABLE),
        "events": (String, RELIABLE),
        "centerline": (PathMsg, RELIABLE),
        "obstacle": (Marker, LATCHED),
        "obstacles": (MarkerArray, LATCHED),
        "contacts": (PointCloud2, RELIABLE),
    }
    LATCHED_TOPICS = ("obstacle", "obstacles")

    def __init__(self, context, prefix: str = "/whisker_node", name: str = "probe",
                 qos: Optional[QoSProfile] = None, pose_qos: QoSProfile = RELIABLE):
        """``qos`` replaces the QoS of every per-pose output (e.g. KEEP_ALL for a storm)."""
        self.context = context
        self.node = rclpy.create_node(name, context=context)
        self.prefix = prefix
        self.got: Dict[str, List] = {k: [] for k in self.TOPICS}
        self.got["diagnostics"] = []
        for topic, (kind, default_qos) in self.TOPICS.items():
            use = default_qos if (qos is None or topic in self.LATCHED_TOPICS) else qos
            self.node.create_subscription(kind, f"{prefix}/{topic}", self._keep(topic), use)
        self.node.create_subscription(DiagnosticArray, "/diagnostics",
                                      self._keep("diagnostics"), 50)
        self.pub = self.node.create_publisher(PoseStamped, f"{prefix}/foot_pose", pose_qos)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)

    def _keep(self, topic):
        return lambda msg: self.got[topic].append(msg)

    def spin_until(self, condition, timeout: float = 10.0) -> bool:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if condition():
                return True
            self.executor.spin_once(timeout_sec=0.01)
        return condition()

    def spin_for(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.01)

    def handshake(self, msg: PoseStamped, timeout: float = 20.0) -> None:
        """Publish the first pose until the node answers (graph matching alone loses messages)."""
        end = time.monotonic() + timeout
        while time.monotonic() < end and not self.got["wrench"]:
            self.pub.publish(msg)
            self.spin_until(lambda: bool(self.got["wrench"]), 0.1)
        if not self.got["wrench"]:
            raise TimeoutError(f"no answer on {self.prefix}/wrench")
        # let the answers to repeated handshake poses drain, then start from a clean slate
        self.spin_for(0.3)
        self.clear()

    def clear(self) -> None:
        for key in self.got:
            if key not in self.LATCHED_TOPICS:
                self.got[key] = []

    def step(self, msg: PoseStamped, timeout: float = 10.0, centerline: bool = False):
        """Publish one pose and wait for its answers (and its centerline, if asked)."""
        stamp = stamp_of(msg)
        n_phase = len(self.got["phase"])
        self.pub.publish(msg)
        ok = self.spin_until(
            lambda: any(stamp_of(m) == stamp for m in self.got["wrench"][-3:])
            and any(stamp_of(m) == stamp for m in self.got["contact_force"][-3:])
            and len(self.got["phase"]) > n_phase
            and len(self.got["contact_force_magnitude"]) > n_phase
            and (not centerline or any(stamp_of(m) == stamp for m in self.got["centerline"][-3:])),
            timeout,
        )
        if not ok:
            raise TimeoutError(f"no answer to the pose stamped {stamp}")
        return next(m for m in reversed(self.got["wrench"]) if stamp_of(m) == stamp)

    def expect_no_answer(self, msg: PoseStamped, wait: float = 0.4) -> None:
        stamp = stamp_of(msg)
        self.pub.publish(msg)
        self.spin_for(wait)
        assert not any(stamp_of(m) == stamp
                       for m in self.got["wrench"]), "a dropped pose was answered"

    def diagnostics_value(self, key: str, after: float = 0.0) -> str:
        """Return ``key`` of our node's next /diagnostics status after ``after`` (monotonic)."""
        start = len(self.got["diagnostics"])
        self.spin_until(lambda: len(self.got["diagnostics"]) > start, 10.0)
        for array in reversed(self.got["diagnostics"]):
            for status in array.status:
                if status.hardware_id == self.prefix:
                    return {kv.key: kv.value for kv in status.values}[key]
        raise KeyError(key)

    def destroy(self) -> None:
        self.executor.remove_node(self.node)
        self.node.destroy_node()
