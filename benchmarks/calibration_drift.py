"""Harm check of a change that moves the calibration reports' last digits: decisions equal, numbers within a
tolerance (docs/history/calibration_sessions.md Sec. 8.73).

Compares every ``*.calibration.json`` report in NEW with the report of the same name in REF:

* **decisions** (must be equal): the claimed effects' labels (name, wheel, tooth, node), their status and
  their integer/string parameters, the baseline updates' labels, the claim check's ``suspect`` verdicts,
  ``not_claimed`` and the conclusion text;
* **numbers** (relative drift, flagged above ``--tolerance``, default 0.5 %): the effects' and the baseline
  updates' float parameters, ``error_before`` and ``error_after``.

It prints one line per report (``same decisions`` or the decisions that differ, and the largest drift of
each number) and the largest relative drift of each field over all reports. Exit status 1 if a decision
differs or a drift exceeds the tolerance.

Usage::

    python benchmarks/calibration_drift.py NEW_DIR REF_DIR [--tolerance 0.005]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any


def decisions(report: dict[str, Any]) -> dict[str, Any]:
    """The report's decisions: what must not change when only the last digits may."""

    def entry(e: dict[str, Any]) -> tuple[Any, ...]:
        fixed = tuple(sorted((k, v) for k, v in e.get("parameters", {}).items() if not isinstance(v, float)))
        return (e.get("label"), e.get("status"), fixed)

    return {
        "effects": [entry(e) for e in report.get("effects") or []],
        "baseline_updates": [e.get("label") for e in report.get("baseline_updates") or []],
        "claim_checks": [(c.get("label"), c.get("suspect")) for c in report.get("claim_checks") or []],
        "not_claimed": report.get("not_claimed"),
        "conclusion": report.get("conclusion"),
    }


def numbers(report: dict[str, Any]) -> dict[str, float]:
    """The report's numbers by field name: the effects' and baseline updates' float parameters, the errors."""
    out: dict[str, float] = {"error_before": report["error_before"], "error_after": report["error_after"]}
    for group in ("effects", "baseline_updates"):
        for e in report.get(group) or []:
            for k, v in e.get("parameters", {}).items():
                if isinstance(v, float):
                    out[f"{group}:{e.get('label')}:{k}"] = v
    return out


def drift(new: float, ref: float) -> float:
    """Relative difference ``|new - ref| / |ref|`` (absolute where ``ref`` is 0)."""
    return abs(new - ref) / abs(ref) if ref else abs(new - ref)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("new", type=Path)
    ap.add_argument("ref", type=Path)
    ap.add_argument("--tolerance", type=float, default=0.005, help="largest relative drift (default 0.005)")
    args = ap.parse_args(argv)
    status = 0
    largest: dict[str, tuple[float, str]] = {}
    n = 0
    for path in sorted(args.new.glob("*.calibration.json")):
        ref_path = args.ref / path.name
        if not ref_path.exists():
            continue
        n += 1
        a, b = json.loads(path.read_text()), json.loads(ref_path.read_text())
        da, db = decisions(a), decisions(b)
        flips = [k for k in da if da[k] != db[k]]
        na, nb = numbers(a), numbers(b)
        worst = ("-", 0.0)
        over = []
        for k in sorted(set(na) | set(nb)):
            if k not in na or k not in nb:
                flips.append(f"number {k} in one report only")
                continue
            d = drift(na[k], nb[k])
            field = k if ":" not in k else f"{k.split(':')[0]}:{k.split(':')[-1]}"
            if d >= largest.get(field, (-1.0, ""))[0]:
                largest[field] = (d, path.name)
            if d > worst[1]:
                worst = (k, d)
            if d > args.tolerance:
                over.append(f"{k} {na[k]:.6g} vs {nb[k]:.6g}")
        if flips or over:
            status = 1
        verdict = (
            "same decisions"
            if not flips
            else "DECISIONS DIFFER: "
            + "; ".join(f"{k}: {da.get(k, '')} vs {db.get(k, '')}" if k in da else k for k in flips)
        )
        print(
            f"{path.name}: {verdict}; largest drift {worst[1]:.2e} ({worst[0]})"
            + (f"; over tolerance: {'; '.join(over)}" if over else "")
        )
    moved = sorted(((d, f, name) for f, (d, name) in largest.items() if d > 0), reverse=True)
    print(
        f"\n{n} report(s) compared; {len(largest) - len(moved)} field(s) equal in every report. "
        "Largest relative drift by field:"
    )
    for d, field, name in moved:
        print(f"  {d:.2e}  {field}  ({name})")
    return status


if __name__ == "__main__":
    sys.exit(main())
