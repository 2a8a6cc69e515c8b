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
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import multiprocessing as mp
import os
import queue as queue_mod
import sys
import time
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from gear_rotor_sim.analysis.classify import Motion, chaotic_windows, classify_motion, motion_windows
from gear_rotor_sim.solver.dt_rule import CONTACT_LOSS_RATE_HZ

# ---------------------------------------------------------------------------------------------------
# Operating cases and model building
# ---------------------------------------------------------------------------------------------------
MESH_OVERRIDES = (
    "friction_coefficient",
    "damping_ratio",
    "half_backlash_m",
    "transmission_error_amplitude_m",
    "transmission_error_phase_rad",
)
RAYLEIGH_OVERRIDES = ("mass_per_s", "stiffness_s")
#: Overrides of the configuration's load: the output torque T2 (Table 3: 200 N m), N m.
LOAD_OVERRIDES = ("load_torque_nm",)
#: Overrides applied to the assembled system (not expressible in the configuration).
SYSTEM_OVERRIDES = ("mesh_stiffness_scale",)
#: Overrides of other configuration fields: the reference (stress-free) temperature, C; the Timoshenko
#: shear coefficient; the node (1-based, Fig 5) of the output torque; a factor on every bearing's tilt
#: stiffness; every bearing's tilt damping, N m s/rad.
CONFIG_OVERRIDES = (
    "reference_temperature_c",
    "shear_coefficient",
    "load_node",
    "bearing_tilt_stiffness_scale",
    "bearing_tilt_damping",
)


@dataclass(frozen=True)
class Case:
    """One model variant: the paper's gearbox at a temperature, bearing type and backlash model.

    Attributes
    ----------
    temperature_c : float
        Uniform steady temperature, C.
    bearing_type : str
        ``"A#"``, ``"B#"`` or ``"C#"`` (Table 5).
    thermal_backlash : bool
        Whether the backlash shrinks with temperature (Eq 27); ``False`` is the paper's Fig 6c.
    overrides : tuple of (str, float)
        Parameter changes for sensitivity studies: mesh fields (``friction_coefficient``,
        ``damping_ratio``, ``half_backlash_m``, ``transmission_error_amplitude_m``,
        ``transmission_error_phase_rad``), shaft
        Rayleigh damping (``mass_per_s``, ``stiffness_s``), the output torque ``load_torque_nm``,
        ``mesh_stiffness_scale`` (multiplies the potential-energy mesh stiffness at every phase, see
        :func:`scale_mesh_stiffness`) and the fields of :data:`CONFIG_OVERRIDES`.
    config : str
        Named paper configuration (:data:`gear_rotor_sim.examples.PAPER_CONFIGS`): ``"paper_sun2021"``
        (default) or ``"paper_sun2021_as_published"``.
    """

    temperature_c: float
    bearing_type: str = "A#"
    thermal_backlash: bool = True
    overrides: tuple[tuple[str, float], ...] = ()
    config: str = "paper_sun2021"

    def label(self) -> str:
        """Short human-readable name, e.g. ``"225 C, A#, thermal backlash"``."""
        bl = "thermal backlash" if self.thermal_backlash else "fixed backlash"
        extra = "".join(f", {k}={v:g}" for k, v in self.overrides)
        if self.config != "paper_sun2021":
            extra += f", {self.config}"
        return f"{self.temperature_c:g} C, {self.bearing_type}, {bl}{extra}"

    def to_json(self) -> str:
        return json.dumps(dataclasses.asdict(self))

    @staticmethod
    def from_json(text: str) -> Case:
        d = json.loads(text)
        return Case(
            float(d["temperature_c"]),
            str(d["bearing_type"]),
            bool(d["thermal_backlash"]),
            tuple((str(k), float(v)) for k, v in d["overrides"]),
            str(d.get("config", "paper_sun2021")),
        )


