"""Calibration on records holding effects nobody declared that were never tried (issue 11, session 22).

Common on real machines and never in a benchmark record before session 22
(docs/history/calibration_sessions.md Sec. 8.62), each made by the independent generator itself
(``lumped_gearbox``: physically modelled, off by default, docs/independent_data.md):

- ``pitch``: manufacturing pitch errors on every tooth of both wheels (``lumped_gearbox/pitch.py``; ISO 1328
  quality 5-7: RMS single pitch deviation 3 or 6 um): a healthy machine's gear-order comb and mesh
  sidebands;
- ``acforce``: AC-coupled (piezoelectric) force sensors, a first-order high-pass at 0.5 Hz on the three
  bearing force channels (``lumped_gearbox/sensors.py``): their means are gone; ``acaxial``: on the axial
  force only;
- ``acclp`` / ``acchp``: band-limited accelerometers, a second-order low-pass at 3 kHz (a magnet mount) or a
  first-order high-pass at 10 Hz (IEPE coupling) on both accelerometers;
- ``multi``: three faults at once, and two faults whose signatures share a family.

Each record is a table record (``benchmarks/calibration_independent.py``: the same fault, seed and operating
point, so with the effect off it is that table's row) with the effect added; the sidecar does not declare
it. It is diagnosed as a user would, ``gear-rotor-sim calibrate RECORD --json``, and with ``--baseline``
against a healthy 2000 rpm record of the SAME machine (its pitch errors and sensors too). Verdicts are the
table's (``calibration_heldout.judge``: named first at the injected location, main parameter within 25 %,
error at least halved; healthy: nothing claimed; several faults: each among the first ``n`` effects, each
within 25 %).

Usage::

    python benchmarks/calibration_undeclared_more.py [--jobs 1] [--out DIR] [--cases SUBSTR ...]
        [--baseline | --only-baseline]
    python benchmarks/calibration_undeclared_more.py --from-results DIR [DIR ...]
    python benchmarks/calibration_undeclared_more.py --list
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import calibration_heldout as ch
import calibration_independent as ci

from lumped_gearbox import CONTACT_RPM, RATTLE_RPM, make_record, parse_fault, write_record
from lumped_gearbox.pitch import PitchErrors
from lumped_gearbox.sensors import SensorFilter

F = ci.FAULTS
#: the table records disturbed: tag -> (faults, the table's seed, speed, declared temperature)
BASES: dict[str, tuple[tuple[str, ...], int, float, float]] = {
    "healthy": ((), 34, CONTACT_RPM, 25.0),  # healthy_3000rpm_25C
    "healthy_8000": ((), 35, RATTLE_RPM, 25.0),  # healthy_8000rpm_25C
    "healthy_125C": ((), 36, CONTACT_RPM, 125.0),  # healthy_3000rpm_125C
    "tooth_pinion": ((F[0],), 11, CONTACT_RPM, 25.0),  # contact_tooth_damage_pinion
    "tooth_gear": ((F[1],), 12, CONTACT_RPM, 25.0),  # contact_tooth_damage_gear
    "gear_ecc": ((F[3],), 14, CONTACT_RPM, 25.0),  # contact_gear_eccentricity
    "wear": ((F[6],), 17, CONTACT_RPM, 25.0),  # contact_tooth_wear
    "temp60": ((F[7],), 18, CONTACT_RPM, 25.0),  # contact_temperature_offset (+60 C)
    "outer_race": ((F[8],), 19, CONTACT_RPM, 25.0),  # contact_outer_race_defect
    # not in the table (new seeds): three faults at once; two whose signatures share a family (1x of the gear)
    "three": (("pinion_eccentricity:eccentricity_m=15e-6,phase_rad=0.5", F[8], F[1]), 201, CONTACT_RPM, 25.0),
    "gecc_gmis": ((F[3], F[5]), 202, CONTACT_RPM, 25.0),
}
FORCES = ("bearing2_fx", "bearing2_fy", "bearing2_fz")
ACCELS = ("node5_ax", "node5_ay")
#: each effect: make_record keywords (the machine: its reference record gets them too) and the columns it
#: touches (for the ``issues`` column of the table)
EFFECTS: dict[str, tuple[dict[str, Any], tuple[str, ...]]] = {
    "pitch6": ({"pitch_errors": PitchErrors(f_pt_um=6.0, seed=7)}, ()),
    "pitch3": ({"pitch_errors": PitchErrors(f_pt_um=3.0, seed=7)}, ()),
    "acforce": ({"sensors": {c: SensorFilter("highpass", 0.5) for c in FORCES}}, FORCES),
    "acaxial": ({"sensors": {"bearing2_fz": SensorFilter("highpass", 0.5)}}, ("bearing2_fz",)),
    "acclp": ({"sensors": {c: SensorFilter("lowpass", 3000.0, 2) for c in ACCELS}}, ACCELS),
    "acchp": ({"sensors": {c: SensorFilter("highpass", 10.0) for c in ACCELS}}, ACCELS),
    "multi": ({}, ()),
}
#: (effect, base) in the order a user's data most likely hold them: pitch errors and AC-coupled forces first
PLAN: list[tuple[str, str]] = [
    *[("pitch6", b) for b in ("healthy", "healthy_8000", "healthy_125C", "tooth_pinion", "gear_ecc")],
    *[("pitch6", b) for b in ("outer_race", "wear", "tooth_gear")],
    *[("pitch3", b) for b in ("healthy", "healthy_8000", "tooth_pinion", "gear_ecc")],
    *[("pitch3", b) for b in ("healthy_125C", "tooth_gear", "wear")],
    *[
        ("acforce", b)
        for b in ("healthy", "healthy_125C", "temp60", "tooth_pinion", "gear_ecc", "outer_race")
    ],
    *[("acforce", b) for b in ("wear", "healthy_8000")],
    *[("acaxial", b) for b in ("healthy_125C", "temp60")],
    *[("acclp", b) for b in ("healthy", "tooth_pinion", "gear_ecc", "outer_race")],
    *[("acchp", b) for b in ("healthy", "gear_ecc")],
    ("multi", "three"),
    ("multi", "gecc_gmis"),
]
#: the healthy reference of ``--baseline`` (calibration_independent.BASELINE, the table's seed 999)
REFERENCE = (2000.0, 25.0, 999)


@dataclass(frozen=True)
class More:
    tag: str
    effect: str
    base: str
    faults: tuple[str, ...]
    seed: int
    speed_rpm: float
    temperature_c: float
    machine: dict[str, Any] = field(default_factory=dict, compare=False, hash=False)

    def held(self) -> ch.Held:
        """The held-out benchmark's case type, for its ``judge``."""
        return ch.Held(self.tag, self.speed_rpm, self.temperature_c, self.faults, self.seed)


