"""Bit-for-bit capture of the solver's outputs over every path of the gear kernel and the Simulator.

For a change of ``gear_rotor_sim/solver/`` or ``gear_rotor_sim/simulator.py`` that must not change a
number (a split of a module, a regrouping of a kernel's arrays; docs/solver.md, "Module layout" and
"Session 17"). ``--save FILE`` writes the outputs of the cases below (run it on the code before
the change), ``--compare FILE`` runs them again on the installed code and compares every array with
``np.array_equal`` (NaN equal to NaN). The cases (``CASES``) exercise:

* the paper gearbox at 3000, 8000 (rattle), 12000 and 20000 rpm, default (reduced) and full basis;
* events located on / off (the dt rule's choice, forced on at 3000 rpm, forced off at 20000 rpm),
  ``event_average`` on / off, ``average_table_jumps``, the exact modal map forced on;
* a speed ramp (3000 -> 3600 rpm) and a temperature ramp (25 -> 35 C);
* the two-stage example (two meshes, issue 15) at 3000 and 12000 rpm, an effect on mesh 2;
* effects: tooth damage, gear eccentricity, an outer-race bearing defect, a tilted gear
  misalignment (the streamed mesh-force orders);
* output decimation: 5 kHz and 50 kHz output against the default 20 kHz, another channel set;
* the modal update mode by mode instead of the fused pass (``_plain``).

Per case: the stream (channels, speed and temperature columns), the chunk statistics of the last
``advance``, the stepper's sub-step and failed-solve counts and the carried ``SolverState``.
The eigenbases are computed in the run (``GEAR_ROTOR_SIM_BASIS_CACHE=off``: the shared disk cache
may hold a basis written with other BLAS threads, a round-off difference that is not the code's);
run with ``OPENBLAS_NUM_THREADS=1``, nothing else of yours running (docs/solver.md, "Session 12":
main's unchanged kernel was not reproducible bit for bit otherwise). The kernels are compiled in the
run, into a fresh ``NUMBA_CACHE_DIR`` (``--use-numba-cache``: the project's cache instead), so that
both sides of a comparison run alike: the same source gives other round-off when its kernels are
loaded from numba's cache than when they are compiled in the process (session 17, main's unchanged
code: 226 of 330 arrays equal between the two; the set-up's arrays are equal, the kernels'
results are not).

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/kernel_bitwise.py --save /tmp/ref.npz``
(about two minutes plus the kernels' compilation), then after the change ``... --compare
/tmp/ref.npz`` (exit status 1 if any array differs; repeatable, e.g. for cases saved later with
``--cases``). ``--cases SUBSTR`` runs the cases whose name
holds SUBSTR (repeatable).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from collections.abc import Callable
from typing import Any

import numpy as np

os.environ["GEAR_ROTOR_SIM_BASIS_CACHE"] = "off"
if "--use-numba-cache" not in sys.argv:  # kernels compiled in this process (see the docstring)
    os.environ["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix="kernel_bitwise_numba_")

from gear_rotor_sim.config import load_config
from gear_rotor_sim.examples import paper_gearbox
from gear_rotor_sim.faults import (
    BearingDefect,
    GearEccentricity,
    GearMisalignment,
    ToothDamage,
)
from gear_rotor_sim.simulator import Simulator

DURATION_S = 0.2
CHUNK_S = 0.05

_TOOTH = ToothDamage(tooth=3, depth=0.3, wheel="pinion")
_ECC = GearEccentricity(member="gear", eccentricity_m=20e-6, phase_rad=0.4)
_BEARING = BearingDefect(kind="outer", bearing=2, force_n=200.0)
_TILT = GearMisalignment(angle_rad=2e-4, phase_rad=0.3)


def _paper(rpm: float, effects: tuple = (), rate: float = 20000.0, **kw: Any) -> Callable[[], Simulator]:
    return lambda: Simulator(paper_gearbox(), rpm, 25.0, rate, effects=effects, **kw)


def _two_stage(rpm: float, **kw: Any) -> Callable[[], Simulator]:
    eff = (ToothDamage(tooth=5, depth=0.4, wheel="gear", mesh=2),)
    return lambda: Simulator(load_config("two_stage_example"), rpm, 25.0, 20000.0, effects=eff, **kw)


def _plain(factory: Callable[[], Simulator]) -> Callable[[], Simulator]:
    """The same Simulator with the gear kernel's modal update mode by mode (``fuse_meshes=False``, the
    path of more than two meshes or four columns a mesh), on its stepper at constant set-points."""

    def make() -> Simulator:
        sim = factory()
        sim._stepper.fuse_meshes = False
        return sim

    return make


#: name -> (Simulator factory, set-points applied after the first chunk or None)
CASES: dict[str, tuple[Callable[[], Simulator], tuple[float | None, float | None] | None]] = {
    "paper_3000": (_paper(3000.0), None),
    "paper_3000_located_ea1": (_paper(3000.0, (_TOOTH,), locate_events=True), None),
    "paper_3000_located_ea0": (_paper(3000.0, (_TOOTH,), locate_events=True, event_average=False), None),
    "paper_3000_full": (_paper(3000.0, (_ECC,), modal_cutoff_hz=None), None),
    "paper_3000_exact": (_paper(3000.0, (_TOOTH,), exact_modal_map=True), None),
    "paper_8000_rattle_ea1": (_paper(8000.0, (_TOOTH,)), None),
    "paper_8000_rattle_ea0": (_paper(8000.0, (_TOOTH,), event_average=False), None),
    "paper_12000_ecc": (_paper(12000.0, (_ECC,)), None),
    "paper_12000_bearing": (_paper(12000.0, (_BEARING,), event_average=False), None),
    "paper_20000_ea1": (_paper(20000.0, (_TOOTH,)), None),
    "paper_20000_ea0": (_paper(20000.0, (_TOOTH,), event_average=False), None),
    "paper_20000_avgjumps": (_paper(20000.0, (_TOOTH,), average_table_jumps=True), None),
    "paper_20000_full": (_paper(20000.0, (_BEARING,), modal_cutoff_hz=None), None),
    "paper_20000_unlocated": (_paper(20000.0, (_TOOTH,), locate_events=False), None),
    "paper_3000_misalignment": (_paper(3000.0, (_TILT,)), None),
    "paper_3000_out5k": (_paper(3000.0, (_TOOTH,), rate=5000.0), None),
    "paper_8000_out50k_channels": (
        _paper(8000.0, (_ECC,), rate=50000.0, channels=["dte", "mesh_force", "bearing1_fx", "node5_ay"]),
        None,
    ),
    "ramp_speed_3000_3600": (_paper(3000.0, (_TOOTH,)), (3600.0, None)),
    "ramp_temperature_25_35": (_paper(3000.0, (_TOOTH,)), (None, 35.0)),
    "two_stage_3000": (_two_stage(3000.0), None),
    "two_stage_3000_ea0_located": (_two_stage(3000.0, event_average=False, locate_events=True), None),
    "two_stage_12000": (_two_stage(12000.0), None),
    "paper_20000_plain_update": (_plain(_paper(20000.0, (_TOOTH,))), None),
    "two_stage_3000_plain_update": (_plain(_two_stage(3000.0, locate_events=True)), None),
}


def run_case(name: str) -> dict[str, np.ndarray]:
    """The arrays of one case (keys prefixed with the case name)."""
    factory, targets = CASES[name]
    sim = factory()
    blocks = []
    for i in range(round(DURATION_S / CHUNK_S)):
        if i == 1 and targets is not None:
            sim.set_targets(*targets)
        blocks.append(sim.advance(CHUNK_S))
    out = {
        "data": np.concatenate([np.asarray(b.data) for b in blocks]),
        "speed": np.concatenate([np.asarray(b.speed_rpm) for b in blocks]),
        "temperature": np.concatenate([np.asarray(b.temperature_c) for b in blocks]),
        "stats": np.array([v for k, v in sorted(sim.last_chunk_stats.items()) if k != "wall_s"]),
        "counts": np.array([sim._stepper.n_substeps, sim._stepper.n_mesh_fail]),
    }
    st = sim.state
    for k, v in vars(st).items():
        out["state_" + k] = np.asarray(v)
    return {f"{name}/{k}": np.asarray(v) for k, v in out.items()}


def run_cases(names: list[str]) -> dict[str, np.ndarray]:
    res: dict[str, np.ndarray] = {}
    for name in names:
        t0 = time.process_time()
        arrs = run_case(name)
        res.update(arrs)
        print(f"  {name}: {len(arrs)} arrays, {time.process_time() - t0:.1f} s CPU", flush=True)
    return res


def compare(res: dict[str, np.ndarray], paths: list[str]) -> int:
    """Arrays of ``res`` against those saved in ``paths``, bit for bit; returns the number differing."""
    ref: dict[str, np.ndarray] = {}
    for p in paths:
        with np.load(p) as f:
            ref.update({k: f[k] for k in f.files})
    path = " + ".join(paths)
    bad = 0
    for k, v in res.items():
        if k not in ref:
            print(f"  MISSING in {path}: {k}")
            bad += 1
            continue
        r = ref[k]
        if not (r.shape == v.shape and r.dtype == v.dtype and np.array_equal(r, v, equal_nan=True)):
            bad += 1
            diff = float(np.nanmax(np.abs(r - v))) if r.shape == v.shape and r.size else float("nan")
            print(f"  DIFFERS {k}: shape {r.shape} -> {v.shape}, max |diff| {diff:.3e}")
    print(f"{len(res) - bad} of {len(res)} arrays bit for bit equal to {path}")
    return bad


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--save", default="")
    g.add_argument("--compare", action="append", default=[], help="saved outputs (repeatable)")
    ap.add_argument("--cases", action="append", default=[], help="substring of the case names")
    ap.add_argument("--use-numba-cache", action="store_true", help="the project's numba cache")
    args = ap.parse_args()
    names = [n for n in CASES if not args.cases or any(s in n for s in args.cases)]
    t0 = time.time()
    res = run_cases(names)
    print(f"{len(names)} cases in {time.time() - t0:.0f} s wall, load {os.getloadavg()[0]:.1f}")
    if args.save:
        np.savez(args.save, **res)
        print(f"saved {len(res)} arrays to {args.save}")
        return 0
    return 1 if compare(res, args.compare) else 0


if __name__ == "__main__":
    sys.exit(main())
