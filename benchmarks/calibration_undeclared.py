"""Calibration on records that hold an effect nobody declared (issue 11).

A user's measurement holds things the sidecar does not say: an encoder zero, a sensor mounted the other
way, x and y swapped, a wrong sensitivity, mains hum, a channel delayed in the acquisition, a clipped
channel, a machine whose bearings are stiffer or softer than nominal, more noise, a short record. Each
record here is a ``lumped_gearbox`` record of the issue-11 table (same generator, seed and sampling as
``benchmarks/calibration_independent.py``, so the correctly declared result of the same record is that
table's row) with ONE such effect added: in the measurement chain by post-processing the noisy record
(the generator is never changed), or through the generator's own inputs (``bearing_stiffness`` fault,
noise level, duration). Session 18 added the acquisition chain's disturbances (spikes, a mount resonance,
coloured noise, dropouts, NaN, time-base gaps and repeats, a gain modulation: ``undeclared_disturbances.py``)
and base records at other seeds and 8000 rpm (:data:`BASES`). It is then diagnosed by
``gear-rotor-sim calibrate RECORD --json``.

What is asked (docs/history/calibration_sessions.md Sec. 8.43): the calibration either explains the
effect (a baseline update, or a library effect with the right meaning) or says plainly that it cannot
(an ``issues`` entry naming the channel), and never names a wrong fault with confidence. Verdict per record:
healthy: nothing in ``effects``; fault: named first (right wheel / tooth), main parameter within
25 %, error at least halved (``calibration_independent.judge``). Besides, ``issues_true``: does an
``issues`` entry name the disturbed channel (effects on one channel), or is it ``-`` (effects of the
whole record, which the verdict alone judges). A refusal (exit status 2) whose message names the disturbed
field is ``REFUSED`` and counts as a pass; ``wrong_claim`` counts a library effect on a healthy record or a
wrong effect named first.

Usage::

    python benchmarks/calibration_undeclared.py [--jobs N] [--out DIR] [--cases SUBSTR ...]
        [--baseline | --only-baseline]
    python benchmarks/calibration_undeclared.py --from-results DIR [DIR ...]   # re-render saved results
    python benchmarks/calibration_undeclared.py --list                          # the cases, no calibration
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import calibration_independent as ci
from calibration_undeclared_cases import BASE_TEMPERATURE_C, BASES, EFFECTS, Undeclared

from lumped_gearbox import make_record, write_record


@dataclass(frozen=True)
class Case:
    effect: Undeclared
    base: str

    @property
    def tag(self) -> str:
        return f"{self.effect.name}__{self.base}"

    @property
    def fault(self) -> str | None:
        return BASES[self.base][0]

    def judged(self) -> ci.Case:
        """The table's case type, for ``ci.judge`` (a baseline property is not a fault to name)."""
        temp = BASE_TEMPERATURE_C.get(self.base, 25.0)
        return ci.Case(self.tag, BASES[self.base][2], temp, self.fault, BASES[self.base][1])


def cases() -> list[Case]:
    return [Case(e, b) for e in EFFECTS for b in e.bases]


def make(case: Case, out: Path) -> Path:
    """The table's record (same seed, daq sampling) with the undeclared effect added."""
    faults = [f for f in (case.fault, case.effect.extra_fault) if f]
    kw = {"duration_s": 2.0, **case.effect.record_kw}
    _, seed, speed = BASES[case.base]
    temp = BASE_TEMPERATURE_C.get(case.base, 25.0)
    rec = make_record(speed, temp, faults, seed=seed, sampling="daq", **kw)
    if case.effect.post is not None:
        fs = 1.0 / float(rec.time_s[1] - rec.time_s[0])
        case.effect.post(rec, fs)
    return write_record(out / f"{case.tag}.csv", rec)


def _columns(case: Case) -> tuple[str, ...]:
    col = case.effect.channel
    return () if col is None else (col,) if isinstance(col, str) else col