def cases() -> list[More]:
    out = []
    for effect, base in PLAN:
        faults, seed, speed, temp = BASES[base]
        out.append(More(f"{effect}_{base}", effect, base, faults, seed, speed, temp, EFFECTS[effect][0]))
    return out


def make(case: More, out: Path, duration_s: float) -> Path:
    rec = make_record(
        case.speed_rpm,
        case.temperature_c,
        list(case.faults),
        duration_s=duration_s,
        seed=case.seed,
        **case.machine,
    )
    return write_record(out / f"{case.tag}.csv", rec)


def _reference(case: More, out: Path, duration_s: float) -> Path:
    """The machine's healthy 2000 rpm reference (its pitch errors and sensors), fitted once and saved."""
    from gear_rotor_sim.calibration.baseline import fit_reference_baseline
    from gear_rotor_sim.calibration.measurement import load_measurement

    path = out / f"reference_{case.effect}.reference.json"
    if not path.exists():
        speed, temp, seed = REFERENCE
        ref = More(f"reference_{case.effect}", case.effect, "", (), seed, speed, temp, case.machine)
        csv = make(ref, out, duration_s)
        fit_reference_baseline(load_measurement(csv), source=str(csv)).save(path)
    return path


def _several(case: More, res: dict[str, Any]) -> dict[str, Any]:
    """Three or more faults: each among the first ``n`` effects at its location, each within 25 %."""
    row = ch.judge(ch.Held(case.tag, case.speed_rpm, case.temperature_c, (), case.seed), res)
    effects = res.get("effects") or []
    n = len(case.faults)
    found, parts = [], []
    for text in case.faults:
        fault = parse_fault(text)
        hit = next((e for e in effects[:n] if ch._matches(fault, e)), None)
        got = float((hit or {}).get("parameters", {}).get(fault.main, math.nan))
        want = float(getattr(fault, fault.main))
        found.append((hit is not None, abs(got - want) <= 0.25 * want))
        parts.append(
            f"{fault.main}: {ci._fmt(got)} / {ci._fmt(want)} ({ci._fmt((got - want) / want, '+.0%')})"
        )
    ratio = row.get("ratio", math.nan)
    row["checks"] = {
        "named first": all(f[0] for f in found),
        "param within 25 %": all(f[1] for f in found),
        "error halved": bool(ratio <= 0.5),
    }
    row.update(truth=" + ".join(case.faults), param_text="; ".join(parts))
    row["first"] = ", ".join(str(e.get("label") or e.get("name")) for e in effects[:n]) or "none"
    row["verdict"] = "PASS" if all(row["checks"].values()) else "FAIL"
    return row


