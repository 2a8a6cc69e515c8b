"""Calibration of records whose input speed varies within the record (issue 11: effects nobody declared).

``lumped_gearbox`` makes each record with a speed profile (``make_record(..., speed_profile=...)``,
docs/independent_data.md "Speed profile"): a linear drift of ``+-0.5 %`` or ``+-1.5 %`` over the record
(centred: the declared speed is the mean) or a fluctuation of 0.5 % at 2 Hz, 1 % at 5 Hz or 0.3 % at the
gear's shaft rate (29.6 Hz at 3000 rpm, 78.9 Hz at 8000 rpm), or of 0.3 % or 1 % at order 2 of the input or of
the output shaft (``in2x*``, ``out2x*``: healthy, pinion tooth, gear misalignment at 3000 rpm). The sidecar
declares the mean speed and says nothing of the variation (``.truth.json`` holds the profile). Records: the
table's 3000 rpm faults (healthy, pinion tooth, gear tooth, pinion eccentricity, unbalance, gear misalignment,
wear, outer race, ball) with each profile, and at 8000 rpm (teeth separating) the healthy record and
the pinion tooth with a +1.5 % drift and the three fluctuations. Each record is diagnosed by
``gear-rotor-sim calibrate RECORD --json`` and, unless ``--no-baseline``, with ``--baseline`` (the
table's constant-speed healthy 2000 rpm record of the same machine; with ``--reference-profile TAG`` a
healthy 2000 rpm record with that speed profile, seed 999).

Usage::

    python benchmarks/calibration_speed_variation.py [--out DIR] [--cases SUBSTR ...] [--profiles TAG ...]
        [--no-baseline | --only-baseline] [--reference-profile TAG] [--reuse] [--duration-s S]

Prints one Markdown table per variant: the profile, the speed variation the report names (its
``issues`` line: range, drift, fluctuation; "-" when none), the first effect, its main parameter error,
the error before/after and the verdict by the issue-11 criteria of ``calibration_independent.judge``
(named first on the right wheel and tooth, within 25 %, error halved; healthy: nothing claimed).
"""

from __future__ import annotations

import argparse
import re
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import calibration_independent as ci
import calibration_speed_error as se

from lumped_gearbox import CONTACT_RPM, RATTLE_RPM, make_record, write_record

