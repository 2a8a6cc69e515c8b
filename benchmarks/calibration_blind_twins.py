"""The blind set's failures classified, with healthy twins for observability (history Sec. 8.75).

For each failed case of a finished ``calibration_blind.py`` run this script makes healthy twins: records of
the same machine at the same speed and declared temperature without the fault, with other noise and gain
seeds (the case's seed + 1, + 2, ...), calibrates them in the same variant (no reference, or ``--baseline``
with the case's own reference) and classifies the failure (the classes pre-registered in
``calibration_blind_cases.json``):

- (d) an effect claimed on a healthy record;
- (a) not observable: the record's ``error_before`` is not above the largest ``error_before`` of its
  healthy twins (the fault moves the record no farther from the model than the noise and gain draws do);
- (b) the injected effect not named first (another effect, the wrong location, or nothing);
- (c) named first, the main parameter off by more than 25 %;
- (e) named, within 25 %, the error not halved.

The first class that applies is the case's; the line also gives the twins' ``error_after`` (the floor a
perfect diagnosis leaves, Sec. 8.32; with ``--max-effects 0`` the error after the baseline update alone) and
``error_before / floor``. ``--max-effects 0`` leaves ``error_before`` as a full calibration has it (the
nominal or reference-updated model's score, before any baseline update or effect) at a fraction of its time.

Usage::

    python benchmarks/calibration_blind_twins.py --out out/calibration_blind [--twins 2]
        [--no-baseline | --only-baseline] [--cases SUBSTR ...] [--max-effects K]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import calibration_blind as cb
import calibration_independent as ci


def twin_case(case: dict[str, Any], k: int) -> ci.Case:
    """The case's ``k``-th healthy twin (same point, seed + k)."""
    return ci.Case(f"{case['tag']}_twin{k}", case["speed_rpm"], case["temperature_c"], None, case["seed"] + k)


def twin_report(
    case: dict[str, Any], k: int, out: Path, baseline: bool, duration_s: float, extra: tuple[str, ...]
) -> dict[str, Any]:
    """The twin's calibration report (from disk when saved)."""
    tw = twin_case(case, k)
    path = out / f"{tw.tag}{'.baseline' if baseline else ''}.calibration.json"
    if path.exists():
        return json.loads(path.read_text())
    csv = out / f"{tw.tag}.csv"
    if not csv.exists():
        ci.make(tw, out, duration_s)
    ref = cb.reference(case, out, duration_s) if baseline else None
    res = ci.calibrate(csv, ref, extra)
    path.write_text(json.dumps(res, indent=1, default=str))
    return res


def classify(row: dict[str, Any], twins: list[dict[str, Any]]) -> str:
    """The failure class of a judged row (``calibration_blind.row_of``) given its twins' reports."""
    checks = row.get("checks", {})
    if "no effect claimed" in checks:
        return "d"
    before = [float(t["error_before"]) for t in twins if t.get("error_before") is not None]
    if before and float(row["error_before"]) <= max(before):
        return "a"
    if not checks.get("named first"):
        return "b"
    if not checks.get("param within 25 %"):
        return "c"
    return "e"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ci.add_run_arguments(ap, "out/calibration_blind", jobs=False)
    ap.add_argument("--set", type=int, default=1, choices=sorted(cb.SETS), help="blind set (default 1)")
    ap.add_argument("--twins", type=int, default=2, help="healthy twins per failed case (default 2)")
    ap.add_argument(
        "--max-effects",
        type=int,
        default=None,
        help="pass --max-effects to the twins' calibrations (0: only their error_before and baseline)",
    )
    args = ap.parse_args(argv)
    out = Path(args.out)
    cases = [
        c
        for c in cb.load_cases(cb.case_file(args.set))
        if not args.cases or any(s in c["tag"] for s in args.cases)
    ]
    extra = ("--max-effects", str(args.max_effects)) if args.max_effects is not None else ()
    print(
        "| case | variant | truth | verdict | class | error before | twins' error before | "
        "twins' error after | before / floor |\n|---|---|---|---|---|---|---|---|---|"
    )
    counts: dict[str, int] = {}
    for baseline in [b for b, on in ((False, not args.only_baseline), (True, not args.no_baseline)) if on]:
        for c in cases:
            (row,) = cb.collect([c], [out], baseline)
            if row["verdict"] in ("PASS", "not run"):
                continue
            twins = []
            if "no effect claimed" not in row.get("checks", {}):
                twins = [
                    twin_report(c, k, out, baseline, args.duration_s, extra) for k in range(1, args.twins + 1)
                ]
            cls = classify(row, twins)
            counts[cls] = counts.get(cls, 0) + 1
            tb = [ci._fmt(t.get("error_before")) for t in twins]
            ta = [float(t["error_after"]) for t in twins if t.get("error_after") is not None]
            ratio = float(row["error_before"]) / max(ta) if ta else None
            print(
                f"| {c['tag']} | {'--baseline' if baseline else 'no reference'} | `{row['truth']}` | "
                f"{row['verdict']} ({row.get('first', '-')}) | {cls} | {ci._fmt(row.get('error_before'))} | "
                f"{', '.join(tb) or '-'} | {', '.join(ci._fmt(x) for x in ta) or '-'} | "
                f"{ci._fmt(ratio, '.2f')} |"
            )
    print("\nfailures by class: " + (", ".join(f"({k}) {v}" for k, v in sorted(counts.items())) or "none"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
