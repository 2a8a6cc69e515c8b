"""Where the gear kernel's time goes at 20000 rpm, by source line (perf samples mapped by gdb).

Issue 13 (docs/solver.md, "Session 16"): on a chunk captured from ``Simulator.advance`` (paper
gearbox, 25 C, DTE only, default reduced basis) the kernel runs 0.22 us per step with the events
located and 0.09 us without; this script says where.

``capture PATH``: the longest ``run_chunk_gear`` call of a 0.05 s ``advance`` after 0.3 s
(``bench_solver._capture_chunk``), pickled.

``loop PATH --seconds S``: that call repeated on fresh copies of its arguments for ``S`` seconds
(prints ``ready PID`` once warm).

``profile PATH``: runs ``loop`` in a child compiled with ``NUMBA_DEBUGINFO=1`` (its own numba cache
directory, so the debug build does not replace the project's cached kernels), samples it with
``perf record`` (user space, the child's PID) and maps every sampled instruction address to its
function and source line with ``gdb`` attached to the child (numba registers its objects through
LLVM's GDB JIT interface). Prints the share of the samples per function (shared libraries: libm's
``sin``/``cos``/``exp``) and per line of the gear kernel's modules (``gear_events.py``,
``gear_loop.py``, ``gear_mesh_solve.py``, ...; docs/solver.md "Module layout"), grouped by the parts
of the step (``--top`` lines). The debug build is the optimised code plus line tables; its time per step is
printed so that it can be compared with the project's build.

``dense PATH``: the cost per sub-step with the event steps sparse and dense (:func:`dense`).

``sections PATH``: the event step's sections timed in place by the time-stamp counter, in an
instrumented copy of the kernel (:func:`sections`, :func:`instrument`).

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/profile_event_steps.py capture /tmp/c20k.pkl``
then ``... profile /tmp/c20k.pkl`` (about a minute; needs ``perf`` and ``gdb``).
"""

from __future__ import annotations

import argparse
import collections
import copy
import itertools
import os
import pickle
import re
import subprocess
import sys
import tempfile
import time

import numpy as np


def capture(path: str, rpm: float, cutoff: object) -> None:
    """Pickle the arguments of the longest kernel call of a 0.05 s ``advance`` (DTE only)."""
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from bench_solver import _capture_chunk

    from gear_rotor_sim.examples import paper_gearbox

    args = _capture_chunk(paper_gearbox(), rpm, ["dte"], cutoff)
    with open(path, "wb") as fh:
        pickle.dump(args, fh)
    print(f"captured {args[4][0].shape[0] - 1} steps at {rpm:.0f} rpm -> {path}")


def loop(path: str, seconds: float) -> None:
    """Run the captured call repeatedly (fresh copies of its arguments) for ``seconds``."""
    from gear_rotor_sim.solver import gear_kernel

    with open(path, "rb") as fh:
        args = pickle.load(fh)
    n = args[4][0].shape[0] - 1
    gear_kernel.run_chunk_gear(*copy.deepcopy(args))  # compile or load
    cpus = []
    print(f"ready {os.getpid()}", flush=True)
    t_end = time.perf_counter() + seconds
    while time.perf_counter() < t_end:
        a = copy.deepcopy(args)
        c0 = time.process_time()
        out = gear_kernel.run_chunk_gear(*a)
        cpus.append(time.process_time() - c0)
    print(
        f"done {len(cpus)} runs, {1e6 * float(np.median(cpus)) / n:.3f} us per step (CPU median), "
        f"{out[3] / n:.3f} committed sub-steps per step",
        flush=True,
    )


def _gdb_lines(pid: int, addrs: list[int]) -> dict[int, tuple[str, int, str]]:
    """(function, offset in it, 'file:line' or '?') of each address, by ``gdb -p PID -batch``."""
    with tempfile.NamedTemporaryFile("w", suffix=".gdb", delete=False) as fh:
        for a in addrs:
            fh.write(f"echo @@{a:#x}\\n\ninfo symbol {a:#x}\ninfo line *{a:#x}\n")
        cmd = fh.name
    res = subprocess.run(
        ["gdb", "-p", str(pid), "-batch", "-nx", "-x", cmd], capture_output=True, text=True, timeout=900
    )
    os.unlink(cmd)
    out: dict[int, tuple[str, int, str]] = {}
    cur = None
    for line in res.stdout.splitlines():
        if line.startswith("@@"):
            cur = int(line[2:], 16)
            out[cur] = ("?", -1, "?")
        elif cur is not None:
            f, off, ln = out[cur]
            m = re.match(r"(\S+) \+ (\d+) in section", line)
            if m and f == "?":
                f, off = _short(m.group(1)), int(m.group(2))
            m = re.match(r'Line (\d+) of "([^"]+)"', line)
            if m and ln == "?":
                ln = f"{os.path.basename(m.group(2))}:{m.group(1)}"
            out[cur] = (f, off, ln)
    return out


