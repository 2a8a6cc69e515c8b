"""Calibration of records whose declared output torque is not the true one (issue 11: undeclared effects).

``lumped_gearbox`` makes each record at its TRUE output torque (``Gearbox(output_torque_nm=...)``); the
sidecar then declares 200 N m (the record's ``.yaml`` rewritten; ``.truth.json`` gets the true torque as
``output_torque_nm``), or leaves ``output_torque_nm`` out (``undeclared``: the rig's 200 N m is used). True
torques 150, 240, 300 N m at 3000 rpm (teeth in contact) and 8000 rpm (teeth separating), for the healthy
machine and seven faults at the table's severities. Each record is diagnosed by ``gear-rotor-sim calibrate
RECORD --json`` and with ``--baseline`` (a healthy 2000 rpm record of the same machine at 200 N m declared
200, and ``ref2000_T240``: true 240 N m declared 200, the reference's load the wrong one); ``--before`` adds
the same calibrations with ``--no-load-check`` (the declared torque as is: the behaviour before session 18).

Usage::

    python benchmarks/calibration_load_error.py [--out DIR] [--cases SUBSTR ...] [--torques NM ...]
        [--no-baseline | --only-baseline] [--before | --only-before] [--references TAG ...]
        [--duration-s S] [--reuse]
    python benchmarks/calibration_load_error.py [--out DIR] (--statistic | --statistic-benchmarks
        | --statistic-files CSV ...) [--statistic-reference JSON]   # the check's statistic, no calibration

Prints one Markdown table per variant: truth, true / declared torque, the torque the calibration ran at
(the ``operating_torque`` entry of ``baseline_updates``; "=" when the declared torque was kept), the first
effect, its main parameter error, the error before/after, and the verdict by the issue-11 criteria of
``calibration_independent.judge`` (named first on the right wheel and tooth, within 25 %, error halved;
healthy: nothing claimed).
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))

import calibration_independent as ci
import calibration_speed_error as se

from lumped_gearbox import CONTACT_RPM, RATTLE_RPM, Gearbox, make_record, write_record

#: the healthy machine and seven faults at the table's severities (calibration_independent.FAULTS)
FAULTS: list[tuple[str, str | None]] = [
    ("healthy", None),
    ("tooth_pinion", ci.FAULTS[0]),
    ("tooth_gear", ci.FAULTS[1]),
    ("pinion_eccentricity", ci.FAULTS[2]),
    ("gear_misalignment", ci.FAULTS[5]),
    ("tooth_wear", ci.FAULTS[6]),
    ("outer_race", ci.FAULTS[8]),
    ("temperature_offset", ci.FAULTS[7]),
]
SPEEDS = {"c3000": CONTACT_RPM, "r8000": RATTLE_RPM}
#: true torques (N m); the sidecar declares DECLARED_NM, "undeclared" records leave the field out
TRUE_NM = [150.0, 240.0, 300.0]
DECLARED_NM = 200.0
#: the record declared without the field: its true torque
UNDECLARED_TRUE_NM = 240.0
#: healthy 2000 rpm references for --baseline: (tag, true torque)
REFERENCES = [("ref2000_T200", 200.0), ("ref2000_T240", 240.0)]


@dataclass(frozen=True)
class LoadCase:
    tag: str
    speed_rpm: float
    true_nm: float
    fault: str | None
    seed: int
    #: the sidecar's torque; None: the field is left out
    declared_nm: float | None = DECLARED_NM

    def table_case(self) -> ci.Case:
        return ci.Case(self.tag, self.speed_rpm, 25.0, self.fault, self.seed)


def cases(torques: list[float]) -> list[LoadCase]:
    """Every record. Seeds ``701 + 40 s + 5 f + t``: speed ``s``, fault ``f``, true torque ``t`` (its
    index in ``TRUE_NM``, 3 for the undeclared record), independent of which a run asks for."""
    out: list[LoadCase] = []
    for si, (op, rpm) in enumerate(SPEEDS.items()):
        for fi, (name, fault) in enumerate(FAULTS):
            for ti, tq in enumerate(TRUE_NM):
                if tq in torques:
                    seed = 701 + 40 * si + 5 * fi + ti
                    out.append(LoadCase(f"{op}_{name}_T{tq:.0f}", rpm, tq, fault, seed))
            seed = 701 + 40 * si + 5 * fi + 3
            out.append(
                LoadCase(
                    f"{op}_{name}_undeclared_T{UNDECLARED_TRUE_NM:.0f}",
                    rpm,
                    UNDECLARED_TRUE_NM,
                    fault,
                    seed,
                    None,
                )
            )
    return out


def make(case: LoadCase, out: Path, duration_s: float) -> Path:
    """The record at the true torque; its sidecar declares ``case.declared_nm`` (or nothing)."""
    csv = out / f"{case.tag}.csv"
    if csv.exists():
        return csv
    rec = make_record(
        case.speed_rpm,
        25.0,
        [case.fault] if case.fault else [],
        duration_s=duration_s,
        seed=case.seed,
        gearbox=Gearbox(output_torque_nm=case.true_nm),
    )
    write_record(csv, rec)
    side = csv.with_suffix(".yaml")
    d = yaml.safe_load(side.read_text())
    if case.declared_nm is None:
        d["operating_point"].pop("output_torque_nm", None)
    else:
        d["operating_point"]["output_torque_nm"] = float(case.declared_nm)
    side.write_text(yaml.safe_dump(d, sort_keys=False))
    truth = csv.with_suffix(".truth.json")
    t = json.loads(truth.read_text())
    t["output_torque_nm"] = case.true_nm
    t["declared_output_torque_nm"] = case.declared_nm
    truth.write_text(json.dumps(t, indent=2))
    return csv


def torque_entry(res: dict[str, Any]) -> dict[str, Any]:
    """The report's ``operating_torque`` entry (empty when the declared torque was kept)."""
    return next((b for b in res.get("baseline_updates") or [] if b.get("name") == "operating_torque"), {})


