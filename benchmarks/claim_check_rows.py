"""The claim check on every claim of saved calibration reports (docs/calibration.md Sec. 8.3).

``calibration/claim_check.py`` reads only the final residual trace and the effects' own errors, so it can be
evaluated on reports saved by the benchmarks (``<tag>[.baseline].calibration.json`` beside
``<tag>.truth.json``; reports of a code with ``residual_trace``). For every claimed effect it prints what
its two tests read (``pattern``: the profile of a trace reading on the effect's own families against the
effect's own patterns; ``torsional``: a lateral effect's own order on the DTE; ``own_order``: on a lateral
channel), the lacking share of the
final error in the effect's own families and the ``lacking_ratio`` (measured, not used), whether the claim
names an injected fault (``true``), a fault outside the library (``out-of-library``) or nothing injected
(``false``), and whether the check marks it suspect.

Usage::

    python benchmarks/claim_check_rows.py DIR [DIR ...] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import yaml

from gear_rotor_sim.calibration.claim_check import check_claims
from gear_rotor_sim.config import load_config

#: faults of the independent generator that the FE library does not model (lumped_gearbox/shaft_faults.py,
#: loose_housing.py); a ``shaft_crack`` claim on a crack record is a true one (``faults/crack.py``, since
#: session 22)
OUT_OF_LIBRARY = ("shaft_crack", "cardan_misalignment", "loose_housing")


def _kind(label: str, truth: list[dict[str, Any]]) -> str:
    names = {t.get("name") for t in truth}
    if label.startswith("shaft_crack@") and "shaft_crack" in names:  # in the library since session 22
        return "true"
    if names & set(OUT_OF_LIBRARY):
        return "out-of-library"
    for t in truth:
        name = str(t.get("name"))
        wheel = (t.get("parameters") or {}).get("wheel") or (t.get("parameters") or {}).get("member")
        if name == "tooth_damage" and label.startswith(f"tooth_damage@{wheel}"):
            return "true"
        if name == "gear_misalignment" and label == f"{wheel}_misalignment":
            return "true"
        if name not in ("tooth_damage", "gear_misalignment") and label.split("@")[0] == name:
            return "true"
    return "false"


def _reading(rd: dict[str, Any]) -> str:
    prof = " ".join(f"{k}:{v:.2f}" for k, v in (rd.get("profile") or {}).items() if v >= 0.05)
    return f"{rd['component']} ({rd['share']:.2f}) {'/'.join(rd.get('patterns') or []) or 'none'} [{prof}]"


def _torsional(chk: dict[str, Any]) -> str:
    """Tests 2 and 3's components (the effect's own order on the DTE and on the lateral channels: record /
    model) and test 3's spread."""
    own = chk.get("own_order") or {}
    comps = [chk["torsional"]] if chk.get("torsional") else []
    out = [
        f"{c['channel']} {c['at']} {c['measured_over_noise']:.3g}/{c['model_over_noise']:.3g}"
        for c in comps + own.get("components", [])
    ]
    spread = f" (spread {own['spread']:.2f})" if own else ""
    return "; ".join(out) + spread or "-"


def rows(directory: Path) -> list[dict[str, Any]]:
    """The check of every claim in the reports of ``directory``."""
    cfgs: dict[str, Any] = {}
    out = []
    for f in sorted(directory.glob("*.calibration.json")):
        rep = json.loads(f.read_text())
        tag = f.name.removesuffix(".calibration.json").removesuffix(".baseline")
        truth_file = directory / f"{tag}.truth.json"
        truth = json.loads(truth_file.read_text()).get("faults", []) if truth_file.exists() else []
        sidecar = directory / f"{tag}.yaml"
        gearbox = str(
            (yaml.safe_load(sidecar.read_text()) if sidecar.exists() else {}).get("gearbox")
            or "paper_sun2021"
        )
        cfg = cfgs.setdefault(gearbox, load_config(gearbox))
        effects = rep.get("effects") or []
        for e, chk in zip(effects, check_claims(effects, rep.get("residual_trace") or {}, cfg), strict=True):
            out.append(
                {
                    "record": tag,
                    "variant": "--baseline" if ".baseline." in f.name else "no reference",
                    "label": e.get("label"),
                    "kind": _kind(str(e.get("label")), truth),
                    "error_before": rep.get("error_before"),
                    "error_after": rep.get("error_after"),
                    **{
                        k: v
                        for k, v in chk.items()
                        if k not in ("readings", "label", "torsional", "own_order")
                    },
                    "reading": "; ".join(_reading(rd) for rd in chk["readings"]),
                    "torsional_rest": _torsional(chk),
                }
            )
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dirs", nargs="+", type=Path, help="directories of saved reports")
    ap.add_argument("--json", type=Path, default=None, help="write the rows as JSON")
    args = ap.parse_args(argv)
    allrows = [r for d in args.dirs for r in rows(d)]
    print(
        "| record | variant | claim | kind | E before -> after | readings of its own families (lacking "
        "share) pattern [profile] | own | own order on the DTE / a lateral channel (measured / model) | "
        "lacking share | lacking ratio | suspect |\n|---|---|---|---|---|---|---|---|---|---|---|"
    )
    for r in sorted(allrows, key=lambda x: (x["kind"], x["record"], x["variant"])):
        print(
            f"| {r['record']} | {r['variant']} | {r['label']} | {r['kind']} | {r['error_before']:.3g} -> "
            f"{r['error_after']:.3g} | {r['reading'] or '-'} | {'/'.join(r['own_patterns']) or '-'} | "
            f"{r['torsional_rest']} | {r['lacking_share']:.2f} | {r['lacking_ratio']:.3g} | "
            f"{', '.join(r['tests']) if r['suspect'] else 'no'} |"
        )
    for kind in ("true", "false", "out-of-library"):
        sel = [r for r in allrows if r["kind"] == kind]
        if sel:
            n_s = sum(r["suspect"] for r in sel)
            print(f"\n{kind}: {len(sel)} claims, {n_s} suspect", end="")
    print()
    if args.json:
        args.json.write_text(json.dumps(allrows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
