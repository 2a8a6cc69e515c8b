"""The gear kernel's regular step by its parts: copies of the kernel with one part switched off (figures).

Issue 13 (docs/history/solver_sessions.md, "Session 24"). Session 23 found the regular step at 20000
rpm 55-72 % independent of the modes but could not say which part of it costs what (the debug build
for a line profile did not compile in time). This script builds copies of the installed kernel
(``bench_kernel_copy.flat_source``) with one part of the regular step removed or replaced by a
cheaper stand-in (:data:`VARIANTS`), compiles each as its own module, and runs every copy on the
chunk captured by ``profile_event_steps.py capture`` (paper gearbox, 20000 rpm, DTE only, default
model), events not located (regular steps only) and located as captured, alternated, CPU medians
per step. The difference from the unchanged copy (``copy``, which also shows the placement noise
against the installed kernel) is what the part costs *in place*: on an out-of-order core a part off
the step's critical path costs less than it would alone.

Some stand-ins change the motion (``tables_const``: the stiffness and force coefficients of the
first table point at every step; ``te_off``: no transmission error; ``solve_contact``: the in-contact
force law only, the teeth never separate): the contact-state changes per step of each run are
printed so that a faster run that merely separates less is seen as such. The others leave the
stream as it is on this chunk (``outputs_off``: the per-step mesh arrays not written;
``unforced_off``: the 9 unforced modes, exactly zero here, not propagated; ``finite_off``: the
``isfinite`` checks removed; ``modes_1``: the fused pass over one forced mode, the stream changes).

``--copy FILE`` adds another kernel source (e.g. main's, by ``bench_kernel_copy.py flatten`` on main's
tree) and checks the installed kernel's results against it on the chunk (the modal state, the carry,
the mesh force, states and channels of every step, the last row of the other per-step arrays);
``--installed-last-rows`` gives the installed kernel one-row excitation arrays, as
``NewmarkStepper.run(excitation_rows=False)`` does for the ``Simulator`` since session 24, and
times it with every row as well (``installed_rows``).

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/profile_event_steps.py capture /tmp/c20k.pkl``
then ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_step_parts.py /tmp/c20k.pkl
[--variants copy outputs_off ...] [--runs 9] [--workdir DIR] [--copy FILE] [--installed-last-rows]``
(each copy compiles for 2-7 minutes on a loaded 2-core machine; ``--workdir`` keeps the copies and
their numba cache for a second run).
"""

from __future__ import annotations

import argparse
import copy
import os
import pickle
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

