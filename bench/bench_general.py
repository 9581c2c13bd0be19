"""
The general (tapered, curved) whisker solver: convergence study and speed, with baselines in-run.

1. Convergence: error of the Chebyshev collocation vs the number of points n, (a) against the
   closed forms (uniform straight whisker, tip and tangential contact up to large forces), (b) for
   a rat-like whisker (taper 1/15, curved) against an n = 96 reference.
2. Speed: a rat-like whisker (taper 1/15, kappa0 = 1 + 0.5 s) swept past a peg in small steps
   (translation 1e-4 L per pose, then whisking 2e-5 rad per pose), one QuasistaticTracker.step per
   pose, timed one by one; the exact closed forms on the paper's parabola in the same run; then the
   independent DOP853 shooting solver on a sample of the same contact poses (warm-started from the
   previous pose's solution, as the tracker is), the median speed ratio and the largest difference.

3. Published mechanics: Solomon & Hartmann's small-angle stiffness and Hires et al.'s slip-off
   angles.

Run: python bench/bench_general.py [--poses 4000] [--sample 20]
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import time

import numpy as np

from vibrissa_ros.core import (FootPose, GeneralWhiskerModel, Parabola, Peg, Phase,
                               QuasistaticTracker, WhiskerShape)
from vibrissa_ros.core.errors import VibrissaError
from vibrissa_ros.core.checks.general_shooting import ShotState, shoot
from vibrissa_ros.core.exact.models import ElasticaModel

POINTS = (8, 12, 16, 20, 24, 32, 40, 48)


def convergence():
    em = ElasticaModel()
    print("convergence (a): max |error| of the contact point, f and m0 vs the closed forms")
    cases = [(Phase.TIP, (0.4, 0.3)), (Phase.TIP, (-0.3, 1.4)), (Phase.TANGENTIAL, (0.3, 0.5)),
             (Phase.TANGENTIAL, (0.6, 0.6))]
    header = "  n   " + "  ".join(f"{'tip' if p == Phase.TIP else 'tan'} "
                                  f"f={em.contact_quantities(p, z)[0]:<6.3g}"
                                  for p, z in cases)
    print(header)
    for n in POINTS:
        row = []
        for phase, z in cases:
            f, m0, s1, _, _ = em.contact_quantities(phase, z)
            P = em.load_point(phase, z)[:2]
            gm = GeneralWhiskerModel(n=n)
            zg = (z[0], s1 if phase == Phase.TANGENTIAL else z[1])
            try:
                gm.seed(phase, zg, f)
                Q = gm.load_point(phase, zg)[:2]
                g = gm.contact_quantities(phase, zg)
                row.append(max(abs(P[0] - Q[0]), abs(P[1] - Q[1]), abs(f - g[0]), abs(m0 - g[1])))
            except (VibrissaError, ValueError):
                row.append(math.nan)  # no solution found at this resolution
        print(f"  {n:<4d}" + "  ".join(f"{e:12.1e}" for e in row))
    print("convergence (b): rat-like whisker (taper 1/15, kappa0 = 1 - 0.5 s) vs n = 96")
    shape = WhiskerShape(1 / 15, 1.0, -0.5)
    cases = [(Phase.TIP, (1.0, 0.5)), (Phase.TIP, (1.2, 1.5)), (Phase.TANGENTIAL, (1.4, 0.7))]
    refs = []
    for phase, z in cases:
        ref = GeneralWhiskerModel(shape, n=96)
        refs.append((np.array(ref.load_point(phase, z)[:2]), ref.solve(phase, *z).f))
    print("  n   " + "  ".join(f"{'tip' if p == Phase.TIP else 'tan'} f={r[1]:<6.3g}"
                               for (p, _), r in zip(cases, refs)))
    for n in POINTS:
        row = []
        for (phase, z), (P, f) in zip(cases, refs):
            gm = GeneralWhiskerModel(shape, n=n)
            try:
                gm.seed(phase, z, f)
                Q = np.array(gm.load_point(phase, z)[:2])
                row.append(max(np.max(np.abs(P - Q)), abs(gm.solve(phase, *z).f - f)))
            except (VibrissaError, ValueError):
                row.append(math.nan)
        print(f"  {n:<4d}" + "  ".join(f"{e:12.1e}" for e in row))


def _timed(tracker, poses):
    times = np.empty(len(poses))
    states = []
    for i, pose in enumerate(poses):
        t0 = time.perf_counter_ns()
        states.append(tracker.step(pose).state)
        times[i] = time.perf_counter_ns() - t0
    return times, states


def speed(n_poses: int, sample: int):
    shape = WhiskerShape(1 / 15, 1.0, 0.5)
    peg = Peg(0.0, 0.6, 0.05)
    model = GeneralWhiskerModel(shape)
    # translation: from touch through the slide along the whisker; then whisking about a fixed foot
    tracker = QuasistaticTracker(peg, FootPose(1.0, 0.0), model=model)
    tracker.step(FootPose(0.1, 0.0))
    translate = [FootPose(0.1 - 1e-4 * (i + 1), 0.0) for i in range(n_poses)]
    t_tr, s_tr = _timed(tracker, translate)
    start = FootPose(0.3, 0.0, math.pi / 2 + 0.6)
    probe = QuasistaticTracker(peg, start, model=GeneralWhiskerModel(shape))
    touch = [e for e in probe.step(FootPose(0.3, 0.0, math.pi / 2 - 0.6)).events
             if e.kind == "touch"][0]
    h0 = touch.pose.heading + 0.02  # whisk from just before the touch: half free, half in contact
    whisk_tracker = QuasistaticTracker(peg, start, model=GeneralWhiskerModel(shape))
    whisk_tracker.step(FootPose(0.3, 0.0, h0))
    whisk = [FootPose(0.3, 0.0, h0 - 2e-5 * (i + 1)) for i in range(n_poses)]
    t_wh, s_wh = _timed(whisk_tracker, whisk)
    for name, t, s in (("translating", t_tr, s_tr), ("whisking", t_wh, s_wh)):
        contact = sum(1 for st in s if st.phase != Phase.FREE)
        print(f"general ({name}, taper 1/15, kappa0 = 1 + 0.5 s, peg r = 0.05): {len(t)} poses "
              f"({contact} in contact), median {np.median(t) / 1e3:.0f} us = "
              f"{1e9 / np.median(t):,.0f} poses/s, mean {1e9 / np.mean(t):,.0f} poses/s, p99 "
              f"{np.percentile(t, 99) / 1e3:.0f} us")
        phases = np.array([int(st.phase) for st in s])
        print("    " + ", ".join(f"phase {ph}: median {np.median(t[phases == ph]) / 1e3:.0f} us"
                                 for ph in (0, 1, 2) if np.any(phases == ph)))
    # the exact closed forms, same run
    exact = QuasistaticTracker(Parabola(0.3), 2.0)
    exact.step(0.0)
    t_ex, _ = _timed(exact, [FootPose(-1e-4 * (i + 1)) for i in range(n_poses)])
    print("exact closed forms (parabola p0 = 0.3, phase 1 and 2): median "
          f"{np.median(t_ex) / 1e3:.1f} us = {1e9 / np.median(t_ex):,.0f} poses/s")
    # the shooting baseline on a sample of the contact poses, warm-started from the previous pose
    shoot_t, core_t, worst = [], [], 0.0
    all_states = [(t_tr, s_tr), (t_wh, s_wh)]
    for times, states in all_states:
        idx = [i for i in range(1, len(states)) if states[i].phase != Phase.FREE
               and states[i - 1].phase == states[i].phase]
        if not idx:
            continue
        for i in np.array(idx)[np.linspace(0, len(idx) - 1, max(sample // 2, 1)).astype(int)]:
            st, prev = states[i], states[i - 1]
            guess = ShotState(prev.phase, prev.m0, prev.f, prev.alpha, prev.s1)
            th = st.tip_slope - float(shape.intrinsic_slope(1.0) - shape.intrinsic_slope(st.s1))
            right = st.phase == Phase.TANGENTIAL and math.cos(th - st.alpha) < 0.0
            t0 = time.perf_counter_ns()
            shot = shoot(shape, peg, st.pose, st.phase, guess, right)
            shoot_t.append(time.perf_counter_ns() - t0)
            core_t.append(times[i])
            worst = max(worst, abs(shot.f - st.f) / max(1.0, st.f),
                        abs(shot.m0 - st.m0) / max(1.0, abs(st.m0)), abs(shot.alpha - st.alpha),
                        abs(shot.s1 - st.s1))
    ms, mc = statistics.median(shoot_t), statistics.median(core_t)
    print("shooting baseline (solve_ivp DOP853 rtol 1e-13 + hybr, warm-started): "
          f"{len(shoot_t)} poses, median {ms / 1e6:.1f} ms")
    print(f"collocation on the same poses: median {mc / 1e3:.0f} us; speed ratio {ms / mc:,.0f}x; "
          f"largest difference {worst:.1e}")


def published():
    """Compare with Solomon & Hartmann 2006 (rotational stiffness) and Hires et al. 2013."""
    print("rotational stiffness dM/dtheta at 1e-5 rad against a point at radial distance d "
          "(units EI_b/L):")
    print("  taper   d     collocation         linear theory d^2/int (d-s)^2/B")
    for taper in (1.0, 1 / 15):
        shape = WhiskerShape(taper)
        for d in (0.3, 0.6, 0.9):
            tracker = QuasistaticTracker(Peg(0.0, d, 0.0), FootPose(0.0, 0.0, math.pi / 2 + 0.05),
                                         model=GeneralWhiskerModel(shape))
            tracker.step(FootPose(0.0, 0.0, math.pi / 2))
            m0 = tracker.step(FootPose(0.0, 0.0, math.pi / 2 - 1e-5)).state.m0
            print(f"  {taper:<6.4g}  {d:<4}  {abs(m0) / 1e-5:<18.12g}  "
                  f"{d * d / shape.linear_compliance(d):.12g}")
    print("slip-off push angle [deg] of a straight whisker whisked against a point pole at "
          "radial distance d")
    print("  (none: no slip-off up to 86 deg)")
    print("  d     " + "  ".join(f"taper {t:<6.4g}" for t in (1.0, 0.2, 1 / 15)))
    for d in (0.3, 0.5, 0.7, 0.9):
        row = []
        for taper in (1.0, 0.2, 1 / 15):
            tracker = QuasistaticTracker(Peg(0.0, d, 0.0), FootPose(0.0, 0.0, math.pi / 2 + 0.05),
                                         model=GeneralWhiskerModel(WhiskerShape(taper)))
            events = tracker.step(FootPose(0.0, 0.0, math.pi / 2 - 1.5)).events
            snaps = [e for e in events if e.kind == "snap"]
            row.append(f"{math.degrees(math.pi / 2 - snaps[0].pose.heading):<12.2f}" if snaps
                       else f"{'none':<12}")
        print(f"  {d:<4}  " + "  ".join(row))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=4000)
    parser.add_argument("--sample", type=int, default=20)
    parser.add_argument("--skip-convergence", action="store_true")
    args = parser.parse_args(argv)
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})  # one core
    if not args.skip_convergence:
        convergence()
        published()
    speed(args.poses, args.sample)


if __name__ == "__main__":
    main()
