"""
Speed of the mechanics core, with the independent shooting solver as the in-run baseline.

Forward scan of the parabola p0 = 0.3 from x0 = 2 to -2 at step 1e-4 (40,001 poses), one
QuasistaticTracker.step per pose, timed one by one; then the shooting solver on a sample of the
same contact poses (each warm-started from its own solution 1e-4 away, as the tracker is), and the
speed ratio of the medians. Run: python bench/bench_core.py [--step 1e-4] [--sample 25]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

from vibrissa_ros.core import Parabola, QuasistaticTracker, scan_grid
from vibrissa_ros.core.checks.shooting import ShootingSolver, ShootingState


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--step", type=float, default=1e-4)
    parser.add_argument("--sample", type=int, default=25)
    args = parser.parse_args(argv)
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})  # one core

    profile = Parabola(0.3)
    grid = scan_grid(2.0, -2.0, args.step)
    tracker = QuasistaticTracker(profile, float(grid[0]))
    times = np.empty(len(grid) - 1)
    states = []
    wall0 = time.perf_counter()
    for i, x0 in enumerate(grid[1:]):
        t0 = time.perf_counter_ns()
        st = tracker.step(float(x0)).state
        times[i] = time.perf_counter_ns() - t0
        states.append(st)
    wall = time.perf_counter() - wall0
    phases = np.array([int(s.phase) for s in states])
    print(f"core: {len(times)} poses in {wall:.3f} s = {len(times) / wall:,.0f} "
          "poses/s (one core)")
    print(f"core: median step {np.median(times) / 1e3:.1f} us, p99 "
          f"{np.percentile(times, 99) / 1e3:.1f} us, max {times.max() / 1e3:.0f} us")
    for ph in (0, 1, 2):
        sel = times[phases == ph]
        if len(sel):
            print(f"core: phase {ph}: {len(sel)} poses, median {np.median(sel) / 1e3:.1f} us")

    # the independent solver on a sample of the contact poses
    contact = np.flatnonzero(phases > 0)
    pick = contact[np.linspace(5, len(contact) - 5, args.sample).astype(int)]
    solver = ShootingSolver(profile)
    shoot_times, core_times, worst = [], [], 0.0
    for i in pick:
        st, prev = states[i], states[i - 1]
        if prev.phase != st.phase:
            continue
        seed_state = ShootingState(prev.x0, int(prev.phase), prev.m0, prev.f, prev.alpha, prev.s1,
                                   prev.tip_slope)
        seed = ((seed_state.kappa0, seed_state.f, seed_state.alpha)
                + ((seed_state.s1,) if st.phase == 1 else ()))
        t0 = time.perf_counter_ns()
        sol = solver.solve(st.x0, int(st.phase), seed)
        shoot_times.append(time.perf_counter_ns() - t0)
        core_times.append(times[i])
        worst = max(worst, abs(sol.f - st.f), abs(sol.m0 - st.m0), abs(sol.alpha - st.alpha),
                    abs(sol.s1 - st.s1))
    ms, mc = statistics.median(shoot_times), statistics.median(core_times)
    print(f"shooting (solve_ivp DOP853 rtol 1e-13 + hybr): {len(shoot_times)} poses, median "
          f"{ms / 1e6:.1f} ms")
    print(f"core on the same poses: median {mc / 1e3:.1f} us; speed ratio {ms / mc:,.0f}x; "
          f"largest difference {worst:.1e}")


if __name__ == "__main__":
    main()
