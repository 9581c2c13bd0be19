import csv
import math
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))  # test helpers (ros_harness)

DATA = Path(__file__).parent / "data"


def read_reference(name="elastica_parabola_p0_0.3.csv"):
    """Read a reference scan: rows (dicts of floats, NaN for empty), '# event:' header records."""
    path = DATA / name
    events = []
    lines = []
    with open(path) as stream:
        for line in stream:
            if line.startswith("# event:"):
                fields = dict(item.split("=", 1) for item in line.split()[3:])
                events.append((line.split()[2], float(fields["x0"]), float(fields["alpha"])))
            elif not line.startswith("#"):
                lines.append(line)
    reader = csv.DictReader(lines)
    rows = [{k: (float(v) if v not in ("", "nan") else math.nan) for k, v in row.items()}
            for row in reader]
    return rows, events


@pytest.fixture(scope="session")
def reference_scan():
    return read_reference()


@pytest.fixture(scope="session")
def ros_domain(tmp_path_factory):
    """Reserve a ROS_DOMAIN_ID for this test session, set for this process and its children."""
    import os

    from domain_coordinator import domain_id

    keys = ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_LOG_DIR",
            "ROS_PYTHON_CHECK_FIELDS")
    saved = {k: os.environ.get(k) for k in keys}
    with domain_id() as domain:
        os.environ["ROS_DOMAIN_ID"] = str(domain)
        os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
        os.environ["ROS_LOG_DIR"] = str(tmp_path_factory.mktemp("roslog"))
        os.environ["ROS_PYTHON_CHECK_FIELDS"] = "1"
        yield domain
    for key, value in saved.items():
        if value is None:
            os.environ.pop(key, None)
        else:
            os.environ[key] = value


@pytest.fixture(scope="session")
def ros_env(ros_domain):
    import os

    from ros_harness import ros_env as make_env

    return make_env(ros_domain, os.environ["ROS_LOG_DIR"])


@pytest.fixture(scope="session")
def installed(tmp_path_factory, ros_env):
    """Build the package with ``colcon build`` (the CI build check) into a temporary workspace."""
    from ros_harness import colcon_build

    from vibrissa_ros.core.rod3d.model import warm_up

    # the 3D whisker's compiled kernels, into numba's cache that the installed copy shares: a
    # node under test then loads them (~0.2 s) instead of compiling them while it is probed
    warm_up()
    return colcon_build(tmp_path_factory.mktemp("ws"), ros_env)


@pytest.fixture(scope="session")
def rcl_context(ros_domain):
    import rclpy

    context = rclpy.Context()
    rclpy.init(context=context)
    yield context
    rclpy.try_shutdown(context=context)