def judge(case: More, res: dict[str, Any]) -> dict[str, Any]:
    """``calibration_heldout.judge`` (up to two faults), :func:`_several` for more; the ``issues`` that name
    a column the effect touched and its mean."""
    row = ch.judge(case.held(), res) if len(case.faults) <= 2 else _several(case, res)
    row["effect"] = case.effect
    cols = EFFECTS[case.effect][1]
    named = [i for i in res.get("issues") or [] if "mean" in str(i) and any(c in str(i) for c in cols)]
    row["issues_named"] = "-" if not cols else ("yes" if named else "no")
    row["issues_text"] = named[:3]
    return row


def _result(out: Path, case: More, baseline: bool) -> Path:
    return out / f"{case.tag}{'.baseline' if baseline else ''}.calibration.json"


def _job(args: tuple[More, str, float, str | None]) -> dict[str, Any]:
    """Calibrate one record (made beforehand) through the held-out benchmark's job, judged here."""
    case, out, duration, baseline = args
    ch._job((case.held(), out, duration, baseline))  # calibrates and saves <tag>[.baseline].calibration.json
    row = judge(case, json.loads(_result(Path(out), case, baseline is not None).read_text()))
    row["baseline"] = Path(baseline).name if baseline else None
    return row


def table(rows: list[dict[str, Any]]) -> str:
    head = (
        "| record | variant | truth | first effect(s) | main parameter(s) | E before -> after | verdict | "
        "`issues` name the effect's columns | CPU (s) |\n|---|---|---|---|---|---|---|---|---|\n"
    )
    lines = []
    for r in rows:
        par = r.get("param_text") or ci.param_cell(r)
        err = f"{ci._fmt(r.get('error_before'))} -> {ci._fmt(r.get('error_after'))}"
        lines.append(
            f"| {r['record']} | {'--baseline' if r.get('baseline') else 'no reference'} | `{r['truth']}` | "
            f"{r.get('first', '-')} | {par} | {err} | {r['verdict']} | {r.get('issues_named', '-')} | "
            f"{ci._fmt(r.get('cpu_s'), '.0f')} |"
        )
    return head + "\n".join(lines) + "\n"


def collect(todo: list[More], dirs: list[Path], baseline: bool) -> list[dict[str, Any]]:
    """Rows of the saved results found in ``dirs`` (the first directory holding a case's wins)."""
    saved = {c.tag: [_result(d, c, baseline) for d in dirs if _result(d, c, baseline).exists()] for c in todo}
    rows = [judge(c, json.loads(saved[c.tag][0].read_text())) for c in todo if saved[c.tag]]
    return [{**r, "baseline": "yes" if baseline else None} for r in rows]


