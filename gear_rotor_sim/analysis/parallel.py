"""Running segments of a sweep in parallel: local processes or a Dask cluster, with a progress line.

:func:`execute_tasks` runs a segment function (default :func:`.segments.run_segment`) for every
(case, speeds) task, on the local cores with a forked :class:`~concurrent.futures.ProcessPoolExecutor`
(the parent builds the systems and compiles the kernels first), serially, or on a Dask scheduler.
Workers report each finished speed through :func:`tick`; BLAS runs single-threaded inside them
(:func:`set_blas_threads`).
"""

from __future__ import annotations

import multiprocessing as mp
import os
import queue as queue_mod
import sys
import time
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from gear_rotor_sim.analysis.cases import Case
    from gear_rotor_sim.analysis.segments import RunSettings, SegmentFn

_PROGRESS: Any = None
_BLAS_SET = (
    "scipy_openblas_set_num_threads64_",
    "scipy_openblas_set_num_threads",
    "openblas_set_num_threads",
)
_BLAS_GET = (
    "scipy_openblas_get_num_threads64_",
    "scipy_openblas_get_num_threads",
    "openblas_get_num_threads",
)


def _openblas_libs() -> list[Any]:
    """The OpenBLAS libraries loaded in this process (numpy's and scipy's bundled copies)."""
    import ctypes

    paths: set[str] = set()
    try:
        with open("/proc/self/maps", encoding="utf-8") as fh:
            for line in fh:
                path = line.split()[-1] if line.strip() else ""
                name = path.rsplit("/", 1)[-1].lower()
                if "openblas" in name and (name.endswith(".so") or ".so." in name):
                    paths.add(path)
    except OSError:
        return []
    libs = []
    for p in sorted(paths):
        try:
            libs.append(ctypes.CDLL(p))
        except OSError:
            continue
    return libs


def set_blas_threads(n: int) -> list[int]:
    """Set the OpenBLAS thread count of every loaded OpenBLAS; return the previous counts.

    Sweeps parallelise over processes; a multithreaded BLAS inside each process (the per-speed
    eigendecomposition) oversubscribes the cores and was measured 5-20x slower on the 2-core machine
    under load. Linux only (``/proc/self/maps``); elsewhere nothing is changed.
    """
    previous = []
    for lib in _openblas_libs():
        get = next((getattr(lib, g) for g in _BLAS_GET if hasattr(lib, g)), None)
        put = next((getattr(lib, g) for g in _BLAS_SET if hasattr(lib, g)), None)
        if get is None or put is None:
            continue
        previous.append(int(get()))
        put(int(n))
    return previous


def restore_blas_threads(previous: list[int]) -> None:
    """Give every loaded OpenBLAS back the thread count :func:`set_blas_threads` returned."""
    libs = [
        lib
        for lib in _openblas_libs()
        if any(hasattr(lib, g) for g in _BLAS_GET) and any(hasattr(lib, g) for g in _BLAS_SET)
    ]
    for lib, n in zip(libs, previous, strict=False):
        put = next(getattr(lib, g) for g in _BLAS_SET if hasattr(lib, g))
        put(int(n))


def _init_worker(progress_queue: Any) -> None:
    global _PROGRESS
    _PROGRESS = progress_queue
    set_blas_threads(1)


def tick() -> None:
    """Report one finished speed to the progress line (no-op outside a sweep)."""
    if _PROGRESS is not None:
        try:
            _PROGRESS.put_nowait(1)
        except (queue_mod.Full, OSError, ValueError):
            pass


class _Progress:
    """A single stderr line: ``label: done/total, elapsed, ETA``."""

    def __init__(self, label: str, total: int, enabled: bool) -> None:
        self.label, self.total, self.enabled = label, total, enabled
        self.done = 0
        self.t0 = time.perf_counter()
        self._last = 0.0

    def update(self, n: int = 1, force: bool = False) -> None:
        self.done = min(self.total, self.done + n)
        now = time.perf_counter()
        if not self.enabled or (not force and now - self._last < 0.5 and self.done < self.total):
            return
        self._last = now
        el = now - self.t0
        eta = el / self.done * (self.total - self.done) if self.done else float("nan")
        sys.stderr.write(f"\r{self.label}: {self.done}/{self.total}  {el:6.1f} s elapsed  ETA {eta:6.1f} s ")
        sys.stderr.flush()

    def close(self) -> None:
        if self.enabled:
            self.update(0, force=True)
            sys.stderr.write("\n")
            sys.stderr.flush()


