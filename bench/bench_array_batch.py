"""
Throughput of array studies in ``vibrissa batch``: tasks/s on Dask against a serial baseline.

One small array study (the rat's right pad, 30 whiskers, whisking 40 ms at 1 kHz from full
retraction against random vertical pegs that columns 0-2 reach), measured in the same run
(the machine may be shared: medians over ``--repeats`` and same-run ratios):

1. baseline: the study's tasks computed one after the other in this process (the function a
   worker calls, no Dask);
2. Dask: the same tasks on an embedded cluster of ``--workers`` single-threaded workers, started
   once before the repeats (its start-up is printed apart: it is paid once per study), each
   repeat into a new dataset directory.

It prints tasks/s, whisker-ticks/s and core-seconds per task of both, the ratio of the medians,
and the extrapolation to a data set of Zhuang et al. 2017's size (240,000 sweeps of about 110
frames of a 31-whisker array; here 30 whiskers), by the measured cost per whisker-tick.

``--dask-environ`` starts the workers as Dask's nannies do by default (with
MALLOC_TRIM_THRESHOLD_=65536, which ``vibrissa batch``'s embedded cluster leaves out: it doubles
the 3D solver's CPU time).

Run: OPENBLAS_NUM_THREADS=1 python bench/bench_array_batch.py [--tasks 6] [--repeats 3]
[--workers 2] [--dask-environ]
"""

from __future__ import annotations

import argparse
import logging
import os
import shutil
import statistics
import tempfile
import time

STUDY = """
kind: array
seed: 8
array: {array}
side: right
objects:
  - cylinder: {{x: {{uniform: [0.027, 0.031]}}, y: -0.016, z: 0, r: {{uniform: [0.001, 0.002]}},
               axis: [0, 0, 1]}}
    samples: {tasks}
motion:
  - whisk: {{frequency: 8, retraction_deg: -20, protraction_deg: 20}}
    duration: 0.04
    rate: 1000
"""
#: Zhuang et al. 2017's data set: sweeps, frames per sweep, whiskers per array (one side: 30 here)
ZHUANG_SWEEPS, ZHUANG_FRAMES, WHISKERS = 240_000, 110, 30


def main() -> None:
    """Measure and print (see the module)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tasks", type=int, default=6)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--dask-environ", action="store_true",
                        help="start the workers with Dask's own environment (its "
                        "MALLOC_TRIM_THRESHOLD_) instead of vibrissa batch's")
    args = parser.parse_args()
    from distributed import Client, LocalCluster

    from vibrissa_ros.studies.array_study import run_array_task
    from vibrissa_ros.studies.batch import _client, run_study
    from vibrissa_ros.studies.dataset import layout_of
    from vibrissa_ros.studies.study import parse_study

    root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "config")
    study = parse_study(STUDY.format(array=os.path.join(root, "rat_array.yaml"),
                                     tasks=args.tasks))
    n = len(study.tasks)
    rows = study.poses
    print(f"study: {n} tasks of {study.whiskers} whiskers x {study.tasks[0].ticks} ticks "
          f"({rows:,} whisker-ticks); load average before: {os.getloadavg()[0]:.1f}")
    started = time.perf_counter()
    if args.dask_environ:
        cluster = LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True,
                               dashboard_address=":0", silence_logs=logging.ERROR)
        client = Client(cluster)
    else:  # the embedded cluster of vibrissa batch
        client, cluster = _client(args.workers, None)
    print(f"cluster start-up ({args.workers} workers): {time.perf_counter() - started:.1f} s")
    serial, dask, serial_cpu, dask_cpu = [], [], [], []
    layout = layout_of(study)
    try:
        for repeat in range(args.repeats):
            t0, c0 = time.perf_counter(), time.process_time()
            failed = 0
            for task in study.tasks:
                files = run_array_task(task, layout, study.array_text, study.array_path,
                                       study.side)
                failed += files.failed
            serial.append(time.perf_counter() - t0)
            serial_cpu.append(time.process_time() - c0)
            out = tempfile.mkdtemp(prefix="bench_array_batch_")
            try:
                before = client.run(time.process_time)
                t0 = time.perf_counter()
                report = run_study(study, out, client=client, progress=None)
                dask.append(time.perf_counter() - t0)
                after = client.run(time.process_time)
                dask_cpu.append(sum(after[w] - before[w] for w in after))
            finally:
                shutil.rmtree(out, ignore_errors=True)
            assert report.complete and not report.errors, report
            print(f"repeat {repeat + 1}: serial {serial[-1]:.1f} s ({serial_cpu[-1]:.1f} CPU-s), "
                  f"Dask {dask[-1]:.1f} s ({dask_cpu[-1]:.1f} CPU-s of the workers) ({failed} "
                  f"failed tasks; load average {os.getloadavg()[0]:.1f})")
    finally:
        client.close()
        cluster.close()
    s, d = statistics.median(serial), statistics.median(dask)
    sc, dc = statistics.median(serial_cpu), statistics.median(dask_cpu)
    print(f"serial (1 process, no Dask): {n / s:.3f} tasks/s, {rows / s:,.0f} whisker-ticks/s, "
          f"{sc / n:.2f} CPU-s per task (medians of {len(serial)})")
    print(f"Dask, {args.workers} workers: {n / d:.3f} tasks/s, {rows / d:,.0f} whisker-ticks/s, "
          f"{dc / n:.2f} CPU-s per task (medians of {len(dask)}); {s / d:.2f}x the serial "
          f"throughput, {dc / sc:.2f}x its CPU time")
    ran = max(1, n - failed)
    done = rows * ran // n  # the whisker-ticks of the tasks that ran (not failed)
    per_tick = dc / done  # core-seconds per whisker-tick on the workers
    print(f"{n - failed} of {n} tasks ran ({failed} failed at the start: a peg drawn inside a "
          f"whisker); {1e3 * per_tick:.2f} CPU-ms per whisker-tick, "
          f"{dc / ran:.1f} CPU-s per task that ran")
    total = ZHUANG_SWEEPS * ZHUANG_FRAMES * WHISKERS * per_tick / 3600.0
    print(f"Zhuang et al. 2017's size ({ZHUANG_SWEEPS:,} sweeps x {ZHUANG_FRAMES} frames x "
          f"{WHISKERS} whiskers), at this contact density: {total:,.0f} core-hours; "
          f"{total / args.workers:,.0f} h on these {args.workers} cores, {total / 64:,.1f} h on "
          "64 cores")


if __name__ == "__main__":
    main()
