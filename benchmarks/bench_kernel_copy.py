"""The gear kernel against a copy of itself: outputs bit for bit, and speed interleaved.

Two checks for a change of ``gear_rotor_sim/solver/gear_kernel.py`` that must not change the numbers
(docs/solver.md, "Session 12"):

``bitwise``: the paper gearbox's 16 default channels (and the two-stage example's default channels)
with a tooth-damage effect at 3000 (also with ``locate_events=True``) / 8000 / 20000 rpm,
``event_average`` on and off,
``average_table_jumps`` on and off, 0.2 s from the static equilibrium. ``--save FILE`` writes them
(run it on the code before the change, or with ``--kernel`` a copy of it), ``--compare FILE``
compares the installed code's outputs with them: exact equality, array by array. The eigenbases are
computed in the run (``GEAR_ROTOR_SIM_BASIS_CACHE=off``): the shared disk cache may hold a basis
written by another process with another BLAS thread count, a round-off difference not the kernel's.

``timing``: ``Simulator.advance`` (DTE only) with the installed kernel and with copies of the kernel
compiled from other source files as other modules (``--copy PATH``, repeatable; e.g. the unchanged
source from ``git show main:gear_rotor_sim/solver/gear_kernel.py``), alternated in one process, CPU
time (``time.process_time``) per simulated second, medians of ``--runs`` alternated runs (session
9's method: two copies of the same source show the placement noise).

``flatten OUT``: the installed gear kernel, split into modules of one role each since session 17
(docs/solver.md, "Module layout"), written as one self-contained source (:func:`flat_source`), so
that ``--copy``, ``--kernel`` and ``--against`` can take a copy of it (and
``profile_event_steps.py sections`` instrument it).

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_kernel_copy.py bitwise --save
/tmp/ref.npz`` (about a minute), ``... bitwise --compare /tmp/ref.npz``, ``... timing --copy
/tmp/gear_kernel_main.py --copy /tmp/gear_kernel_main2.py [--rpm 20000] [--runs 9]
[--average-table-jumps]``.
"""

from __future__ import annotations

import argparse
import ast
import importlib.util
import os
import statistics
import sys
import time

import numpy as np

from gear_rotor_sim.config import load_config
from gear_rotor_sim.examples import paper_gearbox
from gear_rotor_sim.faults import ToothDamage
from gear_rotor_sim.simulator import Simulator
from gear_rotor_sim.solver import gear_kernel

SPEEDS_RPM = (3000.0, 8000.0, 20000.0)
#: The gear kernel's modules in the order their names are defined (docs/solver.md, "Module layout").
KERNEL_MODULES = ("gear_tables", "gear_mesh_solve", "gear_events", "gear_jumps", "gear_output", "gear_step",
                  "gear_loop", "gear_kernel")  # fmt: skip
DURATION_S = 0.2


def _cases() -> list[tuple[str, object, float, dict]]:
    cases = []
    for rpm in SPEEDS_RPM:
        for ea in (True, False):
            for aj in (False, True):
                kw = {"event_average": ea, "average_table_jumps": aj}
                cases.append((f"paper_{rpm:.0f}_ea{int(ea)}_aj{int(aj)}", paper_gearbox(), rpm, kw))
                if rpm == SPEEDS_RPM[0]:  # in continuous contact the rule locates nothing: force it
                    kw = {**kw, "locate_events": True}
                    name = f"paper_{rpm:.0f}_located_ea{int(ea)}_aj{int(aj)}"
                    cases.append((name, paper_gearbox(), rpm, kw))
    for ea in (True, False):
        kw = {"event_average": ea, "average_table_jumps": False}
        cases.append((f"two_stage_3000_ea{int(ea)}", load_config("two_stage_example"), 3000.0, kw))
    return cases


def run_cases() -> dict[str, np.ndarray]:
    """The outputs of every case (the stream, and the stepper's carried state at the end)."""
    res: dict[str, np.ndarray] = {}
    for name, cfg, rpm, kw in _cases():
        eff = [ToothDamage(tooth=3, depth=0.3, wheel="pinion")]
        sim = Simulator(cfg, rpm, 25.0, 20000.0, effects=eff, **kw)  # type: ignore[arg-type]
        blocks = [np.asarray(sim.advance(0.1).data) for _ in range(round(DURATION_S / 0.1))]
        res[name] = np.concatenate(blocks)
        res[name + "_substeps"] = np.array([sim._stepper.n_substeps])
        print(f"  {name}: {res[name].shape[0]} samples x {res[name].shape[1]} channels", flush=True)
    return res


def _arrays(x: object) -> list[np.ndarray]:
    """The arrays of a nested tuple of kernel arguments, in order."""
    if isinstance(x, np.ndarray):
        return [x]
    if isinstance(x, tuple | list):
        return [a for y in x for a in _arrays(y)]
    return []