def build_config(case: Case) -> Any:
    """The paper gearbox configuration of ``case`` (a :class:`gear_rotor_sim.config.RigConfig`)."""
    from gear_rotor_sim.examples import paper_gearbox

    cfg = paper_gearbox(
        bearing_type=case.bearing_type, thermal_backlash=case.thermal_backlash, config=case.config
    )
    mesh_changes = {k: v for k, v in case.overrides if k in MESH_OVERRIDES}
    ray_changes = {k: v for k, v in case.overrides if k in RAYLEIGH_OVERRIDES}
    load_changes = {k: v for k, v in case.overrides if k in LOAD_OVERRIDES}
    cfg_changes = {k: v for k, v in case.overrides if k in CONFIG_OVERRIDES}
    known = MESH_OVERRIDES + RAYLEIGH_OVERRIDES + SYSTEM_OVERRIDES + LOAD_OVERRIDES + CONFIG_OVERRIDES
    unknown = {k for k, _ in case.overrides} - set(known)
    if unknown:
        raise ValueError(f"overrides: {sorted(unknown)} not in {known}")
    if mesh_changes:
        cfg = cfg.replace(meshes=tuple(dataclasses.replace(m, **mesh_changes) for m in cfg.meshes))
    if ray_changes:
        cfg = cfg.replace(rayleigh_damping=dataclasses.replace(cfg.rayleigh_damping, **ray_changes))
    if load_changes and cfg.load is not None:
        cfg = cfg.replace(load=dataclasses.replace(cfg.load, torque_nm=float(load_changes["load_torque_nm"])))
    if cfg_changes:
        cfg = _apply_config_overrides(cfg, cfg_changes)
    return cfg


def _apply_config_overrides(cfg: Any, changes: dict[str, float]) -> Any:
    """``cfg`` with the :data:`CONFIG_OVERRIDES` of ``changes`` applied (errors name the field)."""
    if "reference_temperature_c" in changes:
        cfg = cfg.replace(reference_temperature_c=float(changes["reference_temperature_c"]))
    if "shear_coefficient" in changes:
        mu = float(changes["shear_coefficient"])
        if not (np.isfinite(mu) and 0.0 < mu <= 2.0):
            raise ValueError(f"shear_coefficient: {mu!r} must be within (0, 2]")
        cfg = cfg.replace(shear_coefficient=mu)
    if "load_node" in changes and cfg.load is not None:
        node = changes["load_node"]
        n_nodes = sum(sh.n_nodes for sh in cfg.shafts)
        if not (float(node).is_integer() and 1 <= node <= n_nodes):
            raise ValueError(f"load_node: {node!r} must be a node number 1..{n_nodes}")
        cfg = cfg.replace(load=dataclasses.replace(cfg.load, node0=int(node) - 1))
    scale = float(changes.get("bearing_tilt_stiffness_scale", 1.0))
    if not (np.isfinite(scale) and scale > 0.0):
        raise ValueError(f"bearing_tilt_stiffness_scale: {scale!r} must be finite and > 0")
    tilt_c = changes.get("bearing_tilt_damping")
    if tilt_c is not None and not (np.isfinite(tilt_c) and tilt_c >= 0.0):
        raise ValueError(f"bearing_tilt_damping: {tilt_c!r} must be finite and >= 0 N m s/rad")
    if scale != 1.0 or tilt_c is not None:
        bearings = []
        for b in cfg.bearings:
            prop = dataclasses.replace(b.properties, k_tilt=b.properties.k_tilt * scale)
            if tilt_c is not None:
                prop = dataclasses.replace(prop, c_tilt=float(tilt_c))
            bearings.append(dataclasses.replace(b, properties=prop))
        cfg = cfg.replace(bearings=tuple(bearings))
    return cfg


