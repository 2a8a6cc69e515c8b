"""Bifurcation sweeps over speed with continuation, run in parallel, cached in ``.npz``.

How a sweep runs
----------------
The speed grid is split into contiguous segments, one (or ``segments_per_worker``) per worker.
Inside a segment the speeds are visited in increasing order and each run starts from the final
state of the previous speed (continuation), so only the first speed of a segment needs a long
transient (``first_transient_factor`` times the normal one). Segments run

* on the local cores with :class:`concurrent.futures.ProcessPoolExecutor` (default; the parent
  builds the system and compiles the kernels once before the workers fork), or
* on a Dask distributed cluster when a scheduler address is given (``Client(address)``).

A progress line (speeds done, elapsed time, estimated time left) is written to stderr.
Results are saved with :meth:`BifurcationResult.save` so figures redraw without re-simulating.

This module holds the bifurcation reduction (Poincare section per speed), :class:`BifurcationResult`
and :func:`run_bifurcation`; the operating cases and model building are in :mod:`.cases`, the steady
run and the continuation segment in :mod:`.segments`, the parallel execution in :mod:`.parallel`
(their names are importable from here as before).
"""

from __future__ import annotations

import dataclasses
import json
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from gear_rotor_sim.analysis.cases import (
    _SYSTEM_CACHE,  # noqa: F401 (benchmarks/bench_solver.py clears it)
    CONFIG_OVERRIDES,
    LOAD_OVERRIDES,
    MESH_OVERRIDES,
    RAYLEIGH_OVERRIDES,
    SYSTEM_OVERRIDES,
    Case,
    build_config,
    build_system,
    scale_mesh_stiffness,
)
from gear_rotor_sim.analysis.classify import Motion, chaotic_windows, classify_motion, motion_windows
from gear_rotor_sim.analysis.parallel import (
    default_workers,
    execute_tasks,
    restore_blas_threads,
    set_blas_threads,
)
from gear_rotor_sim.analysis.segments import (
    RunSettings,
    SegmentFn,
    mesh_period_s,
    run_segment,
    split_segments,
    steady_run,
)

#: Names of the modules this one was split into, importable from here as before.
__all__ = [
    "BIFURCATION_CHANNELS",
    "CONFIG_OVERRIDES",
    "LOAD_OVERRIDES",
    "MESH_OVERRIDES",
    "RAYLEIGH_OVERRIDES",
    "SYSTEM_OVERRIDES",
    "BifurcationResult",
    "Case",
    "RunSettings",
    "SegmentFn",
    "build_config",
    "build_system",
    "default_workers",
    "execute_tasks",
    "mesh_period_s",
    "reduce_bifurcation",
    "restore_blas_threads",
    "run_bifurcation",
    "run_segment",
    "scale_mesh_stiffness",
    "set_blas_threads",
    "split_segments",
    "steady_run",
]

# ---------------------------------------------------------------------------------------------------
# Per-speed reduction for the bifurcation diagram
# ---------------------------------------------------------------------------------------------------
BIFURCATION_CHANNELS = ("dte",)


def reduce_bifurcation(data: np.ndarray, channels: Sequence[str], settings: RunSettings, dt: float) -> dict:
    """Poincare section of the DTE (phase 0 of each mesh period) and its velocity, range, RMS."""
    x = data[:, list(channels).index("dte")]
    spm = settings.steps_per_mesh
    idx = np.arange(spm - 1, x.size, spm)  # the runner's sample k is step k+1 of the window: phase 0
    i1, i2 = np.maximum(idx - 1, 0), np.maximum(idx - 2, 0)
    v = (3.0 * x[idx] - 4.0 * x[i1] + x[i2]) / (2.0 * dt)  # same 2nd-order backward formula everywhere
    return {
        "section": x[idx],
        "section_v": v,
        "dte_min": np.array(x.min()),
        "dte_max": np.array(x.max()),
        "dte_rms": np.array(np.sqrt(np.mean(x * x))),
        "dte_v_range": np.array(np.ptp(np.gradient(x, dt))),
    }