def _short(fn: str) -> str:
    """The Python name in a numba symbol (``...6solver9gear_loop9_run_loopB3v22...`` -> ``_run_loop``)."""
    m = re.search(r"(?:solver\d+gear_[a-z_]+?|kernels)(\d+)(?=_)", fn)
    if m is None:
        return fn[:60]
    n = int(m.group(1))
    return fn[m.end() : m.end() + n]


def perf_samples(pid: int, seconds: float) -> tuple[int, collections.Counter[int], collections.Counter[str]]:
    """``perf record`` of process ``pid`` for ``seconds`` (user space, 4 kHz): the number of samples, the
    samples per address in JIT code (numba's) and per shared-library symbol."""
    data = tempfile.mktemp(suffix=".perf")
    try:
        subprocess.run(
            ["perf", "record", "-q", "-e", "cpu-clock", "-F", "4000", "-p", str(pid), "-o", data, "--",
             "sleep", str(seconds)],
            check=True,
            capture_output=True,
        )  # fmt: skip
        rep = subprocess.run(
            ["perf", "script", "-i", data, "-F", "ip,sym,dso"], capture_output=True, text=True, check=True
        ).stdout
    finally:
        if os.path.exists(data):
            os.unlink(data)
    ips: collections.Counter[int] = collections.Counter()
    lib: collections.Counter[str] = collections.Counter()
    total = 0
    for ln in rep.splitlines():
        parts = ln.split()
        if not parts:
            continue
        total += 1
        dso = parts[-1]
        if any(k in dso for k in ("unknown", "anon", "JIT", "perf-")):
            ips[int(parts[0], 16)] += 1
        else:
            lib[f"{os.path.basename(dso.strip('()'))}:{' '.join(parts[1:-1]).split('+')[0]}"] += 1
    return total, ips, lib


