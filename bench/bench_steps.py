"""
Cost of one tracker step on random foot paths: the worst case is what bounds the node's latency.

Random profiles of every family (sizes over 1e-2..1e2, random placements), both models, random
walks with big jumps, far poses (1e5, 1e6 L), rotations and reversals — the same kinds of paths the
property tests draw. Prints the evaluations (model and profile evaluations, the unit the tracker's
budget counts) and the wall time per step: median, p99 and the worst, and how the steps ended.

    python bench/bench_steps.py [--paths 200] [--steps 40] [--seed 0]
"""

import argparse
import math
import random
import statistics
import time
from collections import Counter

from vibrissa_ros.core import (
    Catenary,
    Circle,
    Ellipse,
    FootPose,
    Parabola,
    QuasistaticTracker,
    TrackerOptions,
    TwoCircles,
    VibrissaError,
)


def random_profile(rng):
    family = rng.choice(["parabola", "catenary", "circle", "two_circles", "ellipse"])
    p0 = rng.uniform(0.05, 0.95)

    def size():
        return 10 ** rng.uniform(-2, 2)

    if family == "parabola":
        prof = Parabola(p0, size())
    elif family == "catenary":
        prof = Catenary(p0, size())
    elif family == "circle":
        prof = Circle(p0, 1 - p0 + size())
    elif family == "two_circles":
        prof = TwoCircles(p0, 1 - p0 + size(), 1 - p0 + size())
    else:
        prof = Ellipse(p0, size(), 1 - p0 + size())
    if rng.random() < 0.5:
        prof = prof.placed(rng.uniform(-1, 1), rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5))
    return prof


def next_pose(rng, pose, rotate):
    r = rng.random()
    if r < 0.25:
        return FootPose(rng.uniform(-3, 3), rng.uniform(-0.5, 0.6),
                        rng.uniform(0, math.pi) if rotate else math.pi / 2)
    if r < 0.28:
        return FootPose(rng.choice([1e5, -1e5, 1e6]), 0.0, math.pi / 2)
    return FootPose(
        pose.x + rng.gauss(0, 0.2), pose.y + rng.gauss(0, 0.05),
        pose.heading + (rng.gauss(0, 0.2) if rotate else 0.0)
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--paths", type=int, default=200)
    parser.add_argument("--steps", type=int, default=40)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    evaluations, seconds, outcomes = [], [], Counter()
    worst = (0, 0.0, "")
    for k in range(args.paths):
        rng = random.Random(args.seed + k)
        prof = random_profile(rng)
        model = "rigid" if rng.random() < 0.2 else "elastica"
        rotate = rng.random() < 0.5
        pose = FootPose(5.0, 0.0, math.pi / 2)
        try:
            tracker = QuasistaticTracker(prof, pose, model=model)
        except VibrissaError:
            outcomes["start refused"] += 1
            continue
        for _ in range(args.steps):
            start, target = tracker.pose, next_pose(rng, tracker.pose, rotate)
            t0 = time.perf_counter()
            try:
                result = tracker.step(target)
                outcome, work = "state", result.evaluations
            except VibrissaError as exc:
                outcome, work = type(exc).__name__, tracker._work
            dt = time.perf_counter() - t0
            outcomes[outcome] += 1
            evaluations.append(work)
            seconds.append(dt)
            if work > worst[0]:
                worst = (work, dt, f"{prof.describe()} {model}: {start} -> {target}")
    evaluations.sort()
    seconds.sort()
    n = len(evaluations)

    def p99(xs):
        return xs[min(n - 1, int(0.99 * n))]

    print(f"{n} steps on {args.paths} random paths; budget {TrackerOptions().max_evaluations} "
          "evaluations per step")
    print(f"evaluations per step: median {statistics.median(evaluations):.0f}, p99 "
          f"{p99(evaluations)}, max {evaluations[-1]}")
    print(
        f"wall time per step:   median {statistics.median(seconds) * 1e3:.2f} ms, p99 "
        f"{p99(seconds) * 1e3:.1f} ms, max {seconds[-1] * 1e3:.1f} ms"
    )
    print(f"costliest step: {worst[0]} evaluations, {worst[1] * 1e3:.1f} ms: {worst[2]}")
    print("outcomes: " + ", ".join(f"{k} {v}" for k, v in outcomes.most_common()))


if __name__ == "__main__":
    main()
