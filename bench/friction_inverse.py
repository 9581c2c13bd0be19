"""
How much Coulomb friction biases the frictionless contour estimate (issue 7's inverse), vs mu.

A uniform straight whisker sweeps a circle profile (p0 = 0.5, R = 1) back and forth with the
scene tracker at several friction coefficients; at every pose with one contact the frictionless
inverse (``core.inverse.estimate_contact``, the sensor's fx, fy, m0 only) estimates the contact
point and the profile's slope there. Printed per mu: the median and largest error of the
estimated contact point [L] and slope [deg], with and without the correction that knowing mu
allows for a slipping contact (the force leans by the friction angle atan(mu) against the slip,
whose direction the motion gives); a sticking contact's force may lean anywhere inside the
cone, so knowing mu only bounds its slope error by atan(mu).

    python bench/friction_inverse.py
"""

from __future__ import annotations

import math
import os
import sys

import numpy as np

# the checkout's package, for a run from bench/: the imports below must follow (E402)
sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

from vibrissa_ros.core.exact.inverse import estimate_contact  # noqa: E402
from vibrissa_ros.core.scan import run_scene  # noqa: E402
from vibrissa_ros.scan.scene_file import load_scene  # noqa: E402

SCENE = "obstacles:\n  - {type: circle, p0: 0.5, R: 1.0}\n"


def main() -> int:
    scene = load_scene(SCENE)
    grid = np.concatenate((np.linspace(1.2, -1.1, 231), np.linspace(-1.1, 1.2, 231)[1:]))
    print("mu    poses  stick   point error [L]        slope error [deg]      "
          "slope error, mu known [deg]")
    print("                     median     max         median    max          "
          "median    max (slipping only)")
    for mu in (0.0, 0.1, 0.2, 0.3, 0.48):
        result = run_scene(list(scene), [float(x) for x in grid], friction=[mu])
        point, slope, fixed, stick = [], [], [], 0
        for st in result.states:
            if len(st.contacts) != 1:
                continue
            c = st.contacts[0]
            est = estimate_contact(st.pose, st.fx, st.fy, st.m0)
            if est is None:
                continue
            # the obstacle's tangent slope at the contact: the force's direction without T
            true_alpha = math.atan2(st.fx, -st.fy) - math.atan2(c.T, c.N)
            point.append(math.hypot(est.contact[0] - c.x, est.contact[1] - c.y))
            slope.append(abs(math.degrees(math.remainder(est.alpha - true_alpha, 2 * math.pi))))
            if c.state == "slip":
                # knowing mu and the slip direction: T = -sign * mu N, the force leans by atan(mu)
                lean = math.copysign(math.atan(mu), c.T) if c.T else 0.0
                corrected = est.alpha - lean
                fixed.append(abs(math.degrees(math.remainder(corrected - true_alpha,
                                                             2 * math.pi))))
            else:
                stick += 1
        print(f"{mu:<5} {len(point):5d}  {stick:5d}   {np.median(point):.2e}  {max(point):.2e}"
              f"     {np.median(slope):7.3f}  {max(slope):7.3f}      "
              f"{np.median(fixed) if fixed else 0.0:.1e}  {max(fixed) if fixed else 0.0:.1e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
