"""
Studies at scale: run every task of a study on a Dask cluster and write the results as a dataset.

One task is one scan, computed by the very function ``vibrissa scan`` calls
(:func:`vibrissa_ros.core.scan.run_scan`, :func:`~vibrissa_ros.core.scan.run_poses` for a whisk),
so every row equals that command's output value for value. The engine is Dask distributed: an
embedded ``LocalCluster`` (one single-threaded worker process per core) or an existing cluster
given by its scheduler's address. Dask schedules, balances (work stealing), retries a task that
raised something unexpected and re-runs the tasks of a lost worker; nothing here queues or retries
on its own.

The workers compute and return each task's tables; the driver writes them, task by task, atomically
(:class:`vibrissa_ros.studies.dataset.StudyWriter`), so workers need no shared file system and a
killed run loses only the tasks in flight. Running the same study into the same directory again
computes only the tasks that are missing.
"""

from __future__ import annotations

import itertools
import os
import sys
import time
import warnings
from dataclasses import dataclass
from typing import IO, List, Optional, Tuple

from ..core.errors import VibrissaError
from .dataset import (Layout, StudyWriter, TaskFiles, encode, failure_tables, layout_of,
                      result_tables)
from .study import Study, Task

#: how often Dask re-runs a task that raised an unexpected exception (not a VibrissaError)
RETRIES = 2
#: at most this many tasks in Dask's graph at once
WINDOW = 20_000


@dataclass(frozen=True)
class BatchReport:
    """
    What one ``vibrissa batch`` run did.

    ``errors`` are tasks that could not be computed in this run (an unexpected exception after
    Dask's retries, or a task that kept killing its workers): they are not written, so running the
    same command again tries them again.
    """

    tasks: int
    already_done: int
    computed: int
    failed: int
    errors: Tuple[Tuple[int, str], ...]
    seconds: float
    workers: int

    @property
    def complete(self) -> bool:
        return self.already_done + self.computed == self.tasks


def run_task(task: Task, layout: Layout) -> TaskFiles:
    """
    Compute one task (on a worker) and write it as Parquet files.

    The files hold its scan's tables, or its failure when the scan raises a
    :class:`VibrissaError` (a model assumption left, a pose that cannot be placed, ...).
    """
    try:
        with warnings.catch_warnings():
            # scipy's bounded minimizer of the rod's clearance meets infinite gaps (no profile
            # point above); the result is right, the warning would only scramble the progress bar
            warnings.filterwarnings("ignore", category=RuntimeWarning, module="scipy.optimize")
            result = task.run()
    except VibrissaError as exc:
        return encode(failure_tables(task, exc, layout))
    return encode(result_tables(task, result, layout))


def _client(workers: Optional[int], scheduler: Optional[str]):
    """Connect a Dask client to the cluster at ``scheduler``, or to a new embedded LocalCluster."""
    import dask
    from distributed import Client, LocalCluster

    if scheduler:
        return Client(scheduler, timeout="30s"), None
    n = (
        workers
        or (len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count())
        or 1
    )
    # Dask's nannies start workers with MALLOC_TRIM_THRESHOLD_=65536; setting it fixes glibc's
    # mmap threshold too, so every numpy array above 128 kB is mapped and unmapped: the 3D
    # solver's steps then cost about twice the CPU time (measured on array studies). The
    # embedded cluster's workers keep glibc's default (the other variables stay: one thread).
    environ = dict(dask.config.get("distributed.nanny.pre-spawn-environ", {}) or {})
    environ.pop("MALLOC_TRIM_THRESHOLD_", None)
    with dask.config.set({"distributed.nanny.pre-spawn-environ": environ}):
        cluster = LocalCluster(
            n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
            silence_logs=40
        )
    return Client(cluster), cluster


