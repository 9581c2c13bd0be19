"""
The rat's pad in the scenes of the benchmarks, for the tests of the trackers.

bench/bench_array.py's peg (PEG, HEAD, WHISK): RB1 touches the peg at s ~ 0.74 as it whisks,
its contact slides out to ~ 0.82 as the load grows, it snaps off and touches again.
bench/soak_array.py's ``pegs`` scene (SOAK_PEGS, soak_head): two tilted pegs and a ball, the
head wandering a few mm and turning +-3 deg.
"""

import math

from vibrissa_ros.core.arrays import WhiskerArray
from vibrissa_ros.core.arrays.rat import rat_array
from vibrissa_ros.core.arrays.tracker import ArrayTracker
from vibrissa_ros.core.arrays.whisking import CosineWhisk
from vibrissa_ros.core.rod3d import BasePose, Cylinder, Scene3D, Sphere

PEG = Cylinder((0.03, -0.016, 0.0), (0, 0, 1), 0.0015, "peg")
HEAD = BasePose((0.0, 0.0, 0.0))
WHISK = CosineWhisk(8.0, -math.radians(20.0), math.radians(20.0))
SOAK_PEGS = Scene3D((Cylinder((0.025, -0.012, 0.0), (0, 0.2, 1), 0.002, "peg_right"),
                     Cylinder((-0.028, -0.018, 0.0), (0.1, 0, 1), 0.001, "peg_left"),
                     Sphere((0.0, 0.045, -0.005), 0.006, "ball")))


def soak_head(t):
    """Return the soak's head pose at t [s]: a slow wander of a few mm and a turn of +-3 deg."""
    turn = 0.05 * math.sin(t)
    return BasePose((0.004 * math.sin(2 * math.pi * 0.7 * t),
                     0.003 * math.sin(2 * math.pi * 0.4 * t),
                     0.002 * math.sin(2 * math.pi * 0.9 * t)),
                    (math.cos(turn), 0.0, 0.0, math.sin(turn)))


def rb1_whisk(ticks):
    """Return RB1's base poses over ``ticks`` ticks of 1 ms (ticks + 1), its obstacles, shape."""
    array = WhiskerArray((rat_array("right")["RB1"],), "RB1")
    tracker = ArrayTracker(array, Scene3D((PEG,)), HEAD, WHISK.angle(0.0))
    rod = tracker.tracker("RB1")
    poses = [tracker.whisker_poses(HEAD, WHISK.angle(k * 1e-3))[0] for k in range(ticks + 1)]
    return poses, rod.obstacles, rod.shape
