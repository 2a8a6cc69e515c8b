"""Calibration of records whose declared speed is not the true one (issue 11: effects nobody declared).

``lumped_gearbox`` makes each record at its TRUE speed; the sidecar then declares another (the record's
``.yaml`` rewritten, ``.truth.json`` keeps the true speed): an induction motor's slip, a tachometer's
error or a sample clock off by ``+-0.3 %``, ``+-1 %``, ``+-3 %`` at 3000 rpm, ``+1 %`` at 8000 rpm (teeth
separating). Each record is diagnosed by ``gear-rotor-sim calibrate RECORD --json`` and with ``--baseline``
(a healthy 2000 rpm record whose declared speed is exact, and one whose true speed is 1 % above the
declared one); ``--before`` adds the same calibrations with ``--no-speed-check`` (the declared speed as
is, the behaviour before session 17).

Usage::

    python benchmarks/calibration_speed_error.py [--out DIR] [--cases SUBSTR ...] [--errors PCT ...]
        [--no-baseline | --only-baseline] [--before | --only-before] [--references TAG ...] [--exact]
        [--duration-s S]

Prints one Markdown table per variant: truth, declared and measured speed (the ``operating_speed`` entry
of ``baseline_updates``; "=" when the declared speed was kept), the first effect, its main parameter
error, the error before/after, and the verdict by the issue-11 criteria of
``calibration_independent.judge`` (named first on the right wheel and tooth, within 25 %, error halved;
healthy: nothing claimed).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))

import calibration_independent as ci

from lumped_gearbox import CONTACT_RPM, RATTLE_RPM, make_record, write_record

#: faults at 3000 rpm (the table's severities): tooth damage on both wheels, an eccentricity, a bearing
#: defect and wear, with the healthy control
FAULTS_3000: list[tuple[str, str | None]] = [
    ("healthy", None),
    ("tooth_pinion", ci.FAULTS[0]),
    ("tooth_gear", ci.FAULTS[1]),
    ("gear_eccentricity", ci.FAULTS[3]),
    ("outer_race", ci.FAULTS[8]),
    ("tooth_wear", ci.FAULTS[6]),
]
ERRORS_PCT = [0.3, -0.3, 1.0, -1.0, 3.0, -3.0]
#: at the rattle point (8000 rpm): healthy and the pinion tooth, true speed 1 % above the declared one
RATTLE: list[tuple[str, str | None]] = [("healthy", None), ("tooth_pinion", ci.FAULTS[0])]
RATTLE_ERROR_PCT = 1.0
#: healthy references for --baseline: (tag, declared rpm, true error %)
REFERENCES = [("ref2000_exact", 2000.0, 0.0), ("ref2000_off1", 2000.0, 1.0)]
#: seeds: the +-1 % records 501 + 2 x (fault index) (+1 % first), the rattle ones 513, 514 (the first
#: run's), the other errors 601 + 10 x (fault index) + their index in OTHER_ERRORS_PCT: a record's seed
#: does not depend on which errors a run asks for
SEED0 = 501
OTHER_ERRORS_PCT = [0.3, -0.3, 3.0, -3.0]


def _seed(fault_index: int, error_pct: float) -> int:
    if abs(error_pct) == 1.0:
        return SEED0 + 2 * fault_index + (0 if error_pct > 0 else 1)
    if error_pct not in OTHER_ERRORS_PCT:
        raise ValueError(f"speed error {error_pct} % not in +-1 or {OTHER_ERRORS_PCT}")
    return 601 + 10 * fault_index + OTHER_ERRORS_PCT.index(error_pct)


@dataclass(frozen=True)
class SpeedCase:
    tag: str
    declared_rpm: float
    error_pct: float
    fault: str | None
    seed: int
    #: control: the sidecar declares the true speed (the same record's seed)
    exact: bool = False

    @property
    def true_rpm(self) -> float:
        return round(self.declared_rpm * (1.0 + self.error_pct / 100.0), 6)

    @property
    def written_rpm(self) -> float:
        """The speed the sidecar declares."""
        return self.true_rpm if self.exact else self.declared_rpm

    def table_case(self) -> ci.Case:
        """The table's case type for ``ci.judge``."""
        return ci.Case(self.tag, self.true_rpm, 25.0, self.fault, self.seed)