def row(case: LoadCase, res: dict[str, Any], variant: str) -> dict[str, Any]:
    r = ci.judge(case.table_case(), res)
    e = torque_entry(res)
    r.update(
        variant=variant,
        true_nm=case.true_nm,
        declared_nm=case.declared_nm,
        measured_nm=(e.get("parameters") or {}).get("output_torque_nm"),
        sigma_nm=(e.get("uncertainty") or {}).get("output_torque_nm"),
        load_error_before=e.get("error_before"),
        load_error_after=e.get("error_after"),
        issues=[i for i in res.get("data_issues") or res.get("issues") or [] if "torque" in str(i)],
    )
    return r


def table(rows: list[dict[str, Any]]) -> str:
    head = (
        "| record | truth | true / declared N m | run at N m (sigma) | healthy model's error: declared -> "
        "run torque | first effect | main parameter (error) | E before -> after | verdict | CPU (s) |\n"
        "|---|---|---|---|---|---|---|---|---|---|\n"
    )
    lines = []
    for r in rows:
        run_at = (
            "="
            if r.get("measured_nm") is None
            else f"{r['measured_nm']:.1f} ({ci._fmt(r.get('sigma_nm'), '.2g')})"
        )
        corr = "-"
        if r.get("load_error_before") is not None:
            corr = f"{ci._fmt(r['load_error_before'])} -> {ci._fmt(r['load_error_after'])}"
        par = ci.param_cell(r, " ")
        decl = "-" if r["declared_nm"] is None else f"{r['declared_nm']:g}"
        lines.append(
            f"| {r['record']} | `{r['truth']}` | {r['true_nm']:g} / {decl} | {run_at} | {corr} | "
            f"{r.get('first', '-')} | {par} | {ci._fmt(r.get('error_before'))} -> "
            f"{ci._fmt(r.get('error_after'))} | {r['verdict']} | {ci._fmt(r.get('cpu_s'), '.0f')} |"
        )
    return head + "\n".join(lines) + "\n"


def _reference(tag: str, true_nm: float, out: Path, duration_s: float, check: bool) -> Path:
    """Saved reference baseline of a healthy 2000 rpm record at ``true_nm``, declared 200 N m."""
    from gear_rotor_sim.calibration.baseline import fit_reference_baseline
    from gear_rotor_sim.calibration.measurement import load_measurement

    csv = make(LoadCase(tag, 2000.0, true_nm, None, 999 if true_nm == DECLARED_NM else 998), out, duration_s)
    dst = out / f"{tag}{'' if check else '.nocheck'}.reference.json"
    if not dst.exists():
        kw = {} if check else {"load_check": False}
        ref = fit_reference_baseline(load_measurement(csv), source=str(csv), **kw)
        ref.save(dst)
    return dst


def record_statistic(csv: Path, reference: Path | None = None) -> dict[str, Any]:
    """The load check's statistic on one record: the healthy model's setup at the declared torque (32
    steps per mesh period, or 64 against ``reference``, without the step rule; the radial means do not
    depend on the step count), no calibration."""
    from gear_rotor_sim.calibration.baseline import load_reference
    from gear_rotor_sim.calibration.fit import Calibrator
    from gear_rotor_sim.calibration.load_check import load_estimate
    from gear_rotor_sim.calibration.measurement import load_measurement

    kw = load_reference(reference).calibrator_kwargs() if reference is not None else {}
    cal = Calibrator(load_measurement(csv), steps_per_mesh=64 if reference else 32, **kw)
    cal.auto_steps = False
    base_out = cal._setup()
    est = load_estimate(cal, base_out)
    if est is None:
        return {
            "declared_nm": float("nan"),
            "ratios": [],
            "ratio": float("nan"),
            "sigma": float("nan"),
            "z": float("nan"),
            "consistent": False,
            "fires": False,
        }
    return {
        "declared_nm": est.declared_nm,
        "ratios": list(est.ratios),
        "ratio": est.ratio,
        "sigma": est.sigma,
        "z": est.z,
        "consistent": est.consistent,
        "fires": est.fires,
    }


