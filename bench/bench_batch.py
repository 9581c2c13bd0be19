"""
Throughput of ``vibrissa batch``: scaling to 2 workers, overhead per task, a large study's cost.

Three measurements, all in the same run (the machine may be shared: medians and same-run ratios):

1. scaling: the same sample of tasks of the random-profile study below, on an embedded cluster of 1
   worker and of 2 workers, alternately, ``--repeats`` times each; the ratio of the median wall
   times (cluster start-up excluded: it is paid once per study);
2. overhead: ``--overhead-tasks`` tasks of ~1 s each (a fine scan) on 1 worker; Dask's own task
   stream gives each task's compute time on the worker, the rest of the wall time (scheduling,
   transfer of the results, writing them) is the engine's overhead;
3. a 10,000-task study of random convex profiles (five families, random shapes, a 301-pose sweep
   each): a seeded sample of ``--sample`` tasks on ``--workers`` workers (``--sample 10000``: all
   of it), giving tasks/s, poses/s, core-seconds per task, and the extrapolation to a data set of
   240,000 sweeps in core-hours.

Run: python bench/bench_batch.py [--repeats 3] [--scaling-tasks 40] [--sample 200] [--workers 2]
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import os
import random
import shutil
import statistics
import tempfile
import time

from vibrissa_ros.studies.batch import run_study
from vibrissa_ros.studies.study import parse_study

RANDOM_PROFILES = """
description: 10,000 random convex obstacles (2,000 per family), one 301-pose sweep each
seed: 11
obstacles:
  - profile: parabola
    samples: 2000
    params: {p0: {uniform: [0.1, 0.6]}, k: {loguniform: [0.3, 3.0]}}
  - profile: catenary
    samples: 2000
    params: {p0: {uniform: [0.1, 0.6]}, c: {loguniform: [0.3, 2.0]}}
  - profile: circle
    samples: 2000
    params: {p0: {uniform: [0.1, 0.6]}, R: {loguniform: [1.0, 4.0]}}
  - profile: two_circles
    samples: 2000
    params: {p0: {uniform: [0.1, 0.6]}, R_left: {loguniform: [1.0, 4.0]},
             R_right: {loguniform: [1.0, 4.0]}}
  - profile: ellipse
    samples: 2000
    params: {p0: {uniform: [0.1, 0.6]}, a: {loguniform: [0.3, 1.5]}, b: {loguniform: [1.0, 3.0]}}
motion: {from: 3.0, to: -3.0, step: 0.02}
"""

# tasks of about one second each: fine forward scans of the paper's parabola
SLOW_TASKS = """
obstacles:
  - profile: parabola
    params: {p0: [0.25, 0.3, 0.35, 0.4, 0.45, 0.5, 0.55, 0.6]}
motion: {from: 2.0, to: -2.0, step: 0.0003}
"""


def _cluster(n):
    from distributed import Client, LocalCluster

    cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                           dashboard_address=":0", silence_logs=logging.ERROR)
    return cluster, Client(cluster)


def _compute(stream):
    """Seconds the workers spent computing tasks, from Dask's task stream."""
    return sum(ss["stop"] - ss["start"] for rec in stream.data for ss in rec["startstops"]
               if ss["action"] == "compute")


def _worker_cpu(client):
    """CPU seconds used so far by the cluster's worker processes."""
    return sum(client.run(time.process_time).values())


def _subset(study, tasks):
    return dataclasses.replace(study, tasks=tuple(tasks))


def _close(cluster, client):
    client.close()
    cluster.close()
    # closing restores the cluster's log level
    logging.getLogger("distributed").setLevel(logging.ERROR)


