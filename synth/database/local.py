"""The local engine: one task per mesh on a pool of worker processes that end with their parent.

Workers are spawned (fresh interpreters that read the thread limits of the environment), ignore
Ctrl-C (the parent handles it) and never outlive the build:

* each worker runs a watchdog thread that ends the worker (``os._exit``) within
  :data:`WATCHDOG_INTERVAL_S` once its parent is gone -- whatever stopped the parent, SIGKILL
  included -- and, on Linux, also asks the kernel to kill it when the parent dies
  (``PR_SET_PDEATHSIG``), which works even while the worker holds the GIL in a long C call;
* when the parent stops planning early (Ctrl-C, SIGTERM, an error while storing), it terminates
  the workers instead of waiting for the meshes they are planning, whose results would be
  dropped anyway.

With the workers gone, multiprocessing's resource tracker, which waits for every process that
shares its pipe, ends too.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import threading
import time
from collections.abc import Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from synth.database.worker import PlanOutcome, crashed, run_one
from synth.isolate import die_with_parent, how_it_ended

__all__ = ["WATCHDOG_INTERVAL_S", "run_local"]

#: Seconds between two checks of a worker's watchdog that its parent is alive.
WATCHDOG_INTERVAL_S = 0.2
# BLAS/OpenMP threads per local worker: the CPUs divided among the workers (unless already set),
# so that N workers do not run N times the cores' worth of threads.
_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")

_Task = tuple[int, str]  # (mesh id, path)


def _watch_parent(parent: int) -> None:
    while True:
        if os.getppid() != parent:  # re-parented: the build process is gone
            os._exit(1)
        time.sleep(WATCHDOG_INTERVAL_S)


def _init_worker(parent: int) -> None:
    """Pool initializer: ignore Ctrl-C and end with the parent process ``parent``."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles Ctrl-C
    die_with_parent()
    threading.Thread(target=_watch_parent, args=(parent,), name="synth-watchdog",
                     daemon=True).start()  # fmt: skip


def _new_pool(workers: int) -> ProcessPoolExecutor:
    context = multiprocessing.get_context("spawn")  # fresh workers that read the env
    return ProcessPoolExecutor(max_workers=workers, mp_context=context,
                               initializer=_init_worker, initargs=(os.getpid(),))  # fmt: skip


def _stop(pool: ProcessPoolExecutor, finished: bool) -> None:
    """Shut ``pool`` down; if the run did not finish, terminate its workers first."""
    if not finished:
        for process in list((pool._processes or {}).values()):  # None once shut down
            process.terminate()
    pool.shutdown(wait=True, cancel_futures=True)


def run_local(
    tasks: list[_Task], params: dict[str, Any], planner: str, timeout: float | None, workers: int
) -> Iterator[tuple[int, PlanOutcome]]:
    """Plan ``tasks`` on ``workers`` processes; yield ``(mesh id, outcome)`` as they finish.

    A crashed worker fails only the mesh that crashes: the tasks in flight when a worker died
    are run again alone, one at a time. Closing the iterator early terminates the workers.
    """
    saved = {k: os.environ.get(k) for k in _THREAD_VARS}
    threads = str(max(1, len(os.sched_getaffinity(0)) // workers))
    os.environ.update({k: threads for k, v in saved.items() if v is None})
    queue = list(reversed(tasks))
    suspects: list[_Task] = []  # in flight when a worker died: rerun alone, one at a time
    pool = _new_pool(workers)
    running: dict[Future[PlanOutcome], _Task] = {}
    finished = False
    try:
        while queue or running or suspects:
            if suspects and not running:
                task = suspects.pop()
                solo, solo_finished = _new_pool(1), False
                try:
                    future = solo.submit(run_one, task[1], params, planner, timeout)
                    members = list((solo._processes or {}).values())
                    try:
                        outcome = future.result()
                    except BrokenProcessPool:
                        outcome = None
                    solo_finished = True
                finally:
                    _stop(solo, solo_finished)
                if outcome is None:  # the worker died planning this mesh alone: its crash
                    codes = [p.exitcode for p in members if p.exitcode != 0]
                    outcome = crashed(task[1], "the worker process planning it was "
                                      + how_it_ended(codes[0] if codes else None))
                yield task[0], outcome
                continue
            while queue and not suspects and len(running) < 2 * workers:
                task = queue.pop()
                running[pool.submit(run_one, task[1], params, planner, timeout)] = task
            done, _ = wait(running, return_when=FIRST_COMPLETED)
            broken = False
            for fut in done:
                task = running.pop(fut)
                try:
                    outcome = fut.result()
                except BrokenProcessPool:
                    broken = True
                    suspects.append(task)
                    continue
                yield task[0], outcome
            if broken:
                suspects.extend(running.values())
                running.clear()
                pool.shutdown(wait=True)
                pool = _new_pool(workers)
        finished = True
    finally:
        _stop(pool, finished)
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