def default_workers() -> int:
    """Usable local cores (``os.sched_getaffinity`` where available)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:
        return max(1, os.cpu_count() or 1)


def execute_tasks(
    tasks: list[tuple[Case, np.ndarray]],
    settings: RunSettings,
    channels: Sequence[str],
    reducer: Callable[[np.ndarray, Sequence[str], RunSettings, float], dict],
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool = True,
    label: str = "sweep",
    segment_fn: SegmentFn | None = None,
) -> list[dict[str, np.ndarray]]:
    """Run ``run_segment`` for every (case, speeds) task; results in task order.

    Parameters
    ----------
    tasks : list of (Case, numpy.ndarray)
        Segments: a case and its contiguous, increasing speeds.
    settings, channels, reducer
        Passed to :func:`run_segment`.
    workers : int, optional
        Local processes (default: the usable cores). ``1`` runs in this process.
    scheduler : str, optional
        Dask scheduler address (``tcp://host:8786``); then ``workers`` is ignored.
    progress : bool
        Write a progress line to stderr.
    label : str
        Prefix of the progress line.
    segment_fn : callable, optional
        Replaces :func:`run_segment` (same signature; must be a picklable top-level function).
        Used to run the same machinery on a different model, e.g. a reference oscillator in tests.
    """
    from gear_rotor_sim.analysis.segments import run_segment

    segment_fn = segment_fn or run_segment
    total = sum(len(s) for _, s in tasks)
    prog = _Progress(label, total, progress)
    results: list[dict[str, np.ndarray] | None] = [None] * len(tasks)
    blas_before = set_blas_threads(1)
    try:
        if scheduler is not None:
            _execute_dask(tasks, settings, channels, reducer, segment_fn, scheduler, prog, results)
        else:
            n_workers = workers or default_workers()
            if n_workers <= 1 or len(tasks) <= 1:
                _execute_serial(tasks, settings, channels, reducer, segment_fn, prog, results)
            else:
                _execute_local(tasks, settings, channels, reducer, segment_fn, n_workers, prog, results)
    finally:
        prog.close()
        restore_blas_threads(blas_before)
    return [r for r in results if r is not None]


class _DirectProgress:
    """Queue-like adapter so that ticks in this process update the progress line directly."""

    def __init__(self, prog: _Progress) -> None:
        self.prog = prog

    def put_nowait(self, n: int) -> None:
        self.prog.update(n)


def _execute_serial(tasks, settings, channels, reducer, segment_fn, prog, results) -> None:  # type: ignore[no-untyped-def]
    global _PROGRESS
    saved, _PROGRESS = _PROGRESS, _DirectProgress(prog)
    try:
        for i, (case, speeds) in enumerate(tasks):
            results[i] = segment_fn(case, speeds, settings, tuple(channels), reducer)
    finally:
        _PROGRESS = saved


def _execute_local(tasks, settings, channels, reducer, segment_fn, n_workers, prog, results) -> None:  # type: ignore[no-untyped-def]
    from gear_rotor_sim.analysis.cases import build_system
    from gear_rotor_sim.analysis.segments import RunSettings, run_segment, steady_run

    ctx = mp.get_context("fork") if "fork" in mp.get_all_start_methods() else mp.get_context()
    if ctx.get_start_method() == "fork" and segment_fn is run_segment:
        # Build every system (and compile the kernels with a short run) before the workers fork.
        for case in dict.fromkeys(c for c, _ in tasks):
            system = build_system(case)
            warm = RunSettings(2, 2, settings.steps_per_mesh, 1.0, settings.contact_loss_rate_hz)
            steady_run(system, float(tasks[0][1][0]), warm, channels, None, first=False)
    q = ctx.Queue()
    with ProcessPoolExecutor(
        max_workers=min(n_workers, len(tasks)), mp_context=ctx, initializer=_init_worker, initargs=(q,)
    ) as pool:
        futs: dict[Future, int] = {
            pool.submit(segment_fn, case, speeds, settings, tuple(channels), reducer): i
            for i, (case, speeds) in enumerate(tasks)
        }
        pending = set(futs)
        while pending:
            done, pending = wait(pending, timeout=0.25, return_when=FIRST_COMPLETED)
            _drain(q, prog)
            for f in done:
                results[futs[f]] = f.result()
        _drain(q, prog)


def _drain(q: Any, prog: _Progress) -> None:
    n = 0
    while True:
        try:
            q.get_nowait()
            n += 1
        except (queue_mod.Empty, OSError, ValueError):
            break
    if n:
        prog.update(n)


def _execute_dask(tasks, settings, channels, reducer, segment_fn, scheduler, prog, results) -> None:  # type: ignore[no-untyped-def]
    from distributed import Client, as_completed

    with Client(scheduler) as client:
        futs = {
            client.submit(segment_fn, case, speeds, settings, tuple(channels), reducer, pure=False): i
            for i, (case, speeds) in enumerate(tasks)
        }
        for f in as_completed(list(futs)):
            i = futs[f]
            results[i] = f.result()
            prog.update(len(tasks[i][1]))