#: the table's faults at 3000 rpm (its severities) and the healthy control
FAULTS_3000: list[tuple[str, str | None]] = [
    ("healthy", None),
    ("tooth_pinion", ci.FAULTS[0]),
    ("tooth_gear", ci.FAULTS[1]),
    ("pinion_eccentricity", ci.FAULTS[2]),
    ("unbalance", ci.FAULTS[4]),
    ("gear_misalignment", ci.FAULTS[5]),
    ("tooth_wear", ci.FAULTS[6]),
    ("outer_race", ci.FAULTS[8]),
    ("ball", ci.FAULTS[10]),
]
#: speed profiles (tag, lumped_gearbox speed_profile fields)
PROFILES: list[tuple[str, dict[str, float]]] = [
    ("drift+0.5", {"drift_pct": 0.5}),
    ("drift-0.5", {"drift_pct": -0.5}),
    ("drift+1.5", {"drift_pct": 1.5}),
    ("drift-1.5", {"drift_pct": -1.5}),
    ("fluct0.5at2Hz", {"fluctuation_pct": 0.5, "fluctuation_hz": 2.0}),
    # other fluctuations a real machine has (session 19, Sec. 8.49): faster and larger (a torsional mode,
    # a belt), and one at the gear's shaft rate at 3000 rpm (a coupling), which no tracker of a few Hz
    # follows: periodic with the gear, it is synchronous content
    ("fluct1at5Hz", {"fluctuation_pct": 1.0, "fluctuation_hz": 5.0}),
    ("fluct0.3at29.6Hz", {"fluctuation_pct": 0.3, "fluctuation_hz": 3000.0 * 29.0 / 49.0 / 60.0}),
    # the gear's shaft rate at 8000 rpm (session 20, Sec. 8.55)
    ("fluct0.3at78.9Hz", {"fluctuation_pct": 0.3, "fluctuation_hz": 8000.0 * 29.0 / 49.0 / 60.0}),
    # at order 2 of the input (100 Hz) and of the output shaft (59.2 Hz) at 3000 rpm: a Cardan joint's 2x
    # ripple (session 21, Sec. 8.60)
    ("in2x0.3", {"fluctuation_pct": 0.3, "fluctuation_hz": 2.0 * 3000.0 / 60.0}),
    ("in2x1", {"fluctuation_pct": 1.0, "fluctuation_hz": 2.0 * 3000.0 / 60.0}),
    ("out2x0.3", {"fluctuation_pct": 0.3, "fluctuation_hz": 2.0 * 3000.0 * 29.0 / 49.0 / 60.0}),
    ("out2x1", {"fluctuation_pct": 1.0, "fluctuation_hz": 2.0 * 3000.0 * 29.0 / 49.0 / 60.0}),
]
#: at the rattle point (8000 rpm): healthy and the pinion tooth, +1.5 % drift and the fluctuations (1 % at
#: 5 Hz and 0.3 % at the gear's rate there since session 20)
RATTLE: list[tuple[str, str | None]] = [("healthy", None), ("tooth_pinion", ci.FAULTS[0])]
RATTLE_PROFILES = ["drift+1.5", "fluct0.5at2Hz", "fluct1at5Hz", "fluct0.3at78.9Hz"]
#: seeds: 701 + 10 x (fault index) + (profile index); 8000 rpm: 801 + 10 x (fault index) + (profile index)
SEED0, RATTLE_SEED0 = 701, 801
#: profiles made only at 8000 rpm (a shaft rate there)
RATTLE_ONLY = {"fluct0.3at78.9Hz"}
#: the order-2 profiles, made at 3000 rpm for these faults only (the misalignment also modulates the mesh
#: timing at its wheel's order 2), seeds 901 + 10 x (fault index) + (index among the order-2 profiles)
ORDER2 = ["in2x0.3", "in2x1", "out2x0.3", "out2x1"]
ORDER2_FAULTS = ["healthy", "tooth_pinion", "gear_misalignment"]
ORDER2_SEED0 = 901


@dataclass(frozen=True)
class VarCase:
    tag: str
    speed_rpm: float
    fault: str | None
    profile: str
    seed: int

    def table_case(self) -> ci.Case:
        """The table's case type for ``ci.judge``."""
        return ci.Case(self.tag, self.speed_rpm, 25.0, self.fault, self.seed)


def cases(profiles: list[str] | None = None) -> list[VarCase]:
    """The records (healthy first at each speed); ``profiles``: only these profile tags."""
    names = [p for p, _ in PROFILES]
    out: list[VarCase] = []
    for fi, (name, fault) in enumerate(FAULTS_3000):
        for pi, p in enumerate(names):
            if p in ORDER2:
                if name in ORDER2_FAULTS:
                    seed = ORDER2_SEED0 + 10 * fi + ORDER2.index(p)
                    out.append(VarCase(f"c3000_{name}_{p}", CONTACT_RPM, fault, p, seed))
                continue
            if p in RATTLE_ONLY:
                continue
            out.append(VarCase(f"c3000_{name}_{p}", CONTACT_RPM, fault, p, SEED0 + 10 * fi + pi))
    for fi, (name, fault) in enumerate(RATTLE):
        for p in RATTLE_PROFILES:
            seed = RATTLE_SEED0 + 10 * fi + names.index(p)
            out.append(VarCase(f"r8000_{name}_{p}", RATTLE_RPM, fault, p, seed))
    if profiles is not None:
        out = [c for c in out if c.profile in profiles]
    return out


def make(case: VarCase, out: Path, duration_s: float) -> Path:
    """The record with its speed profile; the sidecar declares the mean speed only."""
    csv = out / f"{case.tag}.csv"
    if csv.exists():
        return csv
    rec = make_record(
        case.speed_rpm,
        25.0,
        [case.fault] if case.fault else [],
        duration_s=duration_s,
        seed=case.seed,
        speed_profile=dict(PROFILES)[case.profile],
    )
    return write_record(csv, rec)