def profile(
    path: str, seconds: float, top: int, groups: list[tuple[str, str, int, int]], debuginfo: bool
) -> None:
    env = dict(os.environ)
    if debuginfo:  # line tables; its own cache directory (the project's cached kernels stay as they are)
        env.update(NUMBA_DEBUGINFO="1", NUMBA_CACHE_DIR=tempfile.mkdtemp(prefix="nb_dbg_"))
    child = subprocess.Popen(
        [sys.executable, __file__, "loop", path, "--seconds", str(seconds + 600.0)],
        env=env,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert child.stdout is not None
    pid = int(child.stdout.readline().split()[1])
    total, ips, lib = perf_samples(pid, seconds)
    where = _gdb_lines(pid, sorted(ips))
    child.terminate()
    child.wait(timeout=60)
    by_fn: collections.Counter[str] = collections.Counter()
    by_line: collections.Counter[str] = collections.Counter()
    blocks: dict[str, collections.Counter[int]] = collections.defaultdict(collections.Counter)
    extent: dict[str, int] = collections.defaultdict(int)
    for ip, c in ips.items():
        fn, off, ln = where.get(ip, ("?", -1, "?"))
        by_fn[fn] += c
        by_line[ln] += c
        if off >= 0:
            blocks[fn][off // 2048] += c
            extent[fn] = max(extent[fn], off)
    for k, c in lib.items():
        by_fn[k] += c
    build = "debug build: line tables" if debuginfo else "the project build"
    print(f"\n{total} samples ({build}); by function:")
    for k, c in by_fn.most_common(12):
        print(f"  {100.0 * c / total:6.2f} %  {k}")
    for fn, bl in blocks.items():
        if sum(bl.values()) < 0.1 * total:
            continue
        n90, acc = 0, 0
        for _, c in bl.most_common():
            acc += c
            n90 += 1
            if acc >= 0.9 * sum(bl.values()):
                break
        print(
            f"  {fn}: sampled code up to offset {extent[fn] / 1024:.0f} KB; 90 % of its samples in {n90} "
            f"blocks of 2 KB ({len(bl)} blocks sampled)"
        )
    if not debuginfo:
        return
    print("\nby part of the kernel (line ranges of its sources):")
    for name, file, a, b in groups:
        c = sum(v for k, v in by_line.items() if k.startswith(file + ":") and a <= int(k.split(":")[1]) <= b)
        print(f"  {100.0 * c / total:6.2f} %  {name} ({file} lines {a}-{b})")
    print(f"\ntop {top} lines:")
    for k, c in by_line.most_common(top):
        print(f"  {100.0 * c / total:6.2f} %  {k}")


def dense(path: str, ks: list[int], reps: int) -> None:
    """Cost per committed sub-step with the event steps sparse (the captured chunk, k = 1) and dense:
    the same chunk with the mesh phase advancing k times faster per step (``phase`` unwrapped, scaled,
    wrapped again; ``phase_rate`` scaled), so that about k times as many steps hold a table jump. A
    test of the kernel, not physics. CPU medians of ``reps`` - 1 runs, located and not."""
    from gear_rotor_sim.solver import gear_kernel

    with open(path, "rb") as fh:
        a0 = pickle.load(fh)
    n = a0[4][0].shape[0] - 1

    def with_k(k: int) -> list:
        a = copy.deepcopy(list(a0))
        exc = list(a[4])
        d = np.diff(exc[0], axis=0)
        d[d < 0.0] += 1.0
        un = exc[0][:1] + np.concatenate([np.zeros((1, d.shape[1])), np.cumsum(d, axis=0) * k])
        exc[0] = np.ascontiguousarray(un - np.floor(un))
        exc[1] = np.ascontiguousarray(exc[1] * k)
        a[4] = tuple(exc)
        return a

    cpu: dict[tuple[int, bool], list[float]] = collections.defaultdict(list)
    nsub: dict[int, int] = {}
    for _ in range(reps):
        for k in ks:
            a = with_k(k)
            for loc in (True, False):
                b = copy.deepcopy(a)
                b[8] = loc
                c0 = time.process_time()
                out = gear_kernel.run_chunk_gear(*b)
                cpu[(k, loc)].append(time.process_time() - c0)
                if loc:
                    nsub[k] = int(out[3])
    for k in ks:
        lo = 1e6 * float(np.median(cpu[(k, True)][1:])) / n
        un = 1e6 * float(np.median(cpu[(k, False)][1:])) / n
        ns = nsub[k] / n
        print(
            f"k={k}: {ns:.3f} sub-steps per step; located {lo:.3f} / not {un:.3f} us per step; "
            f"{(lo - un) / ns:.3f} us per sub-step"
        )


#: Section marks of ``_event_step`` (its comments) and what :func:`sections` calls them.
SECTION_MARKS = (
    ("        # --- sub-step map r', rho", "map r', rho"),
    ("        # --- responses of delta, delta'", "responses (free part, qs, qn)"),
    ("        # --- excitation at the sub-step end", "excitation (tables, TE)"),
    ("        # --- compensation: pd = H_d E^-1", "compensation (Gauss-Jordan)"),
    ("        # --- delta, delta' affine in the mesh forces", "affine form"),
    ("        # --- mesh solve (the mesh whose", "mesh solve, crossing, re-split"),
    ("        # --- commit: new amplitudes", "commit (amplitudes, modes)"),
    ("        # --- right limits at the boundary", "right limits"),
)
_RDTSC = """
from llvmlite import ir as _llir
from numba import types as _nbtypes
from numba.core import cgutils as _cgutils
from numba.extending import intrinsic as _intrinsic


@_intrinsic
def _rdtsc(typingctx):  # llvm.readcyclecounter: the time-stamp counter (not serialising)
    def codegen(context, builder, signature, args):
        fnty = _llir.FunctionType(_llir.IntType(64), [])
        fn = _cgutils.get_or_insert_function(builder.module, fnty, "llvm.readcyclecounter")
        return builder.call(fn, [])

    return _nbtypes.int64(), codegen
"""


def instrument(src: str) -> str:
    """The gear kernel's one-file source (``bench_kernel_copy.flat_source``) with time-stamp counter
    reads at the sections of ``_event_step`` (:data:`SECTION_MARKS`; ``prof[k]`` ticks, ``prof[16]``
    committed and ``prof[21]`` re-split sub-steps), around the event step's call (``prof[8]``,
    ``prof[17]`` calls) and the whole loop (``prof[10]``); ``run_chunk_gear`` takes ``prof`` (int64,
    32) as its last argument."""
    out: list[str] = []
    in_ev = False
    for line in src.split("\n"):
        if line.startswith("def "):
            in_ev = line.startswith("def _event_step(")
        for k, (pat, _) in enumerate(SECTION_MARKS):
            if in_ev and line.startswith(pat):
                out.append(
                    "        _tp = _rdtsc()"
                    if k == 0
                    else f"        _tq = _rdtsc(); prof[{k - 1}] += _tq - _tp; _tp = _tq"
                )
        if in_ev and line == "                continue":
            out.append("                prof[5] += _rdtsc() - _tp; prof[21] += 1")
        if in_ev and line == "        i += 1":
            out.append("        prof[7] += _rdtsc() - _tp; prof[16] += 1")
        if line.startswith("            status, nfl, nsb = _event_step("):
            out.append("            _te0 = _rdtsc()")
        if line.startswith("            for r in range(2 * nm):  # prediction of the next full step"):
            out.append("            prof[8] += _rdtsc() - _te0; prof[17] += 1")
        out.append(line)
    s = "\n".join(out)
    reps = (
        ("    rp, sub, resp, mats, solve, swork, g = work\n", "    rp, sub, resp, mats, solve, swork, g, prof = work\n"),  # noqa: E501
        ("(np.zeros(nmode), np.zeros(nmode)))\n", "(np.zeros(nmode), np.zeros(nmode)), prof)\n"),
        ("    average_jumps: bool = False,\n) -> tuple", "    average_jumps: bool = False,\n    prof: np.ndarray = None,\n) -> tuple"),  # noqa: E501
        ("    ev, avg, work, ja = evw\n", "    ev, avg, work, ja = evw\n    prof = work[7]\n    _t00 = _rdtsc()\n"),  # noqa: E501
        ("    _copy_int(s_p, state)\n    for i in range(nm):\n        mcarry[0, i]", "    prof[10] += _rdtsc() - _t00\n    _copy_int(s_p, state)\n    for i in range(nm):\n        mcarry[0, i]"),  # noqa: E501
        ("\n_MAX_PIECES = ", _RDTSC + "\n_MAX_PIECES = "),
    )  # fmt: skip
    for old, new in reps:
        if old not in s:
            raise ValueError(f"the gear kernel has changed: {old.strip()[:50]!r} not found")
        s = s.replace(old, new, 1)
    return s


def sections(path: str, reps: int, src_path: str) -> None:
    """Time-stamp-counter ticks per evaluated sub-step by section of ``_event_step``, in a copy of the
    kernel compiled as another module (:func:`instrument`), on the captured call; medians of ``reps``
    - 1 runs. The counter is not serialising: a section's figure may carry some of its neighbours'."""
    import importlib.util

    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from bench_kernel_copy import flat_source

    if src_path:
        with open(src_path, encoding="utf-8") as fh:
            src = fh.read()
    else:
        src = flat_source()
    tmp = tempfile.mkdtemp(prefix="gk_sections_")
    dst = os.path.join(tmp, "gear_kernel_sections.py")
    with open(dst, "w", encoding="utf-8") as fh:
        fh.write(instrument(src))
    spec = importlib.util.spec_from_file_location("gear_kernel_sections", dst)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    with open(path, "rb") as fh:
        a = pickle.load(fh)
    n = a[4][0].shape[0] - 1
    profs, cpus = [], []
    for _ in range(reps):
        prof = np.zeros(32, dtype=np.int64)
        b = [*copy.deepcopy(list(a)), prof]
        c0 = time.process_time()
        mod.run_chunk_gear(*b)  # type: ignore[attr-defined]
        cpus.append(time.process_time() - c0)
        profs.append(prof)
    p = np.median(np.array(profs[1:]), axis=0)
    cpu = float(np.median(cpus[1:]))
    ne = p[16] + p[21]
    print(
        f"{path}: {1e6 * cpu / n:.3f} us per step (CPU, instrumented), counter {p[10] / cpu / 1e9:.2f} GHz; "
        f"{p[17]:.0f} event steps ({100 * p[8] / p[10]:.1f} % of the loop, {p[8] / p[17]:.0f} ticks each), "
        f"{p[16]:.0f} committed + {p[21]:.0f} re-split sub-steps; ticks per evaluated sub-step:"
    )
    for k, (_, name) in enumerate(SECTION_MARKS):
        print(f"  {name:32s} {p[k] / ne:6.0f}  ({100 * p[k] / p[10]:4.1f} % of the loop)")
    print(f"  {'sum':32s} {p[:8].sum() / ne:6.0f}  ({100 * p[:8].sum() / p[10]:4.1f} %)")


def _source(module: str) -> list[str]:
    from gear_rotor_sim import solver

    with open(os.path.join(os.path.dirname(solver.__file__), module), encoding="utf-8") as fh:
        return fh.read().splitlines()


def _groups() -> list[tuple[str, str, int, int]]:
    """(part, file, first line, last line) of the parts of the step, found from the comments in the
    kernel's sources (the event step in gear_events.py, the loop in gear_loop.py)."""
    ev = "gear_events.py"
    src = _source(ev)
    marks = [
        ("event step: sub-step map r', rho", "# --- sub-step map"),
        ("event step: responses of delta, delta'", "# --- responses of delta"),
        ("event step: excitation (tables, TE)", "# --- excitation at the sub-step end"),
        ("event step: compensation (Gauss-Jordan)", "# --- compensation: pd"),
        ("event step: affine form call", "# --- delta, delta' affine"),
        ("event step: mesh solve, crossing, re-split", "# --- mesh solve (the mesh"),
        ("event step: commit (amplitudes, modes)", "# --- commit: new amplitudes"),
        ("event step: right limits", "# --- right limits at the boundary"),
        ("end of event step", "return STATUS_OK, n_fail, n_sub"),
    ]
    pos = []
    for name, pat in marks:
        idx = next(i for i, s in enumerate(src) if pat in s)
        pos.append((name, idx + 1))
    out = []
    for (name, a), (_, b) in itertools.pairwise(pos):
        out.append((name, ev, a, b - 1))
    lp = "gear_loop.py"
    src = _source(lp)
    loop0 = next(i for i, s in enumerate(src) if s.startswith("def _run_loop")) + 1
    ev_call = next(i for i, s in enumerate(src) if "status, nfl, nsb = _event_step(" in s) + 1
    out.append(("_run_loop (regular steps, event detection, outputs)", lp, loop0, len(src)))
    out.append(("  of it: the event step's call site", lp, ev_call, ev_call + 3))
    ms = "gear_mesh_solve.py"
    src = _source(ms)
    af = next(i for i, s in enumerate(src) if s.startswith("def _affine_forces")) + 1
    out.append(("_affine_forces (inlined)", ms, af, af + 70))
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("capture")
    c.add_argument("path")
    c.add_argument("--rpm", type=float, default=20000.0)
    c.add_argument("--full", action="store_true", help="the full basis (modal_cutoff_hz=None)")
    lp = sub.add_parser("loop")
    lp.add_argument("path")
    lp.add_argument("--seconds", type=float, default=10.0)
    p = sub.add_parser("profile")
    p.add_argument("path")
    p.add_argument("--seconds", type=float, default=10.0)
    p.add_argument("--top", type=int, default=30)
    p.add_argument(
        "--no-debuginfo", action="store_true", help="the project's build (functions and offsets only)"
    )
    d = sub.add_parser("dense")
    d.add_argument("path")
    d.add_argument("--k", type=int, nargs="+", default=[1, 2, 4, 8])
    d.add_argument("--reps", type=int, default=9)
    sc = sub.add_parser("sections")
    sc.add_argument("path")
    sc.add_argument("--reps", type=int, default=9)
    sc.add_argument(
        "--kernel", default="", help="a one-file gear kernel source (default: the installed one, flattened)"
    )
    a = ap.parse_args()
    if a.cmd == "capture":
        capture(a.path, a.rpm, None if a.full else "auto")
    elif a.cmd == "loop":
        loop(a.path, a.seconds)
    elif a.cmd == "dense":
        dense(a.path, a.k, a.reps)
    elif a.cmd == "sections":
        sections(a.path, a.reps, a.kernel)
    else:
        profile(a.path, a.seconds, a.top, _groups(), not a.no_debuginfo)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
