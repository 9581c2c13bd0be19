#!/usr/bin/env python3
"""
Compare two checkouts' whisker-array ticks in lockstep, tick by tick.

This machine's speed varies by up to ~2x from one minute to the next (other guests take its
cores), so two benchmark runs one after the other compare poorly. Here each checkout runs the
array of ``bench_array.py`` (the right or both pads whisking at 8 Hz against the peg) in its own
process, and the two take turns tick by tick, in alternating order: both see the same machine
at nearly the same moment, and the ratio of their tick times is what is reported (per tick, and
of the medians and means), with each one's median, mean and p99 and its solver's evaluations.

Usage::

    OPENBLAS_NUM_THREADS=1 python bench/ab_array.py OLD_TREE NEW_TREE [--ticks 500] [--side right]

OLD_TREE and NEW_TREE are source trees (e.g. ``git worktree add /tmp/old <commit>`` and this
one); each is put first on the child's ``PYTHONPATH``. Both processes stay resident, so each tick
also finds the caches disturbed by the other one's: the times are higher than
``bench_array.py``'s, and only their ratio is meant to compare.
"""

import argparse
import os
import subprocess
import sys
import time

import numpy as np


def child(tree: str, side: str) -> None:
    """Run one checkout's array: read tick numbers on stdin, answer each tick's time."""
    sys.path.insert(0, os.path.join(tree, "bench"))
    import bench_array
    from vibrissa_ros.core.arrays import ArrayTracker
    from vibrissa_ros.core.rod3d import _jit

    _jit.warm_up()
    array, scene, whisk = bench_array._setup(side)
    tracker = ArrayTracker(array, scene, bench_array.HEAD, whisk.angle(0.0))
    print("ready", flush=True)
    for line in sys.stdin:
        k = int(line)
        t0 = time.perf_counter()
        tracker.step(bench_array.HEAD, whisk.angle(k * 1e-3))
        elapsed = time.perf_counter() - t0
        evaluations = sum(tracker.tracker(n).solver.evaluations for n in tracker.names)
        print(repr(elapsed), evaluations, flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("trees", nargs=2, help="the two source trees, A then B")
    parser.add_argument("--ticks", type=int, default=500, help="1-ms ticks (default 500)")
    parser.add_argument("--side", choices=("right", "left", "both"), default="right")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.trees[0], args.side)
        return
    procs = []
    for tree in args.trees:
        tree = os.path.abspath(tree)
        env = dict(os.environ, PYTHONPATH=tree, OPENBLAS_NUM_THREADS="1")
        proc = subprocess.Popen(
            [sys.executable, os.path.abspath(__file__), tree, tree, "--child", "--side",
             args.side], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env,
            cwd=os.path.dirname(tree) or "/")
        if proc.stdout.readline().strip() != "ready":
            raise SystemExit(f"{tree}: the array did not start")
        procs.append(proc)
    times, evaluations = ([], []), [0, 0]
    for k in range(1, args.ticks + 1):
        for i in ((0, 1) if k % 2 else (1, 0)):
            procs[i].stdin.write(f"{k}\n")
            procs[i].stdin.flush()
            elapsed, count = procs[i].stdout.readline().split()
            times[i].append(float(elapsed) * 1e3)
            evaluations[i] = int(count)
    for proc in procs:
        proc.stdin.close()
        proc.wait()
    a, b = (np.array(t) for t in times)
    print(f"\n== {args.side} side(s), {args.ticks} ticks of 1 ms in lockstep")
    for name, tree, t, ev in (("A", args.trees[0], a, evaluations[0]),
                              ("B", args.trees[1], b, evaluations[1])):
        print(f"   {name} {tree}: tick median {np.median(t):.3f} ms, mean {t.mean():.3f}, "
              f"p99 {np.percentile(t, 99):.2f}; solver evaluations {ev:,}")
    print(f"   B / A: per-tick ratio median {np.median(b / a):.3f}; medians "
          f"{np.median(b) / np.median(a):.3f}; means {b.mean() / a.mean():.3f}")


if __name__ == "__main__":
    main()