#: name -> list of (source text, replacement); each text must occur exactly once in the flat source.
VARIANTS: dict[str, list[tuple[str, str]]] = {
    "copy": [],
    # 6. the per-step mesh arrays (dte, dted, fmesh, states, kt, et, edt, coef) not written
    "outputs_off": [
        (
            "    o = n - 1\n    for i in range(nm):\n        dte[o, i] = d_p[i]\n",
            "    o = n - 1\n    for i in range(0):\n        dte[o, i] = d_p[i]\n",
        )
    ],
    # 2. the table look-up: table interval 100 at every step (no floor, modulo, interpolation)
    "tables_const": [
        (
            "        i0, i1, fr = _table_cell(f, nt)\n        if jflag[i, i0] == 0:",
            "        i0, i1, fr = 100, 101, 0.25\n        if jflag[i, i0] == 0:",
        )
    ],
    # 2. the transmission error of Eq 24 and its rate: zero
    "te_off": [
        (
            "        e = mesh_par[i, 4] * te_sc[n, i]  # sin, cos of Eq 24's argument (_te_sin_cos)\n"
            "        edot = mesh_par[i, 4] * te_sc[n, nm + i] * two_pi * phase_rate[n, i]\n",
            "        e = 0.0\n        edot = 0.0\n",
        )
    ],
    # 4. the mesh solve: the in-contact law of Eq 25 only (no active set)
    "solve_contact": [
        (
            "        ns1, f1 = _mesh_solve_one(s_p[0], a10 - ee[0], b10 - ed[0], am0, bm0, kk[0], cm[0], "
            "bst[0])\n",
            "        ns1 = 2\n        f1 = (kk[0] * (a10 - ee[0] - bst[0]) + cm[0] * (b10 - ed[0])) / "
            "(1.0 - kk[0] * am0 - cm[0] * bm0)\n",
        )
    ],
    # 5. the unforced modes' propagation skipped (their amplitudes are zero at a fixed set point)
    "unforced_off": [
        (
            "    for j in range(nf, nmode):  # unforced modes only propagate\n",
            "    for j in range(nf, nf):  # unforced modes only propagate\n",
        )
    ],
    # the isfinite checks of the regular step (excitation, commit, prediction)
    "finite_off": [
        (
            "        if not (np.isfinite(k) and np.isfinite(e) and np.isfinite(edot)):\n"
            "            finite = False\n",
            "",
        ),
        (
            "        if not (np.isfinite(d) and np.isfinite(fi)):\n            return STATUS_NONFINITE\n"
            "        if abs(d) >= bound:",
            "        if abs(d) >= bound:",
        ),
        (
            "        if not np.isfinite(ypred[0]):\n            _copy_int(s_p, state)",
            "        if False:\n            _copy_int(s_p, state)",
        ),
    ],
    # the fused pass over one forced mode (the rest only propagate): the mode-independent floor
    "modes_1": [("    return _run_loop(\n        modal, nf,", "    return _run_loop(\n        modal, 1,")],
}


def variant_source(flat: str, name: str) -> str:
    """The flat kernel source with variant ``name``'s replacements (each must match exactly once)."""
    src = flat
    for old, new in VARIANTS[name]:
        k = src.count(old)
        if k != 1:
            raise ValueError(f"variant {name}: {k} matches of {old[:60]!r}")
        src = src.replace(old, new)
    return src


def contact_changes(states: np.ndarray) -> float:
    """Contact-state changes per step of a run's per-step states (outs[7])."""
    s = np.asarray(states)[:, 0]
    return float(np.count_nonzero(np.diff(s))) / max(s.shape[0] - 1, 1)


def last_rows(call: list) -> list:
    """The call with delta' and the excitation arrays (and delta, where ``event_average`` makes the
    channels ``outs[12]``) given one row, as ``NewmarkStepper.run(excitation_rows=False)`` passes them
    since session 24 (the kernel then writes the last step's row only)."""
    outs = list(call[6])
    for i in (5, 8, 9, 10, 11) + ((4,) if call[13] else ()):
        outs[i] = np.ascontiguousarray(outs[i][:1])
    out = list(call)
    out[6] = tuple(outs)
    return out


def same_results(a: list, b: list) -> list[str]:
    """Names of the arrays that differ between two finished calls' arguments (modal state, carry,
    the per-step mesh force, states and channels, the last row of every per-step array)."""
    bad = []
    pairs = [(f"modal{i}", a[0][i], b[0][i]) for i in (0, 1)]
    pairs += [(f"carry{i}", x, y) for i, (x, y) in enumerate(zip(a[5], b[5], strict=True))]
    for i, (x, y) in enumerate(zip(a[6][3:], b[6][3:], strict=True)):
        if x.shape == y.shape:
            pairs.append((f"outs{i + 3}", x, y))
        elif x.shape[0] and y.shape[0]:
            pairs.append((f"outs{i + 3}[-1]", x[-1], y[-1]))
    for name, x, y in pairs:
        if not np.array_equal(x, y, equal_nan=True):
            bad.append(name)
    return bad


