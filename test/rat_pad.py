"""
The right pad's peg scene of bench/bench_array.py, for the tests of one whisker's tracker.

RB1 touches the peg at s ~ 0.74 as it whisks, its contact slides out to ~ 0.82 as the load
grows, it snaps off and touches again.
"""

import math

from vibrissa_ros.core.arrays import WhiskerArray
from vibrissa_ros.core.arrays.rat import rat_array
from vibrissa_ros.core.arrays.tracker import ArrayTracker
from vibrissa_ros.core.arrays.whisking import CosineWhisk
from vibrissa_ros.core.rod3d import BasePose, Cylinder, Scene3D

PEG = Cylinder((0.03, -0.016, 0.0), (0, 0, 1), 0.0015, "peg")
HEAD = BasePose((0.0, 0.0, 0.0))
WHISK = CosineWhisk(8.0, -math.radians(20.0), math.radians(20.0))


def rb1_whisk(ticks):
    """Return RB1's base poses over ``ticks`` ticks of 1 ms (ticks + 1), its obstacles, shape."""
    array = WhiskerArray((rat_array("right")["RB1"],), "RB1")
    tracker = ArrayTracker(array, Scene3D((PEG,)), HEAD, WHISK.angle(0.0))
    rod = tracker.tracker("RB1")
    poses = [tracker.whisker_poses(HEAD, WHISK.angle(k * 1e-3))[0] for k in range(ticks + 1)]
    return poses, rod.obstacles, rod.shape
