"""Where one ``gear-rotor-sim calibrate`` call spends its CPU (issue 11: the time per record).

Runs ``gear-rotor-sim calibrate RECORD --json [--baseline REF]`` in this process under :mod:`cProfile`
and prints

* the record's CPU time (``time.process_time``) and wall time, and the report's ``n_simulations``;
* the top functions by cumulative time and by own time, each with its share of the record's CPU;
* the model runs (``ModelRunner.force_signals``) counted by the calibration function that asked for them:
  calls, runs actually simulated (cache misses) and the CPU inside those runs, and the feature passes
  (``Comparison.features``) counted likewise;
* the candidate fits by effect type (their model runs included) and the scores (``Comparison.score``).

cProfile's own cost falls on every Python call, so it inflates the Python-heavy parts (the scores, the
candidates' linear algebra) against the compiled ones (the integrator): ``--no-profile`` keeps the
counters alone, whose shares are those of a plain run.

The JSON report is written to ``--save DIR`` as ``<stem>[.baseline].calibration.json`` (the names
``benchmarks/calibration_timing.py --compare`` and ``/tmp``-style comparisons read), so a profiled run can
be compared with an unprofiled one: the profiler changes the time, not the report.

Usage::

    python benchmarks/calibration_profile.py RECORD.csv [--baseline REF] [--top 25] [--save DIR]
        [--stats FILE] [--no-profile]
"""

from __future__ import annotations

import argparse
import contextlib
import cProfile
import io
import json
import pstats
import sys
import time
from collections import defaultdict
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

#: modules that pass a model run or a feature pass on without deciding to ask for it: the caller
#: reported is the first frame outside them
PLUMBING = (
    "calibration/model_runner.py",
    "calibration/model_misalignment.py",
    "calibration/fit_model.py",
    "calibration/residual.py",
    "faults/misalignment_force.py",
    "calibration_profile.py",
)


def asker(skip: int = 2) -> str:
    """``module:function`` of the first calibration frame outside :data:`PLUMBING` on the stack."""
    f = sys._getframe(skip)
    while f is not None:
        name = f.f_code.co_filename.replace("\\", "/")
        if "gear_rotor_sim/" in name and not name.endswith(PLUMBING):
            return f"{name.rsplit('gear_rotor_sim/', 1)[1]}:{f.f_code.co_name}"
        f = f.f_back
    return "(outside gear_rotor_sim)"


class Counter:
    """Calls, cache misses and CPU per asking function of the wrapped model runs and feature passes."""

    def __init__(self) -> None:
        self.runs: dict[str, list[float]] = defaultdict(lambda: [0, 0, 0.0])
        self.features: dict[str, list[float]] = defaultdict(lambda: [0, 0.0])
        #: candidate fits by effect type (calls, CPU s with their model runs), and the scores
        self.fits: dict[str, list[float]] = defaultdict(lambda: [0, 0.0])
        self.scores = [0, 0.0]
        self._depth = 0

    @contextlib.contextmanager
    def installed(self) -> Iterator[None]:
        from gear_rotor_sim.calibration import fit_candidates, model_runner, residual

        runner_cls = model_runner.ModelRunner
        cmp_cls = residual.Comparison
        fit_cls = fit_candidates.CandidateFitting
        orig_force, orig_feat = runner_cls.force_signals, cmp_cls.features
        orig_fit, orig_score = fit_cls._fit_candidate, cmp_cls.score
        counter = self

        def fit_candidate(cal: Any, e: Any, cur: Any) -> Any:
            t = time.process_time()
            try:
                return orig_fit(cal, e, cur)
            finally:
                row = counter.fits[type(e).__name__]
                row[0] += 1
                row[1] += time.process_time() - t

        def score(cmp: Any, *a: Any, **k: Any) -> Any:
            t = time.process_time()
            try:
                return orig_score(cmp, *a, **k)
            finally:
                counter.scores[0] += 1
                counter.scores[1] += time.process_time() - t

        def force_signals(runner: Any, effects: Any = ()) -> Any:
            who = asker()
            before = runner.n_runs
            nested = counter._depth > 0
            counter._depth += 1
            t = time.process_time()
            try:
                return orig_force(runner, effects)
            finally:
                counter._depth -= 1
                row = counter.runs[who if not nested else f"{who} (mesh-force pass)"]
                row[0] += 1
                row[1] += runner.n_runs > before
                if not nested:
                    row[2] += time.process_time() - t

        def features(cmp: Any, *a: Any, **k: Any) -> Any:
            who = asker()
            t = time.process_time()
            try:
                return orig_feat(cmp, *a, **k)
            finally:
                row = counter.features[who]
                row[0] += 1
                row[1] += time.process_time() - t

        runner_cls.force_signals, cmp_cls.features = force_signals, features
        fit_cls._fit_candidate, cmp_cls.score = fit_candidate, score
        try:
            yield
        finally:
            runner_cls.force_signals, cmp_cls.features = orig_force, orig_feat
            fit_cls._fit_candidate, cmp_cls.score = orig_fit, orig_score

    def print(self, cpu: float, out: Callable[[str], None]) -> None:
        out("\nmodel runs by the function that asked (calls, simulated, CPU s, % CPU)")
        for who, (n, miss, t) in sorted(self.runs.items(), key=lambda kv: -kv[1][2]):
            out(f"  {n:5d} {miss:5d} {t:8.1f} {100 * t / cpu:5.1f} %  {who}")
        tot = [sum(r[i] for r in self.runs.values()) for i in range(3)]
        out(f"  {tot[0]:5.0f} {tot[1]:5.0f} {tot[2]:8.1f} {100 * tot[2] / cpu:5.1f} %  total")
        out("\nfeature passes (Comparison.features) by the function that asked (calls, CPU s, % CPU)")
        for who, (n, t) in sorted(self.features.items(), key=lambda kv: -kv[1][1]):
            out(f"  {n:5d} {t:8.1f} {100 * t / cpu:5.1f} %  {who}")
        n = sum(r[0] for r in self.features.values())
        t = sum(r[1] for r in self.features.values())
        out(f"  {n:5d} {t:8.1f} {100 * t / cpu:5.1f} %  total")
        out("\ncandidate fits by effect type, their model runs included (calls, CPU s, % CPU)")
        for who, (n, t) in sorted(self.fits.items(), key=lambda kv: -kv[1][1]):
            out(f"  {n:5d} {t:8.1f} {100 * t / cpu:5.1f} %  {who}")
        n, t = self.scores
        out(f"\nscores (Comparison.score): {n} calls, {t:.1f} s, {100 * t / cpu:.1f} %")


