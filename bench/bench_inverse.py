"""
Accuracy of the contour reconstruction from the base wrench (the inverse problem), measured.

1. Noise-free: random convex profiles (random families, shapes, placements), back-and-forth scans;
   the largest distance between an estimated and the true contact point, and the phase agreement.
2. Noisy: Gaussian noise with sigma = 1% of the scan's peak |f| on fx and fy and 1% of the peak
   |m0| on m0; readings with f < 3 sigma are taken as no contact. For the paper's examples: the
   error distribution (median, 95th percentile, max, in L) of the estimates' distance to the true
   profile and to the true contact point, which part of the profile each phase recovers, and the
   fraction of the profile within the whisker's reach recovered by one sweep direction and by both.

Run: python bench/bench_inverse.py [--seeds 20]
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
from scipy.optimize import minimize_scalar

# test/, for the tests' generator: the imports below must follow (E402)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "test"))
from test_inverse import random_profiles  # noqa: E402  (the same generator the tests use)

from vibrissa_ros.core import Catenary, Parabola, TwoCircles, run_scan, scan_grid  # noqa: E402
from vibrissa_ros.core.exact.inverse import covered_intervals, estimate_contact  # noqa: E402
from vibrissa_ros.scan.plots import direction_segments  # noqa: E402


def distance_to_profile(profile, x, y):
    a0 = profile.alpha_at_x(min(max(x, profile.xi(profile.alpha_min + 1e-3)),
                                profile.xi(profile.alpha_max - 1e-3)))
    res = minimize_scalar(lambda a: math.dist(profile.point(a), (x, y)),
                          bracket=(a0 - 0.05, a0 + 0.05), tol=1e-12)
    return res.fun


def noise_free(seeds):
    worst, wrong_phase, n = 0.0, 0, 0
    for profile in random_profiles(seeds, 40):
        for st in run_scan(profile, scan_grid(3.0, -3.0, 0.01, back=True)).states:
            if st.phase:
                est = estimate_contact(st.pose, st.fx, st.fy, st.m0)
                worst = max(worst, math.dist(est.contact, st.contact))
                wrong_phase += est.phase != st.phase
                n += 1
    print(f"noise-free: {n} contact states on 40 random profiles: largest error {worst:.2e} L, "
          f"phase disagreements {wrong_phase}")


def noisy(name, profile, seed, x_max):
    scan = run_scan(profile, scan_grid(x_max, -x_max, 0.002, back=True))
    states = scan.states
    f_peak = max(s.f for s in states)
    m_peak = max(abs(s.m0) for s in states)
    sf, sm = 0.01 * f_peak, 0.01 * m_peak
    rng = np.random.default_rng(seed)
    a_left, a_right = profile.alpha_at_height(1.0, -1), profile.alpha_at_height(1.0, +1)
    reach = (profile.xi(a_left), profile.xi(a_right))
    per_direction = []
    to_profile, to_contact = [], []
    phase_x = {1: [], 2: []}
    for d, (a, b) in enumerate(direction_segments(states)):
        xs = []
        for st in states[a:b]:
            fx, fy, m0 = (st.fx + rng.normal(0, sf), st.fy + rng.normal(0, sf),
                          st.m0 + rng.normal(0, sm))
            est = estimate_contact(st.pose, fx, fy, m0, min_force=3 * sf)
            if est is None:
                continue
            to_profile.append(distance_to_profile(profile, *est.contact))
            if st.contact is not None:
                to_contact.append(math.dist(est.contact, st.contact))
            xs.append(est.contact[0])
            phase_x[int(est.phase)].append(est.contact[0])
        per_direction.append(xs)

    def fraction(points):
        inside = [x for x in points if reach[0] <= x <= reach[1]]
        covered = sum(b - a for a, b in covered_intervals(inside, 0.02))
        return covered / (reach[1] - reach[0])

    tp, tc = np.array(to_profile), np.array(to_contact)
    print(f"\n{name}: sigma_f = {sf:.4f}, sigma_m = {sm:.4f} (1% of peak f {f_peak:.3f}, peak "
          f"|m0| {m_peak:.3f}); {len(tp)} estimates")
    print(f"  distance to the true profile [L]: median {np.median(tp):.2e}, p95 "
          f"{np.percentile(tp, 95):.2e}, max {tp.max():.2e}")
    print(f"  distance to the true contact [L]: median {np.median(tc):.2e}, p95 "
          f"{np.percentile(tc, 95):.2e}, max {tc.max():.2e}")
    for ph, label in ((1, "tangential"), (2, "tip")):
        spans = covered_intervals([x for x in phase_x[ph]], 0.02)
        text = ", ".join(f"[{a:+.2f}, {b:+.2f}]" for a, b in spans[:6]) or "none"
        print(f"  x recovered in phase {ph} ({label}): {text}")
    print(f"  profile within reach x in [{reach[0]:.3f}, {reach[1]:.3f}]: recovered "
          f"{fraction(per_direction[0]):.1%} by the first sweep direction, "
          f"{fraction(per_direction[0] + per_direction[1]):.1%} by both")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=11)
    args = parser.parse_args(argv)
    noise_free(args.seed)
    for name, prof, x_max in (("parabola p0 = 0.3", Parabola(0.3), 2.0),
                              ("catenary p0 = 0.5, c = 0.6", Catenary(0.5, 0.6), 1.5),
                              ("two circles p0 = 0.4, R = 0.8 | 1.6",
                               TwoCircles(0.4, 0.8, 1.6), 1.8)):
        noisy(name, prof, args.seed, x_max)


if __name__ == "__main__":
    main()
