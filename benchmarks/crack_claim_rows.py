"""What offering the breathing shaft crack (``faults/crack.py``, session 22) changed on saved records.

For every record ``<tag>.csv`` with ``<tag>.truth.json`` in ``RECORDS``, compares a report made before
(``<tag>[.baseline].calibration.json`` in ``RECORDS``, the benchmarks' naming) with one made after
(``<tag>[.baseline].json`` in ``--after``: ``gear-rotor-sim calibrate RECORD --json > AFTER/<tag>.json``):
the first effect and its main parameter, the error before and after, and every ``shaft_crack`` claimed
(confidence, status) or fitted in round 0 (its Delta BIC there and the round-0 leader). A crack claimed on a
record without one is a wrong claim; a change of the first effect is a moved row.

Usage::

    python benchmarks/crack_claim_rows.py RECORDS --after DIR [--baseline] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any


def _first(rep: dict[str, Any]) -> str:
    eff = rep.get("effects") or []
    if not eff:
        return "none"
    e = eff[0]
    p = e.get("parameters") or {}
    main = next((v for k, v in p.items() if isinstance(v, float) and k not in ("phase_rad",)), None)
    val = f" {main:.3g}" if main is not None else ""
    status = "" if e.get("status") == "found" else f", {e.get('status')}"
    return f"{e['label']}{val} ({e.get('confidence', 0):.2f}{status})"


def _crack(rep: dict[str, Any]) -> str:
    claims = [e for e in rep.get("effects") or [] if str(e.get("label", "")).startswith("shaft_crack")]
    if claims:
        e = claims[0]
        return (
            f"CLAIMED loss {e['parameters']['stiffness_loss']:.3g} ({e.get('confidence', 0):.2f}, "
            f"{e.get('status')})"
        )
    r0 = (rep.get("candidates_by_round") or [[]])[0]
    c = next((c for c in r0 if str(c.get("label", "")).startswith("shaft_crack")), None)
    lead = r0[0]["label"] if r0 else "-"
    if c is None:
        return f"not in round 0 (leader {lead})"
    return f"round 0 dBIC {c['delta_bic']:.3g} (leader {lead})"


def rows(records: Path, after: Path, baseline: bool) -> list[dict[str, Any]]:
    """One row per record with both reports."""
    suffix = ".baseline" if baseline else ""
    out = []
    for truth_f in sorted(records.glob("*.truth.json")):
        tag = truth_f.name[: -len(".truth.json")]
        before_f = records / f"{tag}{suffix}.calibration.json"
        after_f = after / f"{tag}{suffix}.json"
        if not (before_f.is_file() and after_f.is_file()):
            continue
        truth = json.loads(truth_f.read_text())
        faults = ", ".join(f["name"] for f in truth.get("faults") or []) or "healthy"
        try:
            b, a = json.loads(before_f.read_text()), json.loads(after_f.read_text())
        except json.JSONDecodeError:  # a report still being written
            continue
        out.append(
            {
                "record": tag,
                "truth": faults,
                "before": _first(b),
                "e_before": f"{b['error_before']:.3g} -> {b['error_after']:.3g}",
                "after": _first(a),
                "e_after": f"{a['error_before']:.3g} -> {a['error_after']:.3g}",
                "crack": _crack(a),
                "moved": _first(b) != _first(a),
            }
        )
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("records", type=Path)
    ap.add_argument("--after", type=Path, required=True)
    ap.add_argument("--baseline", action="store_true", help="compare the --baseline reports")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    rs = rows(args.records, args.after, args.baseline)
    print("| record | truth | before: first (conf) | E | after: first (conf) | E | shaft_crack |")
    print("|---|---|---|---|---|---|---|")
    for r in rs:
        mark = " **moved**" if r["moved"] else ""
        print(
            f"| {r['record']} | {r['truth']} | {r['before']} | {r['e_before']} | {r['after']}{mark} | "
            f"{r['e_after']} | {r['crack']} |"
        )
    wrong = [r for r in rs if r["crack"].startswith("CLAIMED") and "shaft_crack" not in r["truth"]]
    print(
        f"\n{len(rs)} records, {sum(r['moved'] for r in rs)} moved, {len(wrong)} with a crack claimed wrongly"
    )
    if args.json:
        args.json.write_text(json.dumps(rs, indent=1))


if __name__ == "__main__":
    main()