def _root(x: np.ndarray) -> np.ndarray:
    while isinstance(x.base, np.ndarray):
        x = x.base
    return x


def _same_layout_copy(x: object, roots: dict | None = None) -> object:
    """A deep copy of nested kernel arguments that keeps each array's layout (numba compiles one
    version per layout) and which arrays share memory (views of one buffer stay views of one copy:
    the kernel's output arrays may alias)."""
    if roots is None:
        roots = {}
    if isinstance(x, np.ndarray):
        r = _root(x)
        rc = roots.get(id(r))
        if rc is None:
            rc = r.copy(order="F" if r.flags.f_contiguous and not r.flags.c_contiguous else "C")
            assert rc.strides == r.strides, "a non-contiguous buffer"
            roots[id(r)] = rc
        off = x.__array_interface__["data"][0] - r.__array_interface__["data"][0]
        return np.ndarray(x.shape, x.dtype, buffer=rc, offset=off, strides=x.strides)
    if isinstance(x, tuple):
        return tuple(_same_layout_copy(y, roots) for y in x)
    if isinstance(x, list):
        return [_same_layout_copy(y, roots) for y in x]
    return x


def against(path: str) -> int:
    """Every ``run_chunk_gear`` call of the cases made twice on identical inputs: by the copy at
    ``path`` (on a deep copy of the arguments) and by the installed kernel; every array the kernel
    writes (state, carry, outputs) and the returned tuple compared bit for bit."""
    ref_fn = _load_copy(path).run_chunk_gear  # type: ignore[attr-defined]
    orig = gear_kernel.run_chunk_gear
    stats = {"calls": 0, "differ": 0, "steps": 0, "substeps": 0}

    def both(*a: object) -> object:
        b = _same_layout_copy(a)
        rb = ref_fn(*b)
        ra = orig(*a)
        stats["calls"] += 1
        stats["steps"] += int(ra[1])
        stats["substeps"] += int(ra[3])
        same = tuple(ra) == tuple(rb) and all(
            x.shape == y.shape and np.array_equal(x, y, equal_nan=True)
            for x, y in zip(_arrays(a), _arrays(b), strict=True)
        )
        if not same:
            stats["differ"] += 1
            bad = [
                f"#{i} {x.shape} {np.max(np.abs(x - y)):.2e}"
                for i, (x, y) in enumerate(zip(_arrays(a), _arrays(b), strict=True))
                if not np.array_equal(x, y, equal_nan=True)
            ]
            print(
                f"    call {stats['calls']} differs: {tuple(ra)} {tuple(rb)} arrays {', '.join(bad)}",
                flush=True,
            )
        return ra

    gear_kernel.run_chunk_gear = both
    try:
        run_cases()
    finally:
        gear_kernel.run_chunk_gear = orig
    print(
        f"{stats['calls'] - stats['differ']} of {stats['calls']} kernel calls bit for bit equal to {path} "
        f"({stats['steps']} steps, {stats['substeps']} sub-steps)"
    )
    return 1 if stats["differ"] else 0


def bitwise(save: str, compare: str, kernel: str) -> int:
    # bases computed here, not read from the shared disk cache (another process may have written a
    # basis there with other BLAS threads: a round-off difference that is not the kernel's)
    os.environ["GEAR_ROTOR_SIM_BASIS_CACHE"] = "off"
    orig = gear_kernel.run_chunk_gear
    if kernel:  # a copy of the kernel instead of the installed one
        gear_kernel.run_chunk_gear = _load_copy(kernel).run_chunk_gear  # type: ignore[attr-defined]
    try:
        res = run_cases()
    finally:
        gear_kernel.run_chunk_gear = orig
    if save:
        np.savez(save, **res)
        print(f"saved {len(res)} arrays to {save}")
        return 0
    ref = np.load(compare)
    bad = 0
    for k, v in res.items():
        r = ref[k]
        same = r.shape == v.shape and np.array_equal(r, v, equal_nan=True)
        if not same:
            bad += 1
            diff = float(np.max(np.abs(r - v))) if r.shape == v.shape else float("nan")
            print(f"  DIFFERS {k}: max |diff| {diff:.3e}")
    print(f"{len(res) - bad} of {len(res)} arrays bit for bit equal to {compare}")
    return 1 if bad else 0