def run_study(
    study: Study,
    out: str,
    workers: Optional[int] = None,
    scheduler: Optional[str] = None,
    client=None,
    progress: Optional[IO[str]] = sys.stderr,
    retries: int = RETRIES,
    window: int = WINDOW,
) -> BatchReport:
    """
    Run the study's missing tasks on Dask and write their results into ``out``.

    Parameters
    ----------
    study : Study
        A validated study (:func:`vibrissa_ros.studies.study.load_study`).
    out : str
        The dataset directory: created, or resumed when it holds this very study.
    workers : int, optional
        Worker processes of the embedded cluster (default: the machine's cores).
    scheduler : str, optional
        Address of an existing Dask scheduler (``tcp://host:8786``); its workers need this version
        of vibrissa_ros installed (``pip install vibrissa_ros[batch]``).
    client : distributed.Client, optional
        An existing client to use instead (it is left open).
    progress : text stream or None, optional
        Where the progress bar goes (None: no bar).
    retries : int, optional
        How often Dask re-runs a task that raised an unexpected exception.
    window : int, optional
        At most this many tasks are submitted at a time (more as they complete).

    Returns
    -------
    BatchReport
        What the run did: tasks already done, computed, failed, and the errors of tasks that
        could not be computed in this run (not written: running again tries them again).

    """
    from distributed import as_completed
    from tqdm import tqdm

    start = time.perf_counter()
    writer = StudyWriter.create(out, study)
    done = writer.done()
    todo = [t for t in study.tasks if t.index not in done]
    layout = layout_of(study)
    failed = 0
    errors: List[Tuple[int, str]] = []
    computed = 0
    if not todo:
        return BatchReport(len(study.tasks), len(done), 0, 0, (), time.perf_counter() - start, 0)
    own = client is None
    cluster = None
    if own:
        client, cluster = _client(workers, scheduler)
    bar = tqdm(
        total=len(study.tasks),
        initial=len(done),
        unit="task",
        desc="vibrissa batch",
        file=progress,
        disable=progress is None,
        dynamic_ncols=True,
        smoothing=0.05,
    )
    earlier_failures = writer.failures()
    pending = iter(todo)
    function, shared = run_task, {}
    if getattr(layout, "kind", None) == "array":
        from .array_study import run_array_task

        # the array file's text goes to every worker once, not with every task
        function = run_array_task
        shared = dict(array_text=client.scatter(study.array_text, broadcast=True),
                      array_label=study.array_path, side=study.side,
                      points_tolerance=study.points_tolerance)

    def submit(n: int):
        tasks = list(itertools.islice(pending, n))
        keys = [f"vibrissa-task-{study.digest[:12]}-{t.index}" for t in tasks]
        return (
            client.map(function, tasks, layout=layout, key=keys, retries=retries, pure=False,
                       **shared)
            if tasks
            else []
        )

    try:
        n_workers = len(client.scheduler_info().get("workers", {}))
        bar.set_postfix(failed=earlier_failures, workers=n_workers)
        # at most `window` tasks in the graph at a time (a 240k-task study would weigh on the
        # scheduler's memory); Dask schedules, balances and retries them
        running = as_completed(submit(window))
        since_refill = 0
        for future in running:
            since_refill += 1
            if since_refill >= max(1, window // 2):
                running.update(submit(since_refill))
                since_refill = 0
            index = int(future.key.rsplit("-", 1)[1])
            try:
                files = future.result()
            except (
                Exception
            ) as exc:  # noqa: BLE001 - Dask gave up on it (after its retries): report it
                errors.append((index, f"{type(exc).__name__}: {exc}"))
                future.release()
                continue
            future.release()
            writer.write(files)
            computed += 1
            if files.failed:
                failed += 1
                bar.set_postfix(failed=earlier_failures + failed, workers=n_workers, refresh=False)
            bar.update(1)
    finally:
        bar.close()
        if own:
            client.close()
            if cluster is not None:
                cluster.close()
    return BatchReport(
        len(study.tasks),
        len(done),
        computed,
        failed,
        tuple(sorted(errors)),
        time.perf_counter() - start,
        n_workers,
    )
