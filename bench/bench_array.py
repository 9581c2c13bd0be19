"""
Speed of the whole whisker array (the rat's mystacial pad), whisking against a peg.

The array of ``config/rat_array.yaml`` (one side: 30 whiskers; both: 60), the head fixed, every
whisker whisking with the built-in cosine whisk (8 Hz, -20 deg to +20 deg about its rest
orientation, the rows' elevation and roll slopes), sampled at 1 kHz (one tick per millisecond),
against a vertical peg (radius 1.5 mm at x = 30 mm, y = -16 mm of the head frame, and its mirror
image for the left side) that the whiskers of columns 0-2 hit during protraction.

Printed per run: the tick time (median, p90, p99, max), ticks/s = 1 / median, the share of
ticks that meet 1 ms, the mean tick (1 ms over it: the share of real time a node keeps up
with), the number of whiskers in contact per tick (its distribution), the time of ticks by how
many whiskers are in contact, and the solver's work in evaluations (per tick, and the share of
the ticks with a snap, touch or release): counts that compare exactly between runs on a busy
machine, where times do not. Baseline in the same run, on the same ticks: every
whisker's own :class:`RodTracker` stepped in a plain loop (no clearance test), the cost the array
stepper is there to avoid. For the reference simulator, WHISKiT Physics needs about 15 ms of CPU
per whisker per 1-ms sample on this kind of machine (the figure of the reference sheet on the rat
array; one side: about 0.45 s per tick).

With ``--breakdown`` it also prints what the ticks nearest the median are made of: each
whisker's step timed and sorted into plain steps (in contact, no event) with one Jacobian
factorization or more, steps with an event and free steps, per tick, and the time outside
them.

With ``--plain [WHISKER ...]`` it prints instead what a plain step of one whisker in contact
costs (its own tracker fed its poses alone, the steps in contact without events: what a median
tick is made of), and its evaluations and factorizations per step.

With ``--points-tolerance T`` it steps two arrays in lockstep instead, tick by tick in
alternating order (the machine's speed varies from minute to minute; each tick of both sees it at
nearly the same moment): one at the default discretization tolerance (1e-11, exact to the
solver's convergence) and one at T (``ArrayTracker``'s ``points_tolerance``: fewer points per
segment). Printed: both runs' tick times and their ratios, their evaluations and factorizations,
the points per segment the whiskers in contact were solved on, and how far T's base forces and
moments lie from the default's (relative to the largest over the run) and whether every event
is the same.

Run: OPENBLAS_NUM_THREADS=1 python bench/bench_array.py [--cycles 2] [--side right|both]
     [--baseline-ticks 250] [--breakdown] [--plain [RB1 RC1 RD0] [--repeats 5]]
     [--points-tolerance 1e-9]
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import math  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from vibrissa_ros.core.arrays import ArrayTracker, CosineWhisk  # noqa: E402
from vibrissa_ros.core.errors import VibrissaError  # noqa: E402
from vibrissa_ros.core.rod3d import BasePose, Cylinder, RodTracker, Scene3D, _jit  # noqa: E402
from vibrissa_ros.scan.array_file import load_array  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
HEAD = BasePose((0.0, 0.0, 0.0))
#: WHISKiT Physics, CPU per whisker per 1-ms sample on this kind of machine [s]
WHISKIT_PER_WHISKER = 15e-3


def _setup(side: str):
    array = load_array(ROOT / "config" / "rat_array.yaml")
    if side != "both":
        array = array.side(side)
    pegs = [Cylinder((0.03, -0.016, 0.0), (0, 0, 1), 0.0015, "peg_right")]
    if side == "both":
        pegs.append(Cylinder((-0.03, -0.016, 0.0), (0, 0, 1), 0.0015, "peg_left"))
    elif side == "left":
        pegs = [Cylinder((-0.03, -0.016, 0.0), (0, 0, 1), 0.0015, "peg_left")]
    whisk = CosineWhisk(8.0, -math.radians(20.0), math.radians(20.0))
    return array, Scene3D(tuple(pegs)), whisk


def _evaluations(tracker) -> int:
    """Return the solver evaluations every whisker's tracker has spent so far."""
    return sum(tracker.tracker(name).solver.evaluations for name in tracker.names)


def _factorizations(tracker) -> int:
    """Return the Jacobian factorizations every whisker's tracker has spent so far."""
    return sum(tracker.tracker(name).solver.factorizations for name in tracker.names)


