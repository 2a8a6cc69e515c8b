"""Calibration of records whose output torque FLUCTUATES, which the sidecar does not declare (issue 11).

A driven machine (pump, compressor, conveyor, generator) does not hold a constant torque. ``lumped_gearbox``
makes each record with its output torque ``T0 [1 + A sin(...)]`` (``make_record(load_profile=...)``,
docs/independent_data.md "Load-torque profile"); the sidecar declares the mean ``T0 = 200`` N m as every
other record, ``.truth.json`` holds the profile. Two fluctuations, both ``A = 10 %``: ``f4`` at 3.7 Hz (a
slow load change, not an order of either shaft) and ``g1`` at 1x of the gear shaft (a reciprocating driven
machine). Faults: healthy, pinion tooth, unbalance, pinion eccentricity and outer race at 3000 rpm (teeth
in contact), healthy and pinion tooth at 8000 rpm (teeth separating), at the table's severities. Each record
is diagnosed by ``gear-rotor-sim calibrate RECORD --json`` and with ``--baseline`` (the healthy 2000 rpm
reference of ``calibration_load_error.py``, constant 200 N m).

Usage::

    python benchmarks/calibration_load_fluctuation.py [--out DIR] [--cases SUBSTR ...]
        [--no-baseline | --only-baseline] [--reuse] [--duration-s S]
    python benchmarks/calibration_load_fluctuation.py [--out DIR] [--cases SUBSTR ...] --statistic
    python benchmarks/calibration_load_fluctuation.py [--out DIR] --statistic-files CSV [CSV ...]

Prints one Markdown table per variant: truth, the load profile, the first effect, its main parameter
error, the error before/after, the verdict by the issue-11 criteria of ``calibration_independent.judge``
(healthy: nothing claimed; a fault: named first, within 25 %, error halved), and what ``issues`` says about
the load. ``--statistic`` / ``--statistic-files``: no calibration, the load-fluctuation check's statistic
(``gear_rotor_sim.calibration.load_fluctuation``) per record.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import calibration_independent as ci
import calibration_load_error as le
import calibration_speed_error as se

from lumped_gearbox import CONTACT_RPM, RATTLE_RPM, make_record, write_record

#: (operating point, fault tag, fault string)
FAULTS: list[tuple[str, str, str | None]] = [
    ("c3000", "healthy", None),
    ("c3000", "tooth_pinion", ci.FAULTS[0]),
    ("c3000", "unbalance", ci.FAULTS[4]),
    ("c3000", "pinion_eccentricity", ci.FAULTS[2]),
    ("c3000", "outer_race", ci.FAULTS[8]),
    ("r8000", "healthy", None),
    ("r8000", "tooth_pinion", ci.FAULTS[0]),
]
SPEEDS = {"c3000": CONTACT_RPM, "r8000": RATTLE_RPM}
#: the fluctuations (tag, load_profile): 10 % at 3.7 Hz, 10 % at 1x of the gear shaft
PROFILES: list[tuple[str, dict[str, float]]] = [
    ("f4", {"amplitude_pct": 10.0, "frequency_hz": 3.7, "phase_rad": 0.3}),
    ("g1", {"amplitude_pct": 10.0, "gear_order": 1.0, "phase_rad": 0.3}),
]


@dataclass(frozen=True)
class FluctuationCase:
    tag: str
    speed_rpm: float
    fault: str | None
    seed: int
    profile: dict[str, float] = field(default_factory=dict)

    def table_case(self) -> ci.Case:
        return ci.Case(self.tag, self.speed_rpm, 25.0, self.fault, self.seed)


def cases() -> list[FluctuationCase]:
    """Every record; seeds ``801 + 10 p + f`` (profile ``p``, fault ``f``)."""
    return [
        FluctuationCase(f"{op}_{name}_{ptag}", SPEEDS[op], fault, 801 + 10 * pi + fi, prof)
        for pi, (ptag, prof) in enumerate(PROFILES)
        for fi, (op, name, fault) in enumerate(FAULTS)
    ]


def make(case: FluctuationCase, out: Path, duration_s: float) -> Path:
    """The record with the fluctuating torque; the sidecar declares the mean, 200 N m."""
    csv = out / f"{case.tag}.csv"
    if csv.exists():
        return csv
    rec = make_record(
        case.speed_rpm,
        25.0,
        [case.fault] if case.fault else [],
        duration_s=duration_s,
        seed=case.seed,
        load_profile=case.profile,
    )
    return write_record(csv, rec)


def _profile_text(p: dict[str, float]) -> str:
    where = f"{p['frequency_hz']:g} Hz" if p.get("frequency_hz") else f"{p['gear_order']:g}x gear"
    return f"{p['amplitude_pct']:g} % at {where}"


def row(case: FluctuationCase, res: dict[str, Any], variant: str) -> dict[str, Any]:
    r = ci.judge(case.table_case(), res)
    r.update(
        variant=variant,
        profile=_profile_text(case.profile),
        claimed=[e.get("label") or e.get("name") for e in res.get("effects") or []],
        issues=[
            str(i) for i in res.get("data_issues") or res.get("issues") or [] if "torque" in str(i).lower()
        ],
    )
    return r


def table(rows: list[dict[str, Any]]) -> str:
    head = (
        "| record | truth | load profile | claimed | main parameter (error) | E before -> after | verdict | "
        "torque issue | CPU (s) |\n|---|---|---|---|---|---|---|---|---|\n"
    )
    lines = []
    for r in rows:
        par = ci.param_cell(r, " ")
        claimed = ", ".join(r.get("claimed") or []) or "nothing"
        lines.append(
            f"| {r['record']} | `{r['truth']}` | {r['profile']} | {claimed} | {par} | "
            f"{ci._fmt(r.get('error_before'))} -> {ci._fmt(r.get('error_after'))} | {r['verdict']} | "
            f"{'yes' if r.get('issues') else 'no'} | {ci._fmt(r.get('cpu_s'), '.0f')} |"
        )
    return head + "\n".join(lines) + "\n"


def statistic(paths: list[Path]) -> str:
    """Markdown table of the load-fluctuation check's statistic over ``paths`` (no calibration)."""
    from gear_rotor_sim.calibration.load_fluctuation import statistic_row, statistic_table_head
    from gear_rotor_sim.calibration.measurement import load_measurement

    lines = [statistic_table_head()]
    for p in paths:
        lines.append(f"| {p.stem} | " + statistic_row(load_measurement(p)))
        print(lines[-1], file=sys.stderr, flush=True)
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="out/calibration_load_fluctuation", help="records and results directory")
    ap.add_argument("--cases", nargs="*", default=None, help="only cases whose tag contains one of these")
    ap.add_argument("--duration-s", type=float, default=2.0, help="record length, s (default 2)")
    ap.add_argument("--no-baseline", action="store_true", help="skip the --baseline variant")
    ap.add_argument("--only-baseline", action="store_true", help="only the --baseline variant")
    ap.add_argument("--reuse", action="store_true", help="take a calibration already saved in --out")
    ap.add_argument(
        "--statistic", action="store_true", help="no calibration: the check's statistic per record"
    )
    ap.add_argument(
        "--statistic-files", nargs="+", default=None, metavar="CSV", help="no calibration: statistic of these"
    )
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.statistic_files:
        text = statistic([Path(p) for p in args.statistic_files])
        print(text)
        (out / "statistic_files.md").write_text(text)
        return 0
    todo = ci.select_cases(cases(), args.cases)
    started = ci.prepare_run(todo, make, out, args.duration_s)
    if started is None:
        return 2
    t0, load0 = started
    if args.statistic:
        text = statistic([out / f"{c.tag}.csv" for c in todo])
        print(text)
        (out / "statistic.md").write_text(text)
        return 0
    variants: list[tuple[str, Path | None, bool]] = []
    if not args.only_baseline:
        variants.append(("no reference", None, True))
    if not args.no_baseline:
        tag, tq = le.REFERENCES[0]
        ref = le._reference(tag, tq, out, args.duration_s, True)
        variants.append((f"--baseline {tag} (healthy 2000 rpm, constant {tq:g} N m)", ref, True))
    se.run_variants(variants, todo, out, row, table, "", t0, load0, args.reuse)
    return 0


if __name__ == "__main__":
    sys.exit(main())