def cases(errors: list[float], exact: bool = False) -> list[SpeedCase]:
    """The records; ``exact``: the same records declared at their true speed (tags ``..._exact``)."""
    out: list[SpeedCase] = []
    sfx = "_exact" if exact else ""
    for fi, (name, fault) in enumerate(FAULTS_3000):
        for e in errors:
            out.append(SpeedCase(f"c3000_{name}_{e:+g}pct{sfx}", CONTACT_RPM, e, fault, _seed(fi, e), exact))
    for ri, (name, fault) in enumerate(RATTLE):
        tag = f"r8000_{name}_{RATTLE_ERROR_PCT:+g}pct{sfx}"
        out.append(SpeedCase(tag, RATTLE_RPM, RATTLE_ERROR_PCT, fault, 513 + ri, exact))
    return out


def make(case: SpeedCase, out: Path, duration_s: float) -> Path:
    """The record at the true speed; its sidecar declares ``case.declared_rpm``."""
    csv = out / f"{case.tag}.csv"
    if csv.exists():
        return csv
    rec = make_record(
        case.true_rpm, 25.0, [case.fault] if case.fault else [], duration_s=duration_s, seed=case.seed
    )
    write_record(csv, rec)
    side = csv.with_suffix(".yaml")
    d = yaml.safe_load(side.read_text())
    d["operating_point"]["speed_rpm"] = float(case.written_rpm)
    side.write_text(yaml.safe_dump(d, sort_keys=False))
    return csv


def _speeds(res: dict[str, Any]) -> tuple[float | None, float | None, float | None, float | None]:
    """(measured rpm, sigma, healthy error at the declared speed, at the measured) from the report's
    ``operating_speed`` entry; Nones when the declared speed was kept."""
    for b in res.get("baseline_updates") or []:
        if b.get("name") == "operating_speed":
            p = b.get("parameters") or {}
            return (
                p.get("speed_rpm"),
                (b.get("uncertainty") or {}).get("speed_rpm"),
                b.get("error_before"),
                b.get("error_after"),
            )
    return None, None, None, None


def row(case: SpeedCase, res: dict[str, Any], variant: str) -> dict[str, Any]:
    r = ci.judge(case.table_case(), res)
    meas, sig, e_decl, e_meas = _speeds(res)
    r.update(
        variant=variant,
        true_rpm=case.true_rpm,
        declared_rpm=case.written_rpm,
        measured_rpm=meas,
        sigma_rpm=sig,
        speed_error_before=e_decl,
        speed_error_after=e_meas,
    )
    return r


def _f(x: Any, spec: str = ".3g") -> str:
    return ci._fmt(x, spec)


def table(rows: list[dict[str, Any]]) -> str:
    head = (
        "| record | truth | true / declared rpm | measured rpm (sigma) | healthy model's error: declared -> "
        "measured speed | first effect | main parameter (error) | E before -> after | verdict | CPU (s) |\n"
        "|---|---|---|---|---|---|---|---|---|---|\n"
    )
    lines = []
    for r in rows:
        meas = (
            "="
            if r.get("measured_rpm") is None
            else f"{r['measured_rpm']:.3f} ({_f(r.get('sigma_rpm'), '.1g')})"
        )
        corr = (
            "-"
            if r.get("speed_error_before") is None
            else f"{_f(r['speed_error_before'])} -> {_f(r['speed_error_after'])}"
        )
        par = ci.param_cell(r, " ")
        lines.append(
            f"| {r['record']} | `{r['truth']}` | {r['true_rpm']:g} / {r['declared_rpm']:g} | {meas} | "
            f"{corr} | "
            f"{r.get('first', '-')} | {par} | {_f(r.get('error_before'))} -> {_f(r.get('error_after'))} | "
            f"{r['verdict']} | {_f(r.get('cpu_s'), '.0f')} |"
        )
    return head + "\n".join(lines) + "\n"