def _names(text: str, cols: tuple[str, ...], keyword: str | None = None) -> bool:
    return any(c in text for c in cols) and (keyword is None or keyword in text)


def _issues_true(case: Case, res: dict[str, Any]) -> str:
    """``yes`` if an ``issues`` entry (or a refusal's message) names a disturbed column, ``no`` if none
    does, ``-`` for an effect of the whole record."""
    cols = _columns(case)
    if not cols or case.effect.name == "declared":
        return "-"
    kw = case.effect.keyword
    if res.get("failed"):
        return "yes" if _names(str(res.get("stderr", "")), cols) else "no"
    return "yes" if any(_names(str(i), cols, kw) for i in res.get("issues") or []) else "no"


def judge(case: Case, res: dict[str, Any]) -> dict[str, Any]:
    """The table's verdict, and whether the disturbance was named; a refusal (exit status 2) naming the
    disturbed field is ``REFUSED`` (the calibration said plainly that it cannot use the record)."""
    row = ci.judge(case.judged(), res)
    row.update(effect=case.effect.name, base=case.base, issues_true=_issues_true(case, res))
    cols = _columns(case)
    if res.get("failed"):
        msg = str(res.get("stderr", "")).strip().splitlines()
        row["issues"] = msg[-1:] if msg else []
        if row["issues_true"] == "yes":
            row["verdict"] = "REFUSED"
        row["wrong_claim"] = False
        return row
    kw = case.effect.keyword
    row["issues"] = [str(i) for i in res.get("issues") or [] if not cols or _names(str(i), cols, kw)]
    row["wrong_claim"] = _wrong_claim(case, res)
    row["not_claimed"] = [e.get("label") or e.get("name") for e in res.get("not_claimed") or []]
    return row


def _wrong_claim(case: Case, res: dict[str, Any]) -> bool:
    """A library effect on a healthy record, or a first effect other than the injected fault's."""
    effects = res.get("effects") or []
    if case.fault is None:
        return bool(effects)
    return bool(effects) and effects[0].get("name") != ci.parse_fault(case.fault).name


def _job(args: tuple[Case, str, str | None]) -> dict[str, Any]:
    case, out, baseline = args
    csv = Path(out) / f"{case.tag}.csv"
    if not csv.exists():
        make(case, Path(out))
    res = ci.calibrate(csv, Path(baseline) if baseline else None)
    (Path(out) / f"{case.tag}{'.baseline' if baseline else ''}.calibration.json").write_text(
        json.dumps(res, indent=1, default=str)
    )
    row = judge(case, res)
    row["baseline"] = Path(baseline).name if baseline else None
    return row


def table(rows: list[dict[str, Any]]) -> str:
    head = (
        "| effect | record | first effect (baseline updates) | main parameter: fitted / truth (error) | "
        "E before -> after | verdict | issue names the channel | issues on that channel |\n"
        "|---|---|---|---|---|---|---|---|\n"
    )
    lines = []
    for r in rows:
        par = ci.param_cell(r)
        first = r.get("first", "-")
        if r.get("baseline_updates"):
            first += f" ({', '.join(r['baseline_updates'])})"
        issues = "; ".join(i[:140] for i in r.get("issues") or []) if r.get("issues_true") != "-" else ""
        err = f"{ci._fmt(r.get('error_before'))} -> {ci._fmt(r.get('error_after'))}"
        lines.append(
            f"| {r['effect']} | {r['base']} | {first} | {par} | {err} | {r['verdict']} | "
            f"{r.get('issues_true', '-')} | {issues.replace('|', '/')} |"
        )
    return head + "\n".join(lines) + "\n"


