"""Sweeps over speed x temperature x backlash model x bearing type (Figs 7-10 of the paper).

Every case of the grid is a :class:`~gear_rotor_sim.analysis.bifurcation.Case`; its speeds run with
continuation in contiguous segments, on local processes or on a Dask cluster, exactly like the
bifurcation sweep (:func:`~gear_rotor_sim.analysis.bifurcation.execute_tasks`). Per speed the sweep
keeps (all over the steady-state window, every integration step):

* ``bearing_rms`` ``(n_bearings, 3)``: RMS of the force each bearing transmits to the housing, x/y/z,
  N; ``bearing_total_rms`` ``(n_bearings,)`` = ``sqrt(rms_x^2 + rms_y^2 + rms_z^2)`` = RMS of the
  total force ``sqrt(Fx^2 + Fy^2 + Fz^2)`` (the paper's "total bearing force", Fig 7);
* ``bearing_mean`` ``(n_bearings, 3)``: mean force (the static thermal and load part), N;
* ``node_amp_max`` ``(n_nodes,)``: the largest total displacement ``sqrt(x^2 + y^2 + z^2)`` over the
  window, m (the Fig 8 "vibration displacement amplitude": the distance from the theoretical node
  position, see ``docs/analysis.md``); ``node_amp_rms``: its RMS; ``node_pp`` ``(n_nodes, 3)``:
  peak-to-peak of x, y, z (the oscillating part only);
* ``orbit`` ``(n_orbit_nodes, n, 2)``: x, y of the orbit nodes over the last mesh periods (Fig 10);
* the DTE Poincare section, as in the bifurcation sweep.

Results are saved to ``.npz`` (:meth:`SweepResult.save`), so figures redraw without re-simulating.
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import json
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gear_rotor_sim.analysis.bifurcation import (
    Case,
    RunSettings,
    SegmentFn,
    default_workers,
    execute_tasks,
    reduce_bifurcation,
    split_segments,
)

N_BEARINGS = 4
N_NODES = 18
DIRECTIONS = ("x", "y", "z")


def sweep_channels(n_bearings: int = N_BEARINGS, n_nodes: int = N_NODES) -> tuple[str, ...]:
    """Channel list of a sweep: DTE, bearing forces x/y/z, node displacements x/y/z."""
    ch = ["dte"]
    ch += [f"bearing{b}_f{d}" for b in range(1, n_bearings + 1) for d in DIRECTIONS]
    ch += [f"node{n}_{d}" for n in range(1, n_nodes + 1) for d in DIRECTIONS]
    return tuple(ch)


def reduce_sweep(
    data: np.ndarray,
    channels: Sequence[str],
    settings: RunSettings,
    dt: float,
    orbit_nodes: tuple[int, ...] = (9,),
    orbit_periods: int = 58,
    orbit_samples_per_mesh: int = 16,
) -> dict:
    """Per-speed statistics of a sweep (see the module docstring)."""
    ch = list(channels)
    out = reduce_bifurcation(data, ch, settings, dt)
    nb = sum(1 for c in ch if c.startswith("bearing") and c.endswith("_fx"))
    nn = sum(1 for c in ch if c.startswith("node") and c.endswith("_x"))
    fb = np.stack([data[:, [ch.index(f"bearing{b}_f{d}") for d in DIRECTIONS]] for b in range(1, nb + 1)], 1)
    rms = np.sqrt(np.mean(fb * fb, axis=0))
    out["bearing_rms"] = rms
    out["bearing_total_rms"] = np.sqrt(np.sum(rms * rms, axis=1))
    out["bearing_mean"] = fb.mean(axis=0)
    xyz = np.stack([data[:, [ch.index(f"node{n}_{d}") for d in DIRECTIONS]] for n in range(1, nn + 1)], 1)
    mag = np.sqrt(np.sum(xyz * xyz, axis=2))
    out["node_amp_max"] = mag.max(axis=0)
    out["node_amp_rms"] = np.sqrt(np.mean(mag * mag, axis=0))
    out["node_pp"] = np.ptp(xyz, axis=0)
    # the same number of orbit samples per mesh period whatever steps per mesh the dt rule chose
    spm = settings.steps_per_mesh
    n_p = min(orbit_periods, settings.n_periods)
    k = np.arange(n_p * orbit_samples_per_mesh)
    rows = data.shape[0] - n_p * spm + (k * spm) // orbit_samples_per_mesh
    orb = [data[rows][:, [ch.index(f"node{n}_x"), ch.index(f"node{n}_y")]] for n in orbit_nodes]
    out["orbit"] = np.stack(orb)
    return out


@dataclass
class SweepResult:
    """Grid sweep results, arrays shaped ``(n_cases, n_speeds, ...)``.

    Attributes
    ----------
    cases : list of Case
        One entry per grid point of temperature x backlash x bearing type (x overrides).
    speeds_rpm : numpy.ndarray
        Common speed grid, ``(n_speeds,)``.
    data : dict of numpy.ndarray
        Reduced outputs per case and speed (keys as in :func:`reduce_sweep`).
    settings : RunSettings
        Integration window per speed.
    orbit_nodes : tuple of int
        1-based nodes of the ``orbit`` array.
    wall_time_s : float
        Total wall time, set-up included.
    meta : dict
        Execution details.
    """

    cases: list[Case]
    speeds_rpm: np.ndarray
    data: dict[str, np.ndarray]
    settings: RunSettings
    orbit_nodes: tuple[int, ...]
    wall_time_s: float
    meta: dict = field(default_factory=dict)

    def index(
        self,
        temperature_c: float,
        bearing_type: str = "A#",
        thermal_backlash: bool = True,
        overrides: tuple[tuple[str, float], ...] = (),
        config: str | None = None,
    ) -> int:
        """Position of a case in :attr:`cases` (any ``config`` when None); KeyError listing them otherwise."""
        want = Case(float(temperature_c), bearing_type, thermal_backlash, tuple(overrides))
        for i, c in enumerate(self.cases):
            if c == dataclasses.replace(want, config=c.config if config is None else config):
                return i
        raise KeyError(f"case {want.label()} not in sweep; have {[c.label() for c in self.cases]}")

    def speed_index(self, speed_rpm: float) -> int:
        """Index of the grid speed nearest to ``speed_rpm``."""
        return int(np.argmin(np.abs(self.speeds_rpm - speed_rpm)))

    def get(self, key: str, case: int, speed_rpm: float | None = None) -> np.ndarray:
        """``data[key][case]`` (all speeds) or at the nearest grid speed."""
        arr = self.data[key][case]
        return arr if speed_rpm is None else arr[self.speed_index(speed_rpm)]

    def force_shares(self, case: int, speed_rpm: float, bearing: int = 2, kind: str = "rms") -> np.ndarray:
        """Share of the bearing force per direction (x, y, z), fractions summing to 1.

        Parameters
        ----------
        case : int
            Case index.
        speed_rpm : float
            Speed (nearest grid point).
        bearing : int
            1-based bearing number.
        kind : str
            ``"rms"``: ``F_i,rms / sum_j F_j,rms`` (shares of the RMS magnitudes, the pie-chart
            reading of Fig 9); ``"power"``: ``F_i,rms^2 / F_total,rms^2`` (shares of the mean
            square, which add up exactly to the total of Fig 7).
        """
        r = self.get("bearing_rms", case, speed_rpm)[bearing - 1]
        if kind == "rms":
            return r / r.sum()
        if kind == "power":
            return r * r / np.sum(r * r)
        raise ValueError(f"kind: {kind!r} is not 'rms' or 'power'")

    def save(self, path: str | Path) -> Path:
        """Write a compressed ``.npz`` with the arrays and JSON metadata."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        arrays = {f"data_{k}": v for k, v in self.data.items()}
        np.savez_compressed(
            path,
            kind=np.array("sweep"),
            cases=np.array(json.dumps([c.to_json() for c in self.cases])),
            settings=np.array(json.dumps(self.settings.__dict__)),
            meta=np.array(json.dumps(self.meta)),
            orbit_nodes=np.array(self.orbit_nodes, dtype=int),
            wall_time_s=np.array(self.wall_time_s),
            speeds_rpm=self.speeds_rpm,
            **arrays,
        )
        return path

    @staticmethod
    def load(path: str | Path) -> SweepResult:
        with np.load(path, allow_pickle=False) as z:
            if str(z["kind"]) != "sweep":
                raise ValueError(f"{path}: not a sweep result (kind={z['kind']})")
            return SweepResult(
                cases=[Case.from_json(c) for c in json.loads(str(z["cases"]))],
                speeds_rpm=z["speeds_rpm"],
                data={k[5:]: z[k] for k in z.files if k.startswith("data_")},
                settings=RunSettings(**json.loads(str(z["settings"]))),
                orbit_nodes=tuple(int(n) for n in z["orbit_nodes"]),
                wall_time_s=float(z["wall_time_s"]),
                meta=json.loads(str(z["meta"])),
            )


