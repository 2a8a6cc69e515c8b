"""Which rows of the 27-row table can pass at all? A severity rule the same for every row (Sec. 8.32).

The acceptance asks the error to be at least halved. A perfect diagnosis leaves about the residual of
a healthy record of the same machine at the same operating point after its own calibration (the floor:
the model-form remainder after the baseline update, and the noise). So a fault row can pass only if

    error_before(row) >= k * floor,    k = 2,

with ``floor`` the healthy records' ``error_after`` at that operating point and variant (mean + 2 sd
over several noise seeds: the floor moves with the noise and gain draws). Wear (or any effect) whose
record scores below that bound is not observable enough for the table's criteria, whatever the method.

This script takes a finished run of ``benchmarks/calibration_independent.py`` (``--table DIR``: its
``results.json`` and the saved reference JSONs), calibrates extra healthy records at the contact and
rattle points (``--seeds``, both variants, the benchmark's own calibration command) and prints, per
row: its ``error_before``, the floor of its operating point, ``error_before / floor`` and whether the
rule holds; with the row's verdict from the run.

Usage::

    python benchmarks/calibration_independent.py --jobs 1 --out DIR
    python benchmarks/observability_rule.py --table DIR --seeds 701 702 703
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import calibration_independent as ci

#: the rule's factor: halving needs the error before at least twice the floor
K = 2.0
#: the two fault operating points of the table and the healthy record that sets each floor
POINTS = {
    "contact": (ci.CONTACT_RPM, "healthy_3000rpm_25C"),
    "rattle": (ci.RATTLE_RPM, "healthy_8000rpm_25C"),
}


def floors(
    table: Path, seeds: list[int], out: Path, ref: Path | None = None
) -> dict[tuple[str, bool], list[float]]:
    """Healthy ``error_after`` at each point and variant: the table's record and one per seed."""
    rows = json.loads((table / "results.json").read_text())
    got: dict[tuple[str, bool], list[float]] = {}
    for point, (_, tag) in POINTS.items():
        for r in rows:
            if r["record"] == tag and r.get("error_after") is not None:
                got.setdefault((point, bool(r.get("baseline"))), []).append(float(r["error_after"]))
    ref = ref or table / f"baseline_{ci.BASELINE[0]:.0f}rpm_{ci.BASELINE[1]:.0f}C.reference.json"
    for point, (speed, _) in POINTS.items():
        for seed in seeds:
            case = ci.Case(f"floor_{speed:.0f}rpm_25C_seed{seed}", speed, 25.0, None, seed)
            csv = ci.make(case, out, 2.0)
            for based in (False, True):
                if based and not ref.exists():
                    continue
                res = ci.calibrate(csv, ref if based else None)
                if res.get("failed") or res.get("effects"):
                    print(f"{case.tag} ({'ref' if based else 'no ref'}): {res.get('effects') or 'failed'}")
                got.setdefault((point, based), []).append(float(res["error_after"]))
                print(
                    f"{case.tag} ({'reference' if based else 'no reference'}): error "
                    f"{res['error_before']:.3g} -> {res['error_after']:.3g}",
                    flush=True,
                )
    return got


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--table", type=Path, required=True, help="output directory of calibration_independent.py"
    )
    ap.add_argument("--seeds", type=int, nargs="*", default=[701, 702, 703])
    ap.add_argument(
        "--out", type=Path, default=None, help="where the extra healthy records go (default: --table)"
    )
    ap.add_argument("--reference", type=Path, default=None, help="reference JSON (default: --table's)")
    ap.add_argument("--reuse-floors", action="store_true", help="read the floors of a previous run (--out)")
    args = ap.parse_args(argv)
    out = args.out or args.table
    out.mkdir(parents=True, exist_ok=True)
    saved = out / "floors.json"
    if args.reuse_floors and saved.exists():
        fl = {
            (k.split("|")[0], k.split("|")[1] == "ref"): v for k, v in json.loads(saved.read_text()).items()
        }
    else:
        fl = floors(args.table, args.seeds, out, args.reference)
        saved.write_text(json.dumps({f"{p}|{'ref' if b else 'noref'}": v for (p, b), v in fl.items()}))
    bound: dict[tuple[str, bool], float] = {}
    for key, v in sorted(fl.items()):
        a = np.array(v)
        sd = float(a.std(ddof=1)) if a.size > 1 else math.nan
        bound[key] = float(a.mean() + 2.0 * (sd if math.isfinite(sd) else 0.0))
        print(
            f"floor {key[0]} ({'reference' if key[1] else 'no reference'}): error_after over {a.size} "
            f"healthy records {', '.join(f'{x:.3g}' for x in a)}; mean {a.mean():.3g}, sd {sd:.3g}; "
            f"mean + 2 sd {bound[key]:.3g}; the rule asks error_before >= {K * bound[key]:.3g}"
        )
    rows: list[dict[str, Any]] = json.loads((args.table / "results.json").read_text())
    print(
        "\n| record | variant | error_before | floor (mean + 2 sd) | error_before / floor | rule "
        f"(>= {K:g}) | verdict |\n|---|---|---|---|---|---|---|"
    )
    for r in rows:
        point = next((p for p in POINTS if r["record"].startswith(p + "_")), None)
        if point is None or r.get("error_before") is None:
            continue
        based = bool(r.get("baseline"))
        f = bound.get((point, based))
        if f is None:
            continue
        ratio = float(r["error_before"]) / f
        print(
            f"| {r['record']} | {'reference' if based else 'none'} | {float(r['error_before']):.3g} | "
            f"{f:.3g} | {ratio:.2f} | {'yes' if ratio >= K else 'no'} | {r['verdict']} |"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