def render(rows: list[dict[str, Any]], note: str) -> str:
    text = ""
    for variant, title in ((None, "Without a reference"), ("yes", "With `--baseline` (healthy 2000 rpm)")):
        part = [r for r in rows if bool(r.get("baseline")) == bool(variant)]
        if not part:
            continue
        done = [r for r in part if r["verdict"] != "not run"]
        n_pass = sum(r["verdict"] in ("PASS", "REFUSED") for r in done)
        wrong = sum(bool(r.get("wrong_claim")) for r in done)
        silent = sum(r.get("issues_true") == "no" for r in done)
        cpus = sorted(r["cpu_s"] for r in done if r.get("cpu_s") is not None)
        text += (
            f"#### {title}: {n_pass} of {len(done)} pass (PASS or REFUSED naming the field), "
            f"{wrong} wrong claim(s), {silent} silent on the disturbed channel\n\n" + table(part)
        )
        if cpus:
            text += f"\nCPU per record: median {cpus[len(cpus) // 2]:.0f} s, max {cpus[-1]:.0f} s.\n\n"
    return text + f"{note}.\n"


def collect(todo: list[Case], dirs: list[Path], baseline: bool) -> list[dict[str, Any]]:
    rows = []
    for c in todo:
        name = f"{c.tag}{'.baseline' if baseline else ''}.calibration.json"
        found = [d / name for d in dirs if (d / name).exists()]
        if found:
            row = judge(c, json.loads(found[0].read_text()))
            row["baseline"] = "yes" if baseline else None
            rows.append(row)
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--jobs", type=int, default=1, help="parallel calibrations (default 1)")
    ap.add_argument("--out", default="out/calibration_undeclared", help="records and results directory")
    ap.add_argument("--cases", nargs="*", default=None, help="only cases whose tag contains one of these")
    ap.add_argument("--baseline", action="store_true", help="also the --baseline variant (healthy 2000 rpm)")
    ap.add_argument("--only-baseline", action="store_true", help="only the --baseline variant")
    ap.add_argument(
        "--reference",
        metavar="JSON",
        help="saved reference baseline to use (default: fitted here on the table's healthy 2000 rpm record)",
    )
    ap.add_argument("--from-results", nargs="+", metavar="DIR", help="judge saved *.calibration.json")
    ap.add_argument("--list", action="store_true", help="print the cases and exit")
    args = ap.parse_args(argv)
    todo = ci.select_cases(cases(), args.cases)
    if args.list:
        for c in todo:
            print(f"{c.tag}: {c.effect.what}; truth {c.fault or 'healthy'}")
        return 0
    if not todo:
        print("no case matches --cases", file=sys.stderr)
        return 2
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.from_results:
        dirs = [Path(d) for d in args.from_results]
        rows = collect(todo, dirs, False) + collect(todo, dirs, True)
        text = render(rows, f"results from {', '.join(map(str, dirs))}")
    else:
        t0, load0 = time.perf_counter(), os.getloadavg()[0]
        for c in todo:
            make(c, out)
        jobs: list[tuple[Case, str, str | None]] = (
            [] if args.only_baseline else [(c, str(out), None) for c in todo]
        )
        if args.baseline or args.only_baseline:
            saved = args.reference
            if saved is None:
                ref = ci.Case("baseline_2000rpm_25C", *ci.BASELINE, None, 999)
                saved = ci._reference((ref, str(out), 2.0))
            jobs += [(c, str(out), saved) for c in todo]
        rows = _run(jobs, args.jobs)
        text = render(rows, ci.run_note(args.jobs, load0, t0))
    ci.save_results(out, text, rows)
    return 0


def _run(jobs: list[tuple[Case, str, str | None]], n_jobs: int) -> list[dict[str, Any]]:
    """The calibrations, in a pool or one by one (each row's verdict printed as it comes: the saved
    results let a cut-short run be re-rendered with ``--from-results``)."""
    if n_jobs > 1:
        with ProcessPoolExecutor(max_workers=n_jobs) as pool:
            return list(pool.map(_job, jobs))
    rows = []
    for j in jobs:
        rows.append(_job(j))
        print(f"{rows[-1]['record']}: {rows[-1]['verdict']}", file=sys.stderr, flush=True)
    return rows


if __name__ == "__main__":
    sys.exit(main())