def _variation(res: dict[str, Any]) -> str:
    """The report's varying-speed line, shortened: range, drift, fluctuation ("-" when none)."""
    for s in res.get("issues") or []:
        if "speed varies within the record" in s:
            m = re.search(r"\(range ([^ ]+) %.*drift ([^ ]+) %.*fluctuation ([^ ]+) % at ([^ ]+) Hz", s)
            return f"range {m[1]} %, drift {m[2]} %, {m[3]} % at {m[4]} Hz" if m else "named"
    return "-"


def row(case: VarCase, res: dict[str, Any], variant: str) -> dict[str, Any]:
    """The table's verdict of one calibration, with the profile and the variation the report names."""
    r = ci.judge(case.table_case(), res)
    r.update(variant=variant, profile=case.profile, variation=_variation(res))
    return r


def table(rows: list[dict[str, Any]]) -> str:
    head = (
        "| record | truth | profile | variation named | first effect | main parameter (error) | "
        "E before -> after | verdict | CPU (s) |\n|---|---|---|---|---|---|---|---|---|\n"
    )
    lines = []
    for r in rows:
        par = ci.param_cell(r, " ")
        lines.append(
            f"| {r['record']} | `{r['truth']}` | {r['profile']} | {r['variation']} | {r.get('first', '-')} | "
            f"{par} | {ci._fmt(r.get('error_before'))} -> {ci._fmt(r.get('error_after'))} | {r['verdict']} | "
            f"{ci._fmt(r.get('cpu_s'), '.0f')} |"
        )
    return head + "\n".join(lines) + "\n"


def _reference(out: Path, duration_s: float, profile: str | None = None) -> Path:
    """The table's healthy 2000 rpm reference, its baseline fitted once: at constant speed, or with the
    speed profile ``profile`` (a reference whose own speed fluctuates, the harder case)."""
    from gear_rotor_sim.calibration.baseline import fit_reference_baseline
    from gear_rotor_sim.calibration.measurement import load_measurement

    sp, tc = ci.BASELINE
    case = ci.Case(f"baseline_{sp:.0f}rpm_{tc:.0f}C", sp, tc, None, 999)
    tag = case.tag if profile is None else f"{case.tag}_{profile}"
    csv = out / f"{tag}.csv"
    if not csv.exists():
        if profile is None:
            ci.make(case, out, duration_s)
        else:
            rec = make_record(
                sp, tc, [], duration_s=duration_s, seed=999, speed_profile=dict(PROFILES)[profile]
            )
            write_record(csv, rec)
    dst = out / f"{tag}.reference.json"
    if not dst.exists():
        fit_reference_baseline(load_measurement(csv), source=str(csv)).save(dst)
    return dst


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="out/calibration_speed_variation", help="records and results directory")
    ap.add_argument("--cases", nargs="*", default=None, help="only cases whose tag contains one of these")
    ap.add_argument(
        "--profiles",
        nargs="*",
        default=None,
        help=f"only these profiles ({', '.join(p for p, _ in PROFILES)})",
    )
    ap.add_argument("--duration-s", type=float, default=2.0, help="record length, s (default 2)")
    ap.add_argument("--no-baseline", action="store_true", help="skip the --baseline variant")
    ap.add_argument("--only-baseline", action="store_true", help="only the --baseline variant")
    ap.add_argument("--reuse", action="store_true", help="take a calibration already saved in --out")
    ap.add_argument(
        "--reference-profile",
        default=None,
        help="the --baseline reference with this speed profile (default: constant speed)",
    )
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    todo = ci.select_cases(cases(args.profiles), args.cases)
    started = ci.prepare_run(todo, make, out, args.duration_s, "--cases / --profiles")
    if started is None:
        return 2
    t0, load0 = started
    variants: list[tuple[str, Path | None, bool]] = []
    if not args.only_baseline:
        variants.append(("no reference", None, True))
    if not args.no_baseline:
        ref = _reference(out, 2.0, args.reference_profile)
        how = "constant speed" if args.reference_profile is None else args.reference_profile
        variants.append((f"--baseline healthy {ci.BASELINE[0]:g} rpm ({how})", ref, True))
    se.run_variants(variants, todo, out, row, table, "--no-speed-check", t0, load0, reuse=args.reuse)
    return 0


if __name__ == "__main__":
    sys.exit(main())