def top(stats: pstats.Stats, key: str, n: int, cpu: float, out: Callable[[str], None]) -> None:
    """The ``n`` functions with the largest ``key`` (``cumulative`` or ``tottime``), with % of ``cpu``."""
    rows = []
    for (file, line, name), (_cc, nc, tt, ct, _callers) in stats.stats.items():  # type: ignore[attr-defined]
        short = file.rsplit("gear_rotor_sim/", 1)[-1].rsplit("site-packages/", 1)[-1]
        rows.append((ct if key == "cumulative" else tt, nc, f"{short}:{line}({name})"))
    rows.sort(key=lambda r: -r[0])
    out(f"\ntop {n} by {'cumulative' if key == 'cumulative' else 'own'} time (s, % CPU, calls)")
    for t, nc, where in rows[:n]:
        out(f"  {t:8.1f} {100 * t / cpu:5.1f} % {nc:8d}  {where}")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("record", type=Path, help="measurement (.csv with its .yaml sidecar)")
    p.add_argument("--baseline", type=Path, help="healthy reference record or saved reference (.json)")
    p.add_argument("--top", type=int, default=25, help="functions listed per ranking (default 25)")
    p.add_argument("--save", type=Path, help="directory for the JSON report")
    p.add_argument("--stats", type=Path, help="write the raw cProfile statistics to FILE")
    p.add_argument(
        "--no-profile",
        action="store_true",
        help="no cProfile (its overhead inflates the Python-heavy parts): the record's CPU and the "
        "counted model runs, feature passes, candidate fits and scores only",
    )
    args = p.parse_args(argv)

    from gear_rotor_sim.cli import main as cli_main

    cli = ["calibrate", str(args.record), "--json"]
    if args.baseline is not None:
        cli += ["--baseline", str(args.baseline)]
    counter = Counter()
    prof = cProfile.Profile(time.process_time)
    buf = io.StringIO()
    c0, w0 = time.process_time(), time.perf_counter()
    with counter.installed(), contextlib.redirect_stdout(buf):
        if not args.no_profile:
            prof.enable()
        try:
            rc = cli_main(cli)
        finally:
            prof.disable()
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    if rc:
        print(f"calibrate exited with {rc}", file=sys.stderr)
        return int(rc)
    report = json.loads(buf.getvalue())
    print(
        f"{args.record.name}{' --baseline' if args.baseline else ''}: CPU {cpu:.1f} s, wall {wall:.1f} s "
        f"({'no profiler' if args.no_profile else 'under the profiler'}), "
        f"n_simulations {report.get('n_simulations')}, error "
        f"{report['error_before']:.6g} -> {report['error_after']:.6g}, effects "
        f"{[e['label'] for e in report['effects']]}"
    )
    if not args.no_profile:
        stats = pstats.Stats(prof)
        if args.stats is not None:
            stats.dump_stats(str(args.stats))
        top(stats, "cumulative", args.top, cpu, print)
        top(stats, "tottime", args.top, cpu, print)
    counter.print(cpu, print)
    if args.save is not None:
        args.save.mkdir(parents=True, exist_ok=True)
        name = args.record.stem + (".baseline" if args.baseline else "") + ".calibration.json"
        (args.save / name).write_text(json.dumps(report, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