def _pct(values, q):
    return float(np.percentile(values, q)) * 1e3


def _time_steps(tracker, steps):
    """
    Time every whisker's tracker step, appending (kind, seconds) to ``steps``.

    Kinds: ``event`` (the step crossed an event), ``plain, 1 LU`` and ``plain, 2+ LU`` (in
    contact before and after, no event, by Jacobian factorizations), ``free`` (no contact).
    The wrappers are the trackers' own attributes: the array calls them as it calls step.
    """
    for name in tracker.names:
        rod = tracker.tracker(name)

        def timed(pose, rod=rod, step=rod.step):
            was, lus = bool(rod.state.contacts), rod.solver.factorizations
            t0 = time.perf_counter()
            result = step(pose)
            elapsed = time.perf_counter() - t0
            if result.events:
                kind = "event"
            elif was and result.state.contacts:
                kind = "plain, 1 LU" if rod.solver.factorizations - lus <= 1 else "plain, 2+ LU"
            else:
                kind = "free"
            steps.append((kind, elapsed))
            return result

        rod.step = timed


def _breakdown(times, per_tick) -> None:
    """Print what the ticks nearest the median are made of (the 20% nearest it)."""
    med = float(np.median(times))
    near = np.argsort(np.abs(times - med))[:max(1, len(times) // 5)]
    print(f"   the {near.size} ticks nearest the median ({med * 1e3:.3f} ms), by whisker step:")
    total = {}
    for i in near:
        for kind, seconds in per_tick[i]:
            total.setdefault(kind, []).append(seconds)
    for kind in ("plain, 1 LU", "plain, 2+ LU", "event", "free"):
        if kind in total:
            s = np.array(total[kind])
            print(f"     {kind:13s} {s.size / near.size:5.2f} a tick, median "
                  f"{np.median(s) * 1e6:5.0f} us, {s.sum() / near.size * 1e6:5.0f} us a tick")
    outside = [times[i] - sum(x for _, x in per_tick[i]) for i in near]
    print("     outside the whiskers' steps (frames, clearance, poses, rows): "
          f"{np.mean(outside) * 1e6:.0f} us a tick")


def run(side: str, cycles: float, baseline_ticks: int, dt: float = 1e-3,
        breakdown: bool = False) -> None:
    _jit.warm_up()  # as array_node does when it starts: no tick loads the compiled kernels
    array, scene, whisk = _setup(side)
    t0 = time.perf_counter()
    tracker = ArrayTracker(array, scene, HEAD, whisk.angle(0.0))
    setup = time.perf_counter() - t0
    ticks = int(round(cycles / whisk.frequency / dt))
    times, contacts, solved, errors, work, kinds, factorized = [], [], [], 0, [], [], []
    steps, per_tick = [], []
    if breakdown:
        _time_steps(tracker, steps)
    for k in range(1, ticks + 1):
        before, lus = _evaluations(tracker), _factorizations(tracker)
        steps.clear()
        t0 = time.perf_counter()
        step = tracker.step(HEAD, whisk.angle(k * dt))
        times.append(time.perf_counter() - t0)
        per_tick.append(list(steps))
        work.append(_evaluations(tracker) - before)
        factorized.append(_factorizations(tracker) - lus)
        kinds.append({e.kind for e in step.events})
        contacts.append(step.in_contact)
        solved.append(int(step.solved.sum()))
        errors += len(step.errors)
        for e in step.errors:
            print(f"   tick {k}: {e.whisker}: {e.message}")
    times, contacts, work = np.array(times), np.array(contacts), np.array(work)
    med = float(np.median(times))
    print(f"\n== {side} side(s): {len(array)} whiskers, {ticks} ticks of 1 ms "
          f"({cycles:g} whisk cycles at {whisk.frequency:g} Hz); set-up {setup:.2f} s")
    print(f"   tick: median {med * 1e3:.3f} ms, p90 {_pct(times, 90):.3f}, p99 "
          f"{_pct(times, 99):.3f}, max {times.max() * 1e3:.1f} ms -> {1.0 / med:,.0f} ticks/s; "
          f"{np.mean(times <= 1e-3) * 100:.0f}% of ticks within 1 ms; errors {errors}")
    print(f"   mean tick {times.mean() * 1e3:.3f} ms: {1e-3 / times.mean():.2f} x real time at "
          "1 kHz (what a node can sustain)")
    print(f"   whiskers in contact per tick: max {contacts.max()}, distribution "
          f"{dict(enumerate(np.bincount(contacts).tolist()))}; trackers stepped per tick: "
          f"median {np.median(solved):.0f}")
    for c in range(contacts.max() + 1):
        m = contacts == c
        if m.any():
            print(f"   {c} in contact: {m.sum():4d} ticks, median {np.median(times[m]) * 1e3:.3f} "
                  f"ms, p99 {_pct(times[m], 99):.3f} ms")
    # the solver's work: counts, not seconds, so runs on a busy machine compare exactly
    print(f"   solver evaluations (a residual, with or without its Jacobian): {work.sum():,} in "
          f"all, per tick median {np.median(work):.0f}, p99 {np.percentile(work, 99):.0f}; "
          f"Jacobian factorizations {sum(factorized):,} in all, per tick median "
          f"{np.median(factorized):.0f}")
    for kind in ("snap", "touch", "release", "tip", "tangential", "reset"):
        m = np.array([kind in ks for ks in kinds])
        if m.any():
            print(f"   ticks with a {kind}: {m.sum():3d}, {work[m].sum():,} evaluations "
                  f"({work[m].sum() / work.sum():.0%}), {times[m].sum():.2f} s "
                  f"({times[m].sum() / times.sum():.0%} of the time)")
    if breakdown:
        _breakdown(times, per_tick)
    whiskit = WHISKIT_PER_WHISKER * len(array)
    print(f"   WHISKiT Physics (15 ms CPU per whisker per sample): {whiskit * 1e3:.0f} ms per "
          f"tick, {whiskit / med:,.0f}x this median")
    if baseline_ticks <= 0:
        return
    # the baseline: every whisker's own tracker stepped on the same poses, no clearance test
    n = min(baseline_ticks, ticks)
    singles = [RodTracker(tracker._scenes[i], p, shape=array.rod(i).shape)
               for i, p in enumerate(tracker.whisker_poses(HEAD, whisk.angle(0.0)))]
    base, mine, failed = [], times[:n], 0
    for k in range(1, n + 1):
        poses = tracker.whisker_poses(HEAD, whisk.angle(k * dt))
        t0 = time.perf_counter()
        for single, pose in zip(singles, poses):
            try:
                single.step(pose)
            except VibrissaError:  # kept its state, as in the array
                failed += 1
        base.append(time.perf_counter() - t0)
    base = np.array(base)
    print(f"   baseline (every whisker's tracker stepped, same {n} ticks): median "
          f"{np.median(base) * 1e3:.3f} ms, p99 {_pct(base, 99):.3f} ms; array/baseline median "
          f"{np.median(mine) / np.median(base):.3f}; failed whisker steps {failed}")


def _points_in_contact(tracker, counts) -> None:
    """Count the points per segment each whisker in contact is solved on, into ``counts``."""
    for name in tracker.names:
        rod = tracker.tracker(name)
        if rod.state.contacts:
            n = rod.solver.points_of(rod.state.equilibrium.modes, rod.state.equilibrium.vec)
            counts[n] = counts.get(n, 0) + 1


def _lockstep(runs, whisk, ticks: int, dt: float, each) -> list:
    """
    Step two array trackers on the same ticks, one after the other in alternating order.

    ``each(steps)`` sees every tick's two results; returns the two runs' tick times [s].
    """
    times = [[], []]
    for k in range(1, ticks + 1):
        steps = [None, None]
        for j in ((0, 1) if k % 2 else (1, 0)):
            t0 = time.perf_counter()
            steps[j] = runs[j].step(HEAD, whisk.angle(k * dt))
            times[j].append(time.perf_counter() - t0)
        each(steps)
    return [np.array(t) for t in times]


def _print_lockstep(labels, times, details=("", ""), after="", versus=None) -> None:
    """Print two lockstep runs' tick times, and the second's against the first (``versus``)."""
    width = max(len(label) for label in labels)
    for label, t, detail in zip(labels, times, details):
        print(f"   {label:>{width}s}: tick median {np.median(t) * 1e3:.3f} ms "
              f"({1.0 / np.median(t):,.0f} ticks/s), mean {t.mean() * 1e3:.3f}, p99 "
              f"{_pct(t, 99):.2f}{detail}")
    ratio = times[1] / times[0]
    versus = versus or f"{labels[1]} / {labels[0]}"
    print(f"   {versus}: per-tick ratio median {np.median(ratio):.3f}; medians "
          f"{np.median(times[1]) / np.median(times[0]):.3f}; means "
          f"{times[1].mean() / times[0].mean():.3f}{after}")


def tolerance_lockstep(side: str, cycles: float, tolerance: float, dt: float = 1e-3) -> None:
    """
    Print the array at the default points_tolerance against ``tolerance``, in lockstep.

    Two ArrayTrackers on the same ticks, stepped one after the other in alternating order; the
    tick times, the solver's work, the point counts in contact, and the coarser one's base
    forces and moments against the default's (largest difference over every whisker and tick,
    relative to the largest value) with the ticks whose events differ.
    """
    _jit.warm_up()
    array, scene, whisk = _setup(side)
    runs = [ArrayTracker(array, scene, HEAD, whisk.angle(0.0)),
            ArrayTracker(array, scene, HEAD, whisk.angle(0.0), points_tolerance=tolerance)]
    ticks = int(round(cycles / whisk.frequency / dt))
    counts = [{}, {}]
    force, moment, differ = [0.0, 0.0], [0.0, 0.0], 0
    # per whisker: the largest difference and the largest value of |F| and |M| over the run
    own = np.zeros((4, len(array)))

    def compare(steps):
        nonlocal force, moment, differ, own
        for j in (0, 1):
            _points_in_contact(runs[j], counts[j])
        a, b = steps
        force = [max(force[0], float(np.abs(a.force_base - b.force_base).max())),
                 max(force[1], float(np.abs(a.force_base).max()))]
        moment = [max(moment[0], float(np.abs(a.moment_base - b.moment_base).max())),
                  max(moment[1], float(np.abs(a.moment_base).max()))]
        own = np.maximum(own, np.array([
            np.abs(a.force_base - b.force_base).max(axis=1),
            np.abs(a.force_base).max(axis=1),
            np.abs(a.moment_base - b.moment_base).max(axis=1),
            np.abs(a.moment_base).max(axis=1)]))
        events = [[(e.whisker, e.kind, e.obstacle) for e in st.events] for st in steps]
        differ += events[0] != events[1] or not np.array_equal(a.contacts, b.contacts)

    times = _lockstep(runs, whisk, ticks, dt, compare)
    print(f"\n== {side} side(s): {len(array)} whiskers, {ticks} ticks of 1 ms in lockstep, "
          f"points_tolerance 1e-11 (default) against {tolerance:g}")
    _print_lockstep(("1e-11", f"{tolerance:g}"), times, [
        f"; evaluations {_evaluations(runs[j]):,}, factorizations "
        f"{_factorizations(runs[j]):,}; points per segment in contact "
        f"{dict(sorted(counts[j].items()))}" for j in (0, 1)],
        versus=f"{tolerance:g} / default")
    print(f"   base force off by {force[0]:.2e} N at most ({force[0] / force[1]:.1e} of the "
          f"largest, {force[1]:.2e} N); base moment by {moment[0]:.2e} N m "
          f"({moment[0] / moment[1]:.1e} of {moment[1]:.2e} N m); ticks whose events or "
          f"contacts differ: {differ}")
    touched = own[1] > 0.0
    if touched.any():
        rf = own[0][touched] / own[1][touched]
        rm = own[2][touched] / own[3][touched]
        print(f"   each whisker in contact against its own largest value: force off by "
              f"{rf.max():.1e} at most (median {np.median(rf):.1e}), moment {rm.max():.1e} "
              f"(median {np.median(rm):.1e}), over {int(touched.sum())} whiskers")


def workers_lockstep(side: str, cycles: float, workers: int, dt: float = 1e-3) -> None:
    """
    Print the array in one process against the same array in ``workers`` parts, in lockstep.

    An ArrayTracker and a PartitionedArrayTracker on the same ticks, stepped one after the
    other in alternating order: their tick times, and whether every tick's result is the same
    to the last bit.
    """
    from vibrissa_ros.core.arrays.partition import PartitionedArrayTracker

    _jit.warm_up()
    array, scene, whisk = _setup(side)
    t0 = time.perf_counter()
    many = PartitionedArrayTracker(array, scene, HEAD, whisk.angle(0.0), workers=workers)
    start = time.perf_counter() - t0
    runs = [ArrayTracker(array, scene, HEAD, whisk.angle(0.0)), many]
    ticks = int(round(cycles / whisk.frequency / dt))
    differ = 0

    def compare(steps):
        nonlocal differ
        a, b = steps
        differ += not (all(np.array_equal(getattr(a, f), getattr(b, f)) for f in
                           ("force", "moment", "force_base", "moment_base", "tip",
                            "contacts", "contact_point", "contact_s", "contact_f"))
                       and a.events == b.events and a.errors == b.errors)

    try:
        times = _lockstep(runs, whisk, ticks, dt, compare)
    finally:
        many.close()
    print(f"\n== {side} side(s): {len(array)} whiskers, {ticks} ticks of 1 ms in lockstep, one "
          f"process against {workers} parts (workers started in {start:.1f} s)")
    _print_lockstep(("one process", f"{workers} parts"), times,
                    after=f"; ticks whose results differ: {differ}",
                    versus=f"{workers} parts / one")


def plain_steps(names, cycles: float, repeats: int, dt: float = 1e-3) -> None:
    """
    Print what a plain step of one whisker in contact costs, its tracker replayed alone.

    The right pad's whiskers ``names``, each on its own RodTracker fed the poses the array
    gives it, ``repeats`` times: the median and the least of the medians of the steps that
    start and end in contact with no event (the steps a median tick is made of), and their
    solver evaluations and factorizations (counts, exact between runs).
    """
    _jit.warm_up()
    array, scene, whisk = _setup("right")
    tracker = ArrayTracker(array, scene, HEAD, whisk.angle(0.0))
    ticks = int(round(cycles / whisk.frequency / dt))
    poses = [tracker.whisker_poses(HEAD, whisk.angle(k * dt)) for k in range(ticks + 1)]
    print(f"\n== plain steps of single whiskers in contact ({ticks} poses each, "
          f"{repeats} runs)")
    for name in names:
        i = list(tracker.names).index(name)
        medians = []
        for _ in range(repeats):
            single = RodTracker(tracker._scenes[i], poses[0][i], shape=array.rod(i).shape)
            times, work, lus = [], 0, 0
            for k in range(1, ticks + 1):
                before = bool(single.state.contacts)
                e0, f0 = single.solver.evaluations, single.solver.factorizations
                t0 = time.perf_counter()
                result = single.step(poses[k][i])
                elapsed = time.perf_counter() - t0
                if before and single.state.contacts and not result.events:
                    times.append(elapsed)
                    work += single.solver.evaluations - e0
                    lus += single.solver.factorizations - f0
            medians.append(float(np.median(times)))
        print(f"   {name}: {len(times)} plain steps, median {np.median(medians) * 1e6:.0f} us "
              f"(least of {repeats} runs' medians {min(medians) * 1e6:.0f} us); "
              f"{work / len(times):.2f} evaluations and {lus / len(times):.2f} "
              "factorizations per step")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cycles", type=float, default=2.0, help="whisk cycles (default 2)")
    parser.add_argument("--side", choices=("right", "left", "both"), default=None,
                        help="one run (default: right, then both)")
    parser.add_argument("--baseline-ticks", type=int, default=250,
                        help="ticks of the plain-loop baseline (0: none)")
    parser.add_argument("--plain", nargs="*", metavar="WHISKER", default=None,
                        help="instead: the plain steps of these right-pad whiskers in contact, "
                             "each replayed alone (default RB1 RC1 RD0)")
    parser.add_argument("--repeats", type=int, default=5, help="runs of --plain (default 5)")
    parser.add_argument("--breakdown", action="store_true",
                        help="also print what the ticks nearest the median are made of (each "
                             "whisker's step timed: a little slower)")
    parser.add_argument("--points-tolerance", type=float, default=None, metavar="T",
                        help="instead: the default discretization tolerance against T, two "
                             "arrays in lockstep (speed, and the base wrenches' difference)")
    parser.add_argument("--workers", type=int, default=None, metavar="W",
                        help="instead: the array in one process against W parts "
                             "(PartitionedArrayTracker, W - 1 worker processes), in lockstep")
    args = parser.parse_args(argv)
    if args.workers is not None:
        for side in ((args.side,) if args.side else ("right", "both")):
            workers_lockstep(side, args.cycles, args.workers)
        return 0
    if args.points_tolerance is not None:
        for side in ((args.side,) if args.side else ("right", "both")):
            tolerance_lockstep(side, args.cycles, args.points_tolerance)
        return 0
    if args.plain is not None:
        plain_steps(args.plain or ["RB1", "RC1", "RD0"], args.cycles, args.repeats)
        return 0
    for side in ((args.side,) if args.side else ("right", "both")):
        run(side, args.cycles, args.baseline_ticks, breakdown=args.breakdown)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