def _reference(tag: str, declared: float, err: float, out: Path, duration_s: float, check: bool) -> Path:
    """Saved reference baseline of a healthy record (declared speed ``declared``, true ``x (1 + err)``)."""
    from gear_rotor_sim.calibration.baseline import fit_reference_baseline
    from gear_rotor_sim.calibration.measurement import load_measurement

    csv = make(SpeedCase(tag, declared, err, None, 999), out, duration_s)
    dst = out / f"{tag}{'' if check else '.nocheck'}.reference.json"
    if not dst.exists():
        ref = fit_reference_baseline(load_measurement(csv), source=str(csv), speed_check=check)
        ref.save(dst)
    return dst


def run_variants(
    variants: list[tuple[str, Path | None, bool]],
    todo: list[Any],
    out: Path,
    row: Any,
    table: Any,
    no_check: str,
    t0: float,
    load0: float,
    reuse: bool = False,
) -> list[dict[str, Any]]:
    """Calibrate every case of ``todo`` in every ``(name, reference, check)`` variant (``no_check``: the CLI
    option that turns the check off), one at a time; print and write ``table.md`` and ``results.json``.
    ``reuse``: take a calibration already saved in ``out``. Shared with calibration_load_error.py."""
    rows: list[dict[str, Any]] = []
    text = ""
    for name, ref, check in variants:
        vrows = []
        for c in todo:
            key = f"{c.tag}.{'nocheck.' if not check else ''}{ref.stem if ref else 'noref'}.calibration.json"
            if reuse and (out / key).exists():
                res = json.loads((out / key).read_text())
            else:
                res = ci.calibrate(out / f"{c.tag}.csv", ref, () if check else (no_check,))
                (out / key).write_text(json.dumps(res, indent=1, default=str))
            vrows.append(row(c, res, name))
            print(f"{name}: {vrows[-1]['record']} {vrows[-1]['verdict']}", file=sys.stderr, flush=True)
        n_pass = sum(r["verdict"] == "PASS" for r in vrows)
        text += f"#### {name}\n\n" + table(vrows) + f"\n{n_pass} of {len(vrows)} pass.\n\n"
        rows += vrows
    text += (
        f"1 job on {os.cpu_count()} cores, load average {load0:.1f} at the start and "
        f"{os.getloadavg()[0]:.1f} at the end; total {time.perf_counter() - t0:.0f} s.\n"
    )
    ci.save_results(out, text, rows)
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="out/calibration_speed_error", help="records and results directory")
    ap.add_argument("--cases", nargs="*", default=None, help="only cases whose tag contains one of these")
    ap.add_argument("--errors", nargs="*", type=float, default=None, help="speed errors in %% at 3000 rpm")
    ap.add_argument("--duration-s", type=float, default=2.0, help="record length, s (default 2)")
    ap.add_argument("--no-baseline", action="store_true", help="skip the --baseline variants")
    ap.add_argument("--only-baseline", action="store_true", help="only the --baseline variants")
    ap.add_argument("--before", action="store_true", help="also calibrate with --no-speed-check")
    ap.add_argument("--only-before", action="store_true", help="only the --no-speed-check calibrations")
    ap.add_argument(
        "--exact",
        action="store_true",
        help="control: the same records with the sidecar declaring the true speed",
    )
    ap.add_argument(
        "--references",
        nargs="*",
        default=None,
        help="--baseline references to use (tags of REFERENCES; default both)",
    )
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    todo = ci.select_cases(cases(ERRORS_PCT if args.errors is None else args.errors, args.exact), args.cases)
    started = ci.prepare_run(todo, make, out, args.duration_s)
    if started is None:
        return 2
    t0, load0 = started
    checks = [False] if args.only_before else [True, False] if args.before else [True]
    variants: list[tuple[str, Path | None, bool]] = []
    for check in checks:
        suffix = "" if check else ", declared speed (--no-speed-check)"
        if not args.only_baseline:
            variants.append((f"no reference{suffix}", None, check))
        if not args.no_baseline:
            for tag, decl, err in REFERENCES:
                if args.references is not None and tag not in args.references:
                    continue
                ref = _reference(tag, decl, err, out, args.duration_s, check)
                variants.append(
                    (f"--baseline {tag} (true {decl * (1 + err / 100):g} rpm){suffix}", ref, check)
                )
    run_variants(variants, todo, out, row, table, "--no-speed-check", t0, load0)
    return 0


if __name__ == "__main__":
    sys.exit(main())