class _ScaledStiffness:
    """``phase -> scale * k(phase)`` (a picklable replacement of ``MeshCoupling.stiffness``)."""

    def __init__(self, base: Callable[[np.ndarray], np.ndarray], scale: float) -> None:
        self.base, self.scale = base, float(scale)

    def __call__(self, phase: np.ndarray) -> np.ndarray:
        return self.scale * np.asarray(self.base(phase))


def _scale_jumps(jumps: np.ndarray, scale: float) -> np.ndarray:
    out = np.array(jumps, dtype=float)
    out[:, 1] *= scale  # the stiffness jumps; phases and coefficient jumps are unchanged
    return out


def scale_mesh_stiffness(system: Any, scale: float) -> Any:
    """The assembled system with every mesh stiffness multiplied by ``scale`` at every phase.

    ``MeshCoupling.stiffness`` (callable), ``table_stiffness`` (the compiled kernel's table) and
    ``mean_stiffness`` are scaled; the mesh damping ``c_m = 2 zeta sqrt(k_mean m_e)`` is scaled by
    ``sqrt(scale)`` so that the damping ratio ``zeta`` stays the configured one. The shape of the
    stiffness over the mesh cycle (single/double contact) is unchanged. ``scale = 1.34`` turns the
    potential-energy mean stiffness of the paper's gears (3.16e8 N/m at 25 C) into the ISO 6336-1
    ``c_gamma_alpha b`` value (4.23e8 N/m), see ``docs/mesh_stiffness.md``.

    Parameters
    ----------
    system : AssembledSystem
        Assembled system (``GearRotorSystem.from_config``).
    scale : float
        Positive, finite stiffness multiplier.
    """
    if not (np.isfinite(scale) and scale > 0):
        raise ValueError(f"mesh_stiffness_scale: {scale!r} must be finite and > 0")
    if scale == 1.0:
        return system
    meshes = tuple(
        dataclasses.replace(
            m,
            stiffness=_ScaledStiffness(m.stiffness, scale),
            mean_stiffness=float(m.mean_stiffness) * scale,
            damping=float(m.damping) * float(np.sqrt(scale)),
            table_stiffness=None if m.table_stiffness is None else np.asarray(m.table_stiffness) * scale,
            table_jumps=None if m.table_jumps is None else _scale_jumps(m.table_jumps, scale),
        )
        for m in system.meshes
    )
    return dataclasses.replace(system, meshes=meshes)


_SYSTEM_CACHE: dict[Case, Any] = {}


def build_system(case: Case) -> Any:
    """Assembled system of ``case`` (cached per process; forked workers inherit the cache)."""
    if case not in _SYSTEM_CACHE:
        from gear_rotor_sim.system import GearRotorSystem

        system = GearRotorSystem.from_config(build_config(case), case.temperature_c)
        for k, v in case.overrides:
            if k == "mesh_stiffness_scale":
                system = scale_mesh_stiffness(system, v)
        _SYSTEM_CACHE[case] = system
    return _SYSTEM_CACHE[case]


# ---------------------------------------------------------------------------------------------------
# One steady-state run (the only place that calls the simulator's runner)
# ---------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class RunSettings:
    """Integration window per speed.

    Attributes
    ----------
    n_transient_periods : int
        Mesh periods discarded before sampling (continuation runs).
    n_periods : int
        Mesh periods sampled after the transient.
    steps_per_mesh : int
        Newmark steps per mesh period while the teeth stay in contact (samples are kept at every step).
    first_transient_factor : float
        Transient multiplier for the first speed of a segment (no continuation state yet).
    contact_loss_rate_hz : float or None
        The default dt rule: once the teeth separate, at least this many steps per second with the
        events located (``simulate_steady``); None keeps ``steps_per_mesh`` throughout.
    """

    n_transient_periods: int = 300
    n_periods: int = 200
    steps_per_mesh: int = 32
    first_transient_factor: float = 4.0
    contact_loss_rate_hz: float | None = CONTACT_LOSS_RATE_HZ