def flat_source() -> str:
    """The installed gear kernel's modules (:data:`KERNEL_MODULES`) as one source: their module
    docstrings and imports dropped, the names they take from :mod:`gear_rotor_sim.solver.kernels`
    imported once at the top, the bodies in order, unchanged."""
    folder = os.path.dirname(gear_kernel.__file__)
    from_kernels: set[str] = set()
    bodies = []
    for mod in KERNEL_MODULES:
        with open(os.path.join(folder, mod + ".py"), encoding="utf-8") as fh:
            src = fh.read()
        tree = ast.parse(src)
        drop: set[int] = set()
        for k, node in enumerate(tree.body):
            doc = k == 0 and isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant)
            if isinstance(node, ast.ImportFrom) and node.module == "gear_rotor_sim.solver.kernels":
                from_kernels.update(a.name for a in node.names)
            if doc or isinstance(node, ast.Import | ast.ImportFrom):
                drop.update(range(node.lineno - 1, node.end_lineno or node.lineno))
        lines = src.split("\n")
        bodies.append("\n".join(ln for i, ln in enumerate(lines) if i not in drop).strip("\n"))
    head = (
        f'"""The gear kernel of {folder} as one source (bench_kernel_copy.py flatten)."""\n\n'
        "from __future__ import annotations\n\nimport numpy as np\nfrom numba import njit\n\n"
        f"from gear_rotor_sim.solver.kernels import {', '.join(sorted(from_kernels))}\n"
    )
    return head + "\n\n" + "\n\n\n".join(bodies) + "\n"


def _load_copy(path: str) -> object:
    # one module name per file: numba's cache of the copy re-imports its module by that name
    stem = "".join(c if c.isalnum() else "_" for c in os.path.splitext(os.path.basename(path))[0])
    spec = importlib.util.spec_from_file_location(f"gear_kernel_copy_{stem}", path)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


def timing(copies: list[str], rpm: float, runs: int, chunk_s: float, average_jumps: bool) -> None:
    kernels = {"installed": gear_kernel.run_chunk_gear}
    for i, p in enumerate(copies):
        kernels[f"copy{i + 1}"] = _load_copy(p).run_chunk_gear  # type: ignore[attr-defined]
    orig = gear_kernel.run_chunk_gear
    sims = {}
    try:
        for k, fn in kernels.items():
            gear_kernel.run_chunk_gear = fn
            sims[k] = Simulator(
                paper_gearbox(), rpm, 25.0, 20000.0, channels=["dte"], average_table_jumps=average_jumps
            )
            sims[k].advance(0.3)  # compiles, settles
        cpu: dict[str, list[float]] = {k: [] for k in kernels}
        load0 = os.getloadavg()[0]
        for _ in range(runs):
            for k, fn in kernels.items():
                gear_kernel.run_chunk_gear = fn
                c0 = time.process_time()
                sims[k].advance(chunk_s)
                cpu[k].append((time.process_time() - c0) / chunk_s)
        load1 = os.getloadavg()[0]
    finally:
        gear_kernel.run_chunk_gear = orig
    opt = ", average_table_jumps" if average_jumps else ""
    print(
        f"{rpm:.0f} rpm, DTE only{opt}, {runs} alternated runs of {chunk_s} s, load {load0:.1f}->{load1:.1f}"
    )
    print("  CPU ms per simulated s, median (min-max), CPU RTF of the median")
    for k, v in cpu.items():
        med = statistics.median(v)
        src = "installed" if k == "installed" else copies[int(k[4:]) - 1]
        print(f"  {k:9s} {1e3 * med:7.2f} ({1e3 * min(v):.2f}-{1e3 * max(v):.2f}), RTF {1 / med:6.2f}  {src}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    b = sub.add_parser("bitwise")
    g = b.add_mutually_exclusive_group(required=True)
    g.add_argument("--save", default="")
    g.add_argument("--compare", default="")
    g.add_argument(
        "--against", default="", help="a copy of gear_kernel.py run on the same inputs, call by call"
    )
    b.add_argument(
        "--kernel", default="", help="a copy of gear_kernel.py to run instead of the installed one"
    )
    f = sub.add_parser("flatten")
    f.add_argument("out")
    t = sub.add_parser("timing")
    t.add_argument("--copy", action="append", default=[])
    t.add_argument("--rpm", type=float, default=20000.0)
    t.add_argument("--runs", type=int, default=9)
    t.add_argument("--chunk", type=float, default=0.5)
    t.add_argument("--average-table-jumps", action="store_true", help="Simulator(average_table_jumps=True)")
    args = ap.parse_args()
    if args.cmd == "bitwise" and args.against:
        return against(args.against)
    if args.cmd == "bitwise":
        return bitwise(args.save, args.compare, args.kernel)
    if args.cmd == "flatten":
        with open(args.out, "w", encoding="utf-8") as fh:
            fh.write(flat_source())
        print(f"wrote {args.out}")
        return 0
    timing(args.copy, args.rpm, args.runs, args.chunk, args.average_table_jumps)
    return 0


if __name__ == "__main__":
    sys.exit(main())