def _timed_run(study, client, root):
    out = tempfile.mkdtemp(dir=root)
    t0 = time.perf_counter()
    report = run_study(study, out, client=client, progress=None)
    wall = time.perf_counter() - t0
    shutil.rmtree(out)
    assert report.complete and not report.errors, report
    return wall, report


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--scaling-tasks", type=int, default=40)
    parser.add_argument("--overhead-tasks", type=int, default=8)
    parser.add_argument("--sample", type=int, default=200)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args(argv)
    logging.getLogger("distributed").setLevel(logging.ERROR)  # the clusters' start/stop chatter
    root = tempfile.mkdtemp(prefix="bench_batch_")
    big = parse_study(RANDOM_PROFILES)
    rng = random.Random(5)
    print(f"study: {len(big.tasks):,} tasks, {big.poses:,} poses ({os.cpu_count()} cores)")
    try:
        # 1. scaling, 1 vs 2 workers, alternately
        from distributed import get_task_stream

        scaling = _subset(big, sorted(rng.sample(big.tasks, args.scaling_tasks),
                                      key=lambda t: t.index))
        clusters = {n: _cluster(n) for n in (1, 2)}
        walls = {1: [], 2: []}
        busy = {1: [], 2: []}
        cores = {1: [], 2: []}
        load = os.getloadavg()[0]
        for _ in range(args.repeats):
            for n in (1, 2):
                cpu0 = _worker_cpu(clusters[n][1])
                with get_task_stream(clusters[n][1]) as stream:
                    wall = _timed_run(scaling, clusters[n][1], root)[0]
                cores[n].append((_worker_cpu(clusters[n][1]) - cpu0) / wall)
                walls[n].append(wall)
                busy[n].append(_compute(stream) / (n * wall))
        m1, m2 = statistics.median(walls[1]), statistics.median(walls[2])
        print(f"scaling: {args.scaling_tasks} tasks, 1 worker {m1:.2f} s, 2 workers "
              f"{m2:.2f} s (medians of {args.repeats}); 2 workers = {m1 / m2:.2f}x "
              "the throughput of 1")
        print(f"scaling: workers busy computing {100 * statistics.median(busy[1]):.0f}% (1) and "
              f"{100 * statistics.median(busy[2]):.0f}% (2) of the wall time, and got "
              f"{statistics.median(cores[1]):.2f} and {statistics.median(cores[2]):.2f} cores of "
              f"CPU time; load average {load:.1f} -> {os.getloadavg()[0]:.1f} on {os.cpu_count()} "
              "cores (above the workers' count: the machine is shared and the ratio "
              "understates the engine)")
        c1, c2 = statistics.median(cores[1]), statistics.median(cores[2])
        per_core = (m1 / m2) / (c2 / c1)
        print(f"scaling: per core of CPU time obtained, 2 workers do {per_core:.2f}x the work of "
              f"1 (1.00: perfect); with two whole cores that is {2 * per_core:.2f}x (an estimate: "
              "re-measure on a quiet machine)")

        # 2. overhead per task for ~1 s tasks, on 1 worker, from Dask's task stream
        slow = parse_study(SLOW_TASKS)
        slow = _subset(slow, slow.tasks[: args.overhead_tasks])
        client = clusters[1][1]
        overheads, computes = [], []
        for _ in range(args.repeats):
            with get_task_stream(client) as stream:
                wall, _ = _timed_run(slow, client, root)
            compute = _compute(stream)
            n = len(slow.tasks)
            overheads.append((wall - compute) / n)
            computes.append(compute / n)
        oh, task = statistics.median(overheads), statistics.median(computes)
        print(f"overhead: {len(slow.tasks)} tasks of {task:.2f} s (median compute on "
              f"the worker); engine overhead {oh * 1e3:.1f} ms per task = {100 * oh / task:.1f}% "
              f"(scheduling, transfer, writing; median of {args.repeats})")
        for cluster, c in clusters.values():
            _close(cluster, c)

        # 3. the random-profile study: a sample (or all of it)
        n = min(args.sample, len(big.tasks))
        sample = big if n == len(big.tasks) else _subset(
            big, sorted(rng.sample(big.tasks, n), key=lambda t: t.index))
        cluster, client = _cluster(args.workers)
        wall, report = _timed_run(sample, client, root)
        _close(cluster, client)
        poses = sum(len(t.grid()) for t in sample.tasks)
        core_s = wall * args.workers / n
        print(f"random profiles: {n} tasks ({report.failed} failed) on {args.workers} workers "
              f"in {wall:.1f} s: {n / wall:.2f} tasks/s, {poses / wall:,.0f} poses/s, "
              f"{core_s:.3f} core-s per task")
        print("random profiles: all 10,000 tasks: "
              f"{len(big.tasks) * core_s / 3600:.2f} core-hours "
              f"({len(big.tasks) * core_s / args.workers / 60:.1f} min on this machine)")
        print("extrapolation: 240,000 sweeps of 301 poses: "
              f"{240_000 * core_s / 3600:.1f} core-hours (x31 for a 31-whisker array: "
              f"{31 * 240_000 * core_s / 3600:.0f} core-hours)")
    finally:
        shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