def statistic(paths: list[Path], reference: Path | None = None) -> str:
    """Markdown table of :func:`record_statistic` over ``paths``."""
    lines = [
        "| record | declared N m | radial ratios | load ratio (sigma) | z | consistent | fires |",
        "|---|---|---|---|---|---|---|",
    ]
    for p in paths:
        s = record_statistic(p, reference)
        lines.append(
            f"| {p.stem} | {s['declared_nm']:g} | {', '.join(f'{x:.4f}' for x in s['ratios'])} | "
            f"{s['ratio']:.4f} ({s['sigma']:.3g}) | {s['z']:+.2f} | {s['consistent']} | {s['fires']} |"
        )
        print(lines[-1], file=sys.stderr, flush=True)
    return "\n".join(lines) + "\n"


def benchmark_records(out: Path, duration_s: float) -> list[Path]:
    """The 71 records of the issue-11 benchmarks at their declared 200 N m (written into ``out`` unless
    there): the 28-row table, its two references and the 41 held-out records."""
    import calibration_heldout as ho

    out.mkdir(parents=True, exist_ok=True)
    table = ci.cases(False) + [
        ci.Case(f"baseline_{sp:.0f}rpm_{tc:.0f}C", sp, tc, None, 999)
        for sp, tc in (ci.BASELINE, ci.BASELINE_ALT)
    ]
    paths = [
        out / f"{c.tag}.csv" if (out / f"{c.tag}.csv").exists() else ci.make(c, out, duration_s)
        for c in table
    ]
    held = ho.cases()
    paths += [
        out / f"{c.tag}.csv" if (out / f"{c.tag}.csv").exists() else ho.make(c, out, duration_s) for c in held
    ]
    return paths


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="out/calibration_load_error", help="records and results directory")
    ap.add_argument("--cases", nargs="*", default=None, help="only cases whose tag contains one of these")
    ap.add_argument("--torques", nargs="*", type=float, default=None, help="true torques, N m (default all)")
    ap.add_argument("--duration-s", type=float, default=2.0, help="record length, s (default 2)")
    ap.add_argument("--no-baseline", action="store_true", help="skip the --baseline variants")
    ap.add_argument("--only-baseline", action="store_true", help="only the --baseline variants")
    ap.add_argument("--before", action="store_true", help="also calibrate with --no-load-check")
    ap.add_argument("--only-before", action="store_true", help="only the --no-load-check calibrations")
    ap.add_argument("--reuse", action="store_true", help="take a calibration already saved in --out")
    ap.add_argument(
        "--references", nargs="*", default=None, help="--baseline references (tags of REFERENCES)"
    )
    ap.add_argument(
        "--statistic", action="store_true", help="no calibration: print the load check's statistic per record"
    )
    ap.add_argument(
        "--statistic-files",
        nargs="+",
        default=None,
        metavar="CSV",
        help="no calibration: the statistic of these records (e.g. the table's and the held-out ones)",
    )
    ap.add_argument(
        "--statistic-benchmarks",
        action="store_true",
        help="no calibration: the statistic of the 71 records of calibration_independent.py and "
        "calibration_heldout.py",
    )
    ap.add_argument("--statistic-reference", default=None, help="saved reference baseline for the statistic")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    ref_stat = Path(args.statistic_reference) if args.statistic_reference else None
    if args.statistic_files or args.statistic_benchmarks:
        files = [Path(p) for p in args.statistic_files or []]
        if args.statistic_benchmarks:
            files += benchmark_records(out / "benchmark_records", args.duration_s)
        text = statistic(files, ref_stat)
        print(text)
        (out / "statistic_files.md").write_text(text)
        return 0
    todo = ci.select_cases(cases(TRUE_NM if args.torques is None else args.torques), args.cases)
    started = ci.prepare_run(todo, make, out, args.duration_s)
    if started is None:
        return 2
    t0, load0 = started
    if args.statistic:
        text = statistic([out / f"{c.tag}.csv" for c in todo], ref_stat)
        print(text)
        (out / "statistic.md").write_text(text)
        return 0
    checks = [False] if args.only_before else [True, False] if args.before else [True]
    variants: list[tuple[str, Path | None, bool]] = []
    for check in checks:
        suffix = "" if check else ", declared torque (--no-load-check)"
        if not args.only_baseline:
            variants.append((f"no reference{suffix}", None, check))
        if not args.no_baseline:
            for tag, tq in REFERENCES:
                if args.references is not None and tag not in args.references:
                    continue
                ref = _reference(tag, tq, out, args.duration_s, check)
                variants.append((f"--baseline {tag} (true {tq:g} N m, declared 200){suffix}", ref, check))
    se.run_variants(variants, todo, out, row, table, "--no-load-check", t0, load0, args.reuse)
    return 0


if __name__ == "__main__":
    sys.exit(main())
