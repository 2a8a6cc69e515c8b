"""The parsimony rule's statistics on saved calibration reports: what keeps a candidate out, and how far
the healthy records stand from the thresholds (docs/history/calibration_sessions.md Sec. 8.69).

For each ``*.calibration.json`` in the given directories (or given files), per search round, the best
tooth-damage candidate of each wheel and the tooth-wear candidate from ``candidates_by_round``: Delta BIC
and the share of the excess residual it explains (``explained_fraction``; the rule of
``FitSettings.min_explained``, Sec. 8.22 cause D), and the wear's static chi^2 (the channel means against
the model before it: the rule ``9 n + 25`` of ``candidates_wear.wear_static_inconsistency``, Sec. 8.34),
read from the report's note where a wear candidate was verified, else from the final static error
(``n E^2``). A record is counted as healthy when its name starts with ``healthy_`` or holds ``node14``
(the held-out gear-shaft unbalance the six channels cannot see, judged as healthy).

The summary prints, over the healthy reports, the largest tooth share in any round after the first
(round 0 runs before the baseline sets, where a baseline set, not a fault, leads), the largest wear
share and the largest static chi^2, each against the thresholds.

Usage::

    python benchmarks/parsimony_margins.py out/heldout out/table
    python benchmarks/parsimony_margins.py --all-rounds out/heldout/healthy_1500rpm_25C.calibration.json
"""

from __future__ import annotations

import argparse
import json
import re
from pathlib import Path
from typing import Any

#: the wear rule's limit on the static chi^2 before the candidate, ``9 n + 25`` for ``n`` means
STATIC_PER_MEAN, STATIC_OFFSET = 9.0, 25.0
#: ``FitSettings``' defaults: every candidate's share and Delta BIC thresholds
MIN_EXPLAINED, BIC_THRESHOLD = 0.25, 10.0
#: the tooth threshold whose margin is printed (``--tooth-share``)
TOOTH_SHARE = 0.1
_STATIC_NOTE = re.compile(r"tooth_wear: not claimed .*static chi2 ([0-9.eE+-]+) for (\d+) means")


def reports(paths: list[str]) -> list[Path]:
    """The report files under ``paths`` (directories: every ``*.calibration.json``)."""
    out: list[Path] = []
    for p in map(Path, paths):
        out.extend(sorted(p.glob("*.calibration.json")) if p.is_dir() else [p])
    return out


def is_healthy(path: Path) -> bool:
    """A healthy record of the table or the held-out set (the node-14 unbalance judged as healthy)."""
    return path.name.startswith("healthy_") or "node14" in path.name


def round_stats(rnd: list[dict[str, Any]]) -> dict[str, tuple[float, float]]:
    """``{key: (delta_bic, explained)}`` of the best tooth candidate per wheel and the wear candidate."""
    out: dict[str, tuple[float, float]] = {}
    for c in rnd:
        if c.get("name") not in ("tooth_damage", "tooth_wear"):
            continue
        key = str(c.get("label"))
        if key not in out:  # the rounds list candidates best first
            out[key] = (float(c["delta_bic"]), float(c["explained_fraction"]))
    return out


def static_chi2(rep: dict[str, Any]) -> tuple[float, int, str]:
    """The static chi^2 the wear rule judged (its note), else ``n E^2`` of the final static error."""
    for note in rep.get("notes") or []:
        m = _STATIC_NOTE.search(note)
        if m:
            return float(m.group(1)), int(m.group(2)), f"the wear note, {m.group(2)} means"
    e = (rep.get("error_after_by_family") or {}).get("static")
    if e is None:
        return float("nan"), 0, "-"
    # the contract's channels hold four judged means (three bearing-force components and the DTE)
    return float(e) ** 2 * 4, 4, "n E^2 of the final static error, 4 means"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("paths", nargs="+", help="report directories or files")
    ap.add_argument("--all-rounds", action="store_true", help="print every round, not only the maxima")
    ap.add_argument(
        "--tooth-share",
        type=float,
        default=TOOTH_SHARE,
        help=f"a damaged tooth's threshold to measure the margin of (default {TOOTH_SHARE})",
    )
    args = ap.parse_args()
    worst = {"band": (0.0, ""), "static": (0.0, "")}
    for path in reports(args.paths):
        rep = json.loads(path.read_text())
        effects = ", ".join(str(e.get("label")) for e in rep.get("effects") or []) or "none"
        chi2, _n, src = static_chi2(rep)
        based = "reference" if path.name.endswith(".baseline.calibration.json") else "no reference"
        print(f"{path.name} ({based}): effects {effects}; static chi2 {chi2:.3g} ({src})")
        band, top = (0.0, "-"), (0.0, "-")
        for i, rnd in enumerate(rep.get("candidates_by_round") or []):
            st = round_stats(rnd)
            if args.all_rounds:
                lead = rnd[0]["label"] if rnd else "-"
                parts = "; ".join(f"{k} dBIC {d:.4g}, share {x:.3f}" for k, (d, x) in st.items())
                print(f"  round {i}: leader {lead} | {parts}")
            for k, (d, x) in st.items():
                if not k.startswith("tooth_damage") or d <= BIC_THRESHOLD:
                    continue
                if x > top[0]:
                    top = (x, f"{k}, round {i}")
                if x < MIN_EXPLAINED and x > band[0]:
                    band = (x, f"{k}, round {i}")
        margin = args.tooth_share / band[0] if band[0] > 0 else float("inf")
        print(
            f"  tooth (dBIC > {BIC_THRESHOLD:g}): largest share {top[0]:.3f} ({top[1]}); largest below "
            f"{MIN_EXPLAINED} {band[0]:.3f} ({band[1]}): {args.tooth_share} / it = {margin:.3g}"
        )
        if is_healthy(path):
            for key, val in (("band", band[0]), ("static", chi2)):
                if val == val and val > worst[key][0]:
                    worst[key] = (val, path.name)
    print("\nhealthy reports, largest values:")
    print(
        f"  tooth share below {MIN_EXPLAINED} with dBIC > {BIC_THRESHOLD:g}: {worst['band'][0]:.3f} "
        f"({worst['band'][1]}) against {args.tooth_share}"
    )
    lim = STATIC_PER_MEAN * 4 + STATIC_OFFSET
    print(f"  static chi2 {worst['static'][0]:.3g} ({worst['static'][1]}) against 9 n + 25 = {lim:.0f}")


if __name__ == "__main__":
    main()