def grid_cases(
    temperatures_c: Sequence[float],
    bearing_types: Sequence[str] = ("A#",),
    thermal_backlash: Sequence[bool] = (True,),
    overrides: Sequence[tuple[tuple[str, float], ...]] = ((),),
) -> list[Case]:
    """Cartesian product of the grid axes as a list of cases (temperature varies slowest)."""
    return [
        Case(float(t), b, bool(bl), tuple(o))
        for t, bl, b, o in itertools.product(temperatures_c, thermal_backlash, bearing_types, overrides)
    ]


def run_sweep(
    cases: Sequence[Case],
    speeds_rpm: np.ndarray,
    settings: RunSettings | None = None,
    orbit_nodes: tuple[int, ...] = (9,),
    orbit_periods: int = 58,
    workers: int | None = None,
    scheduler: str | None = None,
    segments_per_worker: int = 1,
    progress: bool = True,
    segment_fn: SegmentFn | None = None,
    channels: Sequence[str] | None = None,
) -> SweepResult:
    """Run every case over ``speeds_rpm`` (continuation per segment) and reduce per speed.

    Parameters
    ----------
    cases : sequence of Case
        Grid points (see :func:`grid_cases`).
    speeds_rpm : numpy.ndarray
        Speeds, sorted increasing before the run.
    settings : RunSettings, optional
        Integration window per speed.
    orbit_nodes : tuple of int
        1-based nodes whose x-y orbit is kept (default node 9 = bearing 2).
    orbit_periods : int
        Mesh periods of orbit kept (58 = two input-shaft revolutions of the 29-tooth pinion).
    workers : int, optional
        Local processes (default: usable cores); ``1`` runs in this process.
    scheduler : str, optional
        Dask scheduler address.
    segments_per_worker : int
        Target segments per worker over the whole grid.
    progress : bool
        Progress line on stderr.
    segment_fn : callable, optional
        Alternative segment runner (tests).
    channels : sequence of str, optional
        Override of :func:`sweep_channels` (a system with other node/bearing counts).
    """
    t0 = time.perf_counter()
    settings = settings or RunSettings()
    speeds = np.sort(np.asarray(speeds_rpm, dtype=float))
    if speeds.size == 0 or np.any(~np.isfinite(speeds)) or np.any(speeds <= 0):
        raise ValueError("speeds_rpm: need at least one positive, finite speed")
    if not cases:
        raise ValueError("cases: at least one case is required")
    n_workers = 1 if scheduler is None and workers == 1 else (workers or default_workers())
    per_case = max(1, int(np.ceil(n_workers * max(1, segments_per_worker) / len(cases))))
    tasks, owner = [], []
    for ci, case in enumerate(cases):
        for sl in split_segments(speeds.size, per_case):
            tasks.append((case, speeds[sl]))
            owner.append(ci)
    reducer = functools.partial(reduce_sweep, orbit_nodes=tuple(orbit_nodes), orbit_periods=orbit_periods)
    parts = execute_tasks(
        tasks,
        settings,
        tuple(channels) if channels is not None else sweep_channels(),
        reducer,
        workers=n_workers,
        scheduler=scheduler,
        progress=progress,
        label=f"sweep [{len(cases)} case(s) x {speeds.size} speed(s)]",
        segment_fn=segment_fn,
    )
    data: dict[str, np.ndarray] = {}
    for key in parts[0]:
        per = [
            np.concatenate([p[key] for p, o in zip(parts, owner, strict=True) if o == ci])
            for ci in range(len(cases))
        ]
        data[key] = np.stack(per)
    return SweepResult(
        cases=list(cases),
        speeds_rpm=speeds,
        data=data,
        settings=settings,
        orbit_nodes=tuple(orbit_nodes),
        wall_time_s=time.perf_counter() - t0,
        meta={"workers": n_workers, "scheduler": scheduler or "", "segments": len(tasks)},
    )