def steady_run(
    system: Any,
    speed_rpm: float,
    settings: RunSettings,
    channels: Sequence[str],
    initial_state: Any = None,
    first: bool = False,
) -> tuple[np.ndarray, Any, RunSettings]:
    """Integrate to steady state at one speed and return per-step samples.

    Returns
    -------
    data : numpy.ndarray
        Shape ``(n_periods * spm, len(channels))`` with ``spm = used.steps_per_mesh``; sample ``k`` is
        step ``k + 1`` of the sampled window, so samples ``spm - 1, 2 spm - 1, ...`` are at mesh
        phase 0.
    state : object
        The simulator's final state, passed back as ``initial_state`` for the next speed.
    used : RunSettings
        ``settings`` with the steps per mesh period the dt rule chose for the sampled window.
    """
    from gear_rotor_sim.solver.steady import simulate_steady

    n_tr = settings.n_transient_periods
    if first or initial_state is None:
        n_tr = int(np.ceil(n_tr * settings.first_transient_factor))
    res, state = simulate_steady(
        system,
        float(speed_rpm),
        n_transient_periods=n_tr,
        n_periods=settings.n_periods,
        steps_per_mesh=settings.steps_per_mesh,
        channels=list(channels),
        initial_state=initial_state,
        sample="step",
        contact_loss_rate_hz=settings.contact_loss_rate_hz,
    )
    used = settings
    if res.steps_per_mesh != settings.steps_per_mesh:
        used = dataclasses.replace(settings, steps_per_mesh=res.steps_per_mesh)
    data = np.asarray(res.data, dtype=float)
    expected = (used.n_periods * used.steps_per_mesh, len(channels))
    if data.shape != expected:
        raise RuntimeError(f"simulate_steady returned shape {data.shape}, expected {expected}")
    return data, state, used


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


def mesh_period_s(system: Any, speed_rpm: float) -> float:
    """Mesh period of the (first) mesh of ``system`` at input speed ``speed_rpm``."""
    teeth = system.meshes[0].pinion_teeth
    return 60.0 / (float(speed_rpm) * teeth)


# ---------------------------------------------------------------------------------------------------
# Segment worker and execution (local processes or Dask)
# ---------------------------------------------------------------------------------------------------
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


def _tick() -> None:
    if _PROGRESS is not None:
        try:
            _PROGRESS.put_nowait(1)
        except (queue_mod.Full, OSError, ValueError):
            pass


def run_segment(
    case: Case,
    speeds_rpm: np.ndarray,
    settings: RunSettings,
    channels: Sequence[str],
    reducer: Callable[[np.ndarray, Sequence[str], RunSettings, float], dict],
) -> dict[str, np.ndarray]:
    """Run consecutive speeds of one case with continuation; stack the reducer's outputs.

    Returns
    -------
    dict
        Each reducer key stacked over speeds (first axis), plus ``wall_s`` per speed.
    """
    system = build_system(case)
    state = None
    rows: list[dict] = []
    walls = []
    for i, s in enumerate(np.asarray(speeds_rpm, dtype=float)):
        t0 = time.perf_counter()
        data, state, used = steady_run(system, s, settings, channels, state, first=(i == 0))
        dt = mesh_period_s(system, s) / used.steps_per_mesh
        rows.append(reducer(data, channels, used, dt))
        walls.append(time.perf_counter() - t0)
        _tick()
    out = {k: np.stack([r[k] for r in rows]) for k in rows[0]}
    out["wall_s"] = np.asarray(walls)
    return out


SegmentFn = Callable[..., dict]


def split_segments(n: int, n_segments: int) -> list[slice]:
    """Contiguous, nearly equal slices covering ``range(n)`` (no empty slice)."""
    n_segments = max(1, min(n_segments, n))
    bounds = np.linspace(0, n, n_segments + 1).round().astype(int)
    return [slice(int(a), int(b)) for a, b in itertools.pairwise(bounds) if b > a]


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