# ---------------------------------------------------------------------------------------------------
# Bifurcation result
# ---------------------------------------------------------------------------------------------------
@dataclass
class BifurcationResult:
    """Poincare samples of the DTE against speed for one case, with the motion classification.

    Attributes
    ----------
    case : Case
        The model variant.
    speeds_rpm : numpy.ndarray
        Input-shaft speeds, shape ``(n,)``.
    section, section_v : numpy.ndarray
        DTE (m) and DTE velocity (m/s) once per mesh period, shape ``(n, n_periods)``.
    dte_min, dte_max, dte_rms, dte_v_range : numpy.ndarray
        Per speed, over the whole sampled window (every step).
    settings : RunSettings
        Integration window used.
    wall_time_s : float
        Total wall time of the sweep, set-up included.
    meta : dict
        Execution details (workers, scheduler, per-speed wall times).
    """

    case: Case
    speeds_rpm: np.ndarray
    section: np.ndarray
    section_v: np.ndarray
    dte_min: np.ndarray
    dte_max: np.ndarray
    dte_rms: np.ndarray
    dte_v_range: np.ndarray
    settings: RunSettings
    wall_time_s: float
    meta: dict = field(default_factory=dict)

    ARRAYS = ("section", "section_v", "dte_min", "dte_max", "dte_rms", "dte_v_range")

    @classmethod
    def from_arrays(
        cls,
        case: Case,
        speeds_rpm: np.ndarray,
        arrays: Any,
        settings: RunSettings,
        wall_time_s: float,
        meta: dict | None = None,
    ) -> BifurcationResult:
        """Result from the per-speed arrays of :func:`reduce_bifurcation` (a mapping by field name)."""
        return cls(
            case, speeds_rpm, *(arrays[k] for k in cls.ARRAYS), settings, float(wall_time_s), dict(meta or {})
        )

    def classify(self, rtol: float = 2e-3, max_period: int = 8, k_chaos: float = 0.5) -> list[Motion]:
        """Motion per speed (see :mod:`gear_rotor_sim.analysis.classify`), section in (DTE, DTE')."""
        out = []
        for i in range(self.speeds_rpm.size):
            pts = np.column_stack([self.section[i], self.section_v[i]])
            scale = np.array([self.dte_max[i] - self.dte_min[i], self.dte_v_range[i]])
            out.append(classify_motion(pts, scale, rtol=rtol, max_period=max_period, k_chaos=k_chaos))
        return out

    def labels(self, **kwargs: float) -> list[str]:
        return [m.label for m in self.classify(**kwargs)]

    def windows(self, **kwargs: float) -> list[tuple[str, float, float]]:
        """Contiguous speed windows per motion label."""
        return motion_windows(self.speeds_rpm, self.labels(**kwargs))

    def chaotic_windows(self, min_width_rpm: float = 0.0, merge_gap: int = 1) -> list[tuple[float, float]]:
        return chaotic_windows(self.speeds_rpm, self.labels(), min_width_rpm, merge_gap)

    def save(self, path: str | Path) -> Path:
        """Write a compressed ``.npz`` (arrays plus JSON metadata)."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(
            path,
            kind=np.array("bifurcation"),
            case=np.array(self.case.to_json()),
            settings=np.array(json.dumps(dataclasses.asdict(self.settings))),
            meta=np.array(json.dumps(self.meta)),
            wall_time_s=np.array(self.wall_time_s),
            speeds_rpm=self.speeds_rpm,
            section=self.section,
            section_v=self.section_v,
            dte_min=self.dte_min,
            dte_max=self.dte_max,
            dte_rms=self.dte_rms,
            dte_v_range=self.dte_v_range,
        )
        return path

    @staticmethod
    def load(path: str | Path) -> BifurcationResult:
        with np.load(path, allow_pickle=False) as z:
            if str(z["kind"]) != "bifurcation":
                raise ValueError(f"{path}: not a bifurcation result (kind={z['kind']})")
            return BifurcationResult.from_arrays(
                Case.from_json(str(z["case"])),
                z["speeds_rpm"],
                z,
                RunSettings(**json.loads(str(z["settings"]))),
                float(z["wall_time_s"]),
                json.loads(str(z["meta"])),
            )


def run_bifurcation(
    case: Case,
    speeds_rpm: np.ndarray,
    settings: RunSettings | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    segments_per_worker: int = 1,
    progress: bool = True,
    segment_fn: SegmentFn | None = None,
) -> BifurcationResult:
    """Bifurcation diagram of the DTE over ``speeds_rpm`` for one case.

    Parameters
    ----------
    case : Case
        Model variant.
    speeds_rpm : numpy.ndarray
        Speeds (sorted increasing before the run), rpm.
    settings : RunSettings, optional
        Integration window per speed.
    workers : int, optional
        Local worker processes (default: usable cores).
    scheduler : str, optional
        Dask scheduler address; the segments then run on that cluster.
    segments_per_worker : int
        Contiguous segments per worker (more segments: finer progress and load balance, but more
        cold starts without continuation).
    progress : bool
        Progress line on stderr.
    segment_fn : callable, optional
        Alternative segment runner (see :func:`execute_tasks`).
    """
    t0 = time.perf_counter()
    settings = settings or RunSettings()
    speeds = np.sort(np.asarray(speeds_rpm, dtype=float))
    if speeds.size == 0 or np.any(~np.isfinite(speeds)) or np.any(speeds <= 0):
        raise ValueError("speeds_rpm: need at least one positive, finite speed")
    n_workers = 1 if scheduler is None and workers == 1 else (workers or default_workers())
    slices = split_segments(speeds.size, n_workers * max(1, segments_per_worker))
    tasks = [(case, speeds[s]) for s in slices]
    parts = execute_tasks(
        tasks,
        settings,
        BIFURCATION_CHANNELS,
        reduce_bifurcation,
        workers=n_workers,
        scheduler=scheduler,
        progress=progress,
        label=f"bifurcation [{case.label()}]",
        segment_fn=segment_fn,
    )
    cat = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    return BifurcationResult.from_arrays(
        case,
        speeds,
        cat,
        settings,
        time.perf_counter() - t0,
        {
            "workers": n_workers,
            "scheduler": scheduler or "",
            "segments": len(tasks),
            "speed_wall_s": [float(w) for w in cat["wall_s"]],
        },
    )