def main() -> None:
    from bench_kernel_copy import _load_copy, flat_source

    from gear_rotor_sim.solver import gear_kernel

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("path", help="a chunk from profile_event_steps.py capture")
    ap.add_argument("--variants", nargs="*", default=list(VARIANTS), choices=list(VARIANTS))
    ap.add_argument("--runs", type=int, default=9)
    ap.add_argument("--workdir", default="", help="where the copies go (default: a new temporary directory)")
    ap.add_argument("--copy", action="append", default=[], help="another kernel source (main's)")
    ap.add_argument("--installed-last-rows", action="store_true", help="installed: one-row excitation arrays")
    args = ap.parse_args()
    with open(args.path, "rb") as fh:
        cap = pickle.load(fh)
    n = cap[4][0].shape[0] - 1
    work = args.workdir or tempfile.mkdtemp(prefix="bench_step_parts_")
    os.makedirs(work, exist_ok=True)
    flat = flat_source()
    kernels = {"installed": gear_kernel.run_chunk_gear}
    for name in args.variants:
        path = os.path.join(work, f"step_{name}.py")
        try:
            src = variant_source(flat, name)
        except ValueError as exc:  # the installed code no longer holds the text (a lever took it)
            print(f"skipped: {exc}")
            continue
        old = open(path, encoding="utf-8").read() if os.path.exists(path) else None
        if old != src:
            with open(path, "w", encoding="utf-8") as fh:
                fh.write(src)
        kernels[name] = _load_copy(path).run_chunk_gear  # type: ignore[attr-defined]
    if args.installed_last_rows:  # the installed kernel with every row as well (the outputs' share)
        kernels["installed_rows"] = gear_kernel.run_chunk_gear
    for i, p in enumerate(args.copy):
        kernels[f"copy:{i + 1}"] = _load_copy(p).run_chunk_gear  # type: ignore[attr-defined]
    print(f"{n} steps; {len(kernels)} kernels; copies in {work}; load {os.getloadavg()[0]:.1f}", flush=True)
    for locate in (False, bool(cap[8])):
        calls = {}
        for k in kernels:
            call = list(cap)
            call[8] = locate
            calls[k] = last_rows(call) if (k == "installed" and args.installed_last_rows) else call
        ends = {}
        done = {}
        for k, fn in kernels.items():  # compile (or load) and what each run ends with
            c0 = time.process_time()
            b = copy.deepcopy(calls[k])
            st = fn(*b)
            done[k] = b
            ends[k] = (st[0], st[3] / n, contact_changes(b[6][7]), time.process_time() - c0)
        for k in kernels:
            if k.startswith("copy:"):
                bad = same_results(done["installed"], done[k])
                print(f"installed against {k}: " + (f"differ: {', '.join(bad)}" if bad else "bit for bit"))
        cpu: dict[str, list[float]] = {k: [] for k in kernels}
        load0 = os.getloadavg()[0]
        for _ in range(args.runs):
            for k, fn in kernels.items():
                b = copy.deepcopy(calls[k])
                c0 = time.process_time()
                fn(*b)
                cpu[k].append(time.process_time() - c0)
        base = "copy" if "copy" in cpu else ("copy:1" if "copy:1" in cpu else "installed")
        ref = float(np.median(cpu[base]))
        print(
            f"events {'located' if locate else 'not located'}: CPU us per step, medians of {args.runs} "
            f"alternated runs (load {load0:.1f} -> {os.getloadavg()[0]:.1f}); difference from '{base}'"
        )
        for k in kernels:
            med = float(np.median(cpu[k]))
            status, nsub, nchg, first = ends[k]
            print(
                f"  {k:14s} {1e6 * med / n:.4f} ({1e6 * min(cpu[k]) / n:.4f}-{1e6 * max(cpu[k]) / n:.4f})"
                f"  {1e6 * (med - ref) / n:+.4f}  x{ref / med:.3f}; status {status}, {nsub:.3f} sub-steps "
                f"and {nchg:.4f} contact changes per step; first call {first:.0f} s CPU",
                flush=True,
            )


if __name__ == "__main__":
    main()