def radial_mean_stats(dirs: list[Path]) -> str:
    """The AC-coupling rule's statistic on saved records (``force_coupling.means_not_measured``): each radial
    bearing-force channel's mean over its noise deviation (scatter of per-revolution means) and over the
    largest mean the rule reads as none (2 % of the load, here of the measured mean at gain 1.25)."""
    import numpy as np
    import yaml

    lines, worst = [], (math.inf, "")
    for d in dirs:
        for csv in sorted(d.glob("*.csv")):
            side = yaml.safe_load(csv.with_suffix(".yaml").read_text())
            cols = [
                c["column"]
                for c in side["channels"]
                if c["quantity"] == "bearing_force" and c["direction"] in "xy"
            ]
            data = np.genfromtxt(csv, delimiter=",", names=True)
            n_rev = round(side["sample_rate_hz"] * 60.0 / side["operating_point"]["speed_rpm"])
            for c in cols:
                x = data[c]
                blocks = x[: x.size // n_rev * n_rev].reshape(-1, n_rev).mean(axis=1)
                sd = float(np.std(blocks, ddof=1) / math.sqrt(blocks.size))
                ratio = abs(float(np.mean(x))) / max(5.0 * sd, 0.02 * abs(float(np.mean(x))) / 1.25)
                worst = min(worst, (ratio, f"{csv.name}:{c}"))
                lines.append(f"{csv.name} {c}: mean {np.mean(x):.4g} N, {abs(np.mean(x)) / sd:.3g} sd")
    return "\n".join(lines) + f"\nsmallest mean over the rule's no-mean bound: {worst[0]:.3g} ({worst[1]})\n"


def pitch_stats(f_pts: tuple[float, ...] = (0.0, 3.0, 6.0)) -> str:
    """Where the pitch errors' content goes (healthy 3000 rpm, clean channels): the share of the time a pair
    in the loaded zone (its stiffness shape above 5 %) is out of contact, and the share of ``bearing2_fx``'s
    and the DTE's power over one hunting period (49 pinion, 29 gear revolutions, 0.98 s) at neither shaft's
    orders."""
    import numpy as np

    from lumped_gearbox import Gearbox, build
    from lumped_gearbox import model as mdl
    from lumped_gearbox.mesh import pair_shape

    gb, lines = Gearbox(), []
    for f_pt in f_pts:
        pe = PitchErrors(f_pt_um=f_pt, seed=7)
        r = make_record(
            CONTACT_RPM, 25.0, [], seed=34, sampling="point", pitch_errors=pe, noise=(0, 0), gain_error=0
        )
        g, q, t = build(gb, CONTACT_RPM, 25.0).geo, r.clean["q"], r.time_s
        e = pe.vector(gb.z1, gb.z2, gb.pressure_angle_rad)
        dm = g[mdl.G_SA] * (q[:, 0] - q[:, 4]) + g[mdl.G_CA] * (q[:, 1] - q[:, 5])
        dm += g[mdl.G_RB1] * q[:, 3] + g[mdl.G_RB2] * q[:, 7]
        u = g[mdl.G_Z1] * g[mdl.G_W1] * t / (2.0 * math.pi)
        dm -= gb.ste_amplitude_m * np.sin(2.0 * math.pi * u)
        b = build(gb, CONTACT_RPM, 25.0).load[mdl.L_B]
        lost = 0
        for i in range(t.size):
            pairs = [math.floor(u[i]) - k for k in range(3)]
            loaded = [n for n in pairs if pair_shape(u[i] - n, g[mdl.G_EPS], g[mdl.G_RELIEF]) > 0.05]
            lost += any(dm[i] + e[n % gb.z1] + e[gb.z1 + n % gb.z2] <= b for n in loaded)
        shares = []
        for col in ("bearing2_fx", "dte"):
            x = r.clean[col][19600:39200]  # the second hunting period (20 kHz)
            p = np.abs(np.fft.rfft(x - x.mean())) ** 2
            k = np.arange(p.size)
            shares.append(f"{col} {p[(k % 49 != 0) & (k % 29 != 0)].sum() / p.sum():.3g}")
        lines.append(
            f"f_pt {f_pt:g} um: a loaded pair out of contact {lost / t.size:.3f} of the time; "
            f"non-synchronous share of the power over a hunting period: {', '.join(shares)}"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--jobs", type=int, default=1, help="parallel calibrations (default 1)")
    ap.add_argument("--out", default="out/calibration_undeclared_more", help="records and results directory")
    ap.add_argument("--cases", nargs="*", default=None, help="only cases whose tag contains one of these")
    ap.add_argument("--duration-s", type=float, default=2.0, help="record length, s (default 2)")
    ap.add_argument("--baseline", action="store_true", help="also the --baseline variant")
    ap.add_argument("--only-baseline", action="store_true", help="only the --baseline variant")
    ap.add_argument(
        "--from-results", nargs="+", metavar="DIR", help="re-render saved results, no calibration"
    )
    ap.add_argument("--list", action="store_true", help="print the cases and exit")
    ap.add_argument(
        "--mean-stats", nargs="+", metavar="DIR", help="the AC-coupling rule's statistic on saved records"
    )
    ap.add_argument(
        "--pitch-stats", action="store_true", help="where the pitch errors' content goes, no calibration"
    )
    args = ap.parse_args(argv)
    if args.pitch_stats:
        print(pitch_stats())
        return 0
    if args.mean_stats:
        print(radial_mean_stats([Path(d) for d in args.mean_stats]))
        return 0
    todo = ci.select_cases(cases(), args.cases)
    if args.list:
        for c in todo:
            print(f"{c.tag}: {' + '.join(c.faults) or 'healthy'} at {c.speed_rpm:.0f} rpm, seed {c.seed}")
        return 0
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.from_results:
        dirs = [Path(d) for d in args.from_results]
        rows = collect(todo, dirs, False) + collect(todo, dirs, True)
        n_pass = sum(r["verdict"] == "PASS" for r in rows)
        ci.save_results(
            out, table(rows) + f"\n{n_pass} of {len(rows)} pass; results from {args.from_results}\n", rows
        )
        return 0
    started = ci.prepare_run(todo, make, out, args.duration_s)
    if started is None:
        return 2
    t0, load0 = started
    jobs: list[tuple[More, str, float, str | None]] = []
    if not args.only_baseline:
        jobs += [(c, str(out), args.duration_s, None) for c in todo]
    if args.baseline or args.only_baseline:
        jobs += [(c, str(out), args.duration_s, str(_reference(c, out, args.duration_s))) for c in todo]
    rows = ci.run_jobs(_job, jobs, args.jobs)
    n_pass = sum(r["verdict"] == "PASS" for r in rows)
    note = ci.run_note(args.jobs, load0, t0)
    ci.save_results(out, table(rows) + f"\n{n_pass} of {len(rows)} pass; {note}.\n", rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
