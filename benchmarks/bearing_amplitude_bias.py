"""Where the bearing-defect force read on an independent record comes from (issue 11;
docs/history/calibration_sessions.md Sec. 8.36).

For each record (a ``lumped_gearbox`` record of the held-out set or of the 28-row table, regenerated
with the benchmark's seed) the calibration runs as the CLI does; then, on the calibrated machine
(baseline sets and every other accepted effect in place), the force is fitted to the envelope family
alone (the family a defect acts on, ``candidates_bearing.fit_force_and_share``'s objective) with these
model responses of the defect, each per newton:

- ``oracle``: the generator's own defect pulses of this record (``lumped_gearbox.bearing.defect_forces``
  with the record's seed and the generator's data-acquisition low-pass, ``daq.low_pass_sample``) added
  to the calibrated model's bearing-force channels. The fitted factor reads the features' own bias:
  with a perfect defect model it is 1 (the truth) whatever the noise; a severity-dependent departure
  is an additive term in the envelope features or their noise model, not a model-form difference.
- ``direct``: the FE library's direct path alone (shaft-path share 0), its pulses averaged over each
  sample interval (the default) and through the simulator's anti-aliasing decimation
  (``ModelRunner.direct_path_anti_alias``).
- ``share``: direct plus the fitted share of the shaft path (the calibration's rule, Sec. 8.30).

Printed: the CLI's force and share, each fit's force over the truth, and the truth in the library's
impulse terms (the generator's 0.4 mm spall against the library's nominal 0.35 mm; its outer race
scaled by the Hertz factor at its position, Sec. 8.13). Usage::

    python benchmarks/bearing_amplitude_bias.py --cases ball_defect_x0.6 [--out DIR] [--table]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from scipy.optimize import minimize_scalar

sys.path.insert(0, str(Path(__file__).resolve().parent))

import calibration_heldout as ho
import calibration_independent as ci

from gear_rotor_sim.calibration.candidates_bearing import choose_share, fit_force_per_share
from lumped_gearbox import bearing as lbear
from lumped_gearbox import parse_fault
from lumped_gearbox.daq import DAQ_SUBSTEPS, anti_alias_fir, low_pass_sample


def _cases(table: bool) -> list[Any]:
    return list(ci.cases(False)) if table else list(ho.cases())


def generator_pulses(fault: Any, speed_rpm: float, t: np.ndarray, fs: float) -> np.ndarray:
    """The generator's defect force per newton at the sample times ``t`` through its DAQ chain, (n, 2)."""
    h = anti_alias_fir(DAQ_SUBSTEPS)
    half = (h.size - 1) // 2
    dt = 1.0 / (fs * DAQ_SUBSTEPS)
    n_fine = (t.size - 1) * DAQ_SUBSTEPS + 2 * half + 1
    tf = t[0] + (np.arange(n_fine) - half) * dt
    # load direction of bearing 2 in the generator (simulate.channels): -110 deg
    sa, ca = math.sin(math.radians(20.0)), math.cos(math.radians(20.0))
    fine = lbear.defect_forces(
        fault.kind, 1.0, fault.defect_angle_rad, speed_rpm, tf, math.atan2(-ca, -sa), seed=0
    )
    return np.column_stack([low_pass_sample(fine[:, k], DAQ_SUBSTEPS, t.size, h) for k in range(2)])


def library_terms(fault: Any) -> float:
    """The generator's force in the library's impulse terms (0.35 mm spall; outer race at its Hertz
    factor, which the library's outer race does not carry)."""
    f = float(fault.force_n) * lbear.SPALL_WIDTH / 0.35e-3
    if fault.kind == "outer":
        psi = fault.defect_angle_rad - math.radians(-110.0)
        f *= max(math.cos(psi), 0.0) ** 1.5
    return f


def envelope_fit(cal: Any, f_prev: Any, d: Any, f0: float) -> tuple[float, float]:
    """Force minimising the envelope chi^2 of ``f_prev + force d`` (bounded Brent), and that chi^2."""

    def chi2(x: float) -> float:
        return float(cal.cmp.score(f_prev.combo(d, x)).chi2["envelope"])

    res = minimize_scalar(chi2, bounds=(0.05 * f0, 5.0 * f0), method="bounded", options={"xatol": 1e-3 * f0})
    return float(res.x), float(res.fun)


def diagnose(case: Any, out: Path, baseline: Path | None, mimic: bool = False) -> dict[str, Any]:
    from gear_rotor_sim.calibration.calibrate_cli import skip_start_transient
    from gear_rotor_sim.calibration.fit import Calibrator
    from gear_rotor_sim.calibration.measurement import load_measurement
    from gear_rotor_sim.faults.bearing import BearingDefect

    faults = getattr(case, "faults", None) or ((case.fault,) if case.fault else ())
    csv = out / f"{case.tag}.csv"
    if not csv.exists():
        (ho.make if hasattr(case, "faults") else ci.make)(case, out, 2.0)
    m = load_measurement(csv, None, "error")
    start = skip_start_transient(m, None)
    if start:
        m = m.segment(start, None)
    kw: dict[str, Any] = {}
    if baseline is not None:
        from gear_rotor_sim.calibration.baseline import load_reference

        kw = load_reference(str(baseline)).calibrator_kwargs()
    t0 = time.process_time()
    cal = Calibrator(m, **kw)
    res = cal.run()
    cpu = time.process_time() - t0
    row: dict[str, Any] = {
        "record": case.tag,
        "cpu_s": cpu,
        "notes": [n for n in res.notes if "bearing" in n],
    }
    found = [e for e in res.effects if isinstance(e.effect, BearingDefect)]
    gen = [parse_fault(f) for f in faults]
    gen = [f for f in gen if f.name.endswith("defect")]
    if not found or not gen:
        row["first"] = [e.label for e in res.effects]
        return row
    e = found[0].effect
    truth = gen[0]
    others = [x.effect for x in res.effects if x.effect is not None and x.effect is not e]
    row.update(
        first=[x.label for x in res.effects],
        truth=float(truth.force_n),
        library_terms=library_terms(truth),
        cli_force=float(e.force_n),
        cli_share=float(e.shaft_path_share),
        bands={
            cal.cmp.names[c]: list(map(float, b)) for c, b in enumerate(cal.cmp.bands) if cal.cmp.env_use[c]
        },
    )
    f0 = float(e.force_n)
    base = cal._raw(tuple(others))
    f_prev = cal._full_features(base)
    # the generator's own pulses (per newton) on the calibrated machine
    names = cal.runner.sim_channels()
    fs = cal.m.sample_rate_hz
    t = cal.runner.start_time + np.arange(base.shape[0]) / fs
    orc = base.copy()
    p = generator_pulses(truth, cal.m.operating_point.speed_rpm, t, fs)
    for k, a in enumerate("xy"):
        if f"bearing2_f{a}" in names:
            orc[:, names.index(f"bearing2_f{a}")] += p[:, k]
    d_orc = cal._full_features(orc).combo(f_prev, -1.0)
    row["oracle"], row["oracle_chi2"] = envelope_fit(cal, f_prev, d_orc, f0)
    unit = dataclasses.replace(e, force_n=1.0)
    per: dict[str, Any] = {}
    for label, share in (("direct", 0.0), ("share", float(e.shaft_path_share)), ("full", 1.0)):
        d = cal._full_features(cal._raw((*others, dataclasses.replace(unit, shaft_path_share=share))))
        per[label] = d.combo(f_prev, -1.0)
        row[label] = envelope_fit(cal, f_prev, per[label], f0)[0]
    d_shaft = per["full"].combo(per["direct"], -1.0)

    def chi2(force: float, share: float) -> float:  # candidates_bearing.fit_shaft_path_share's objective
        return float(
            cal.cmp.score(f_prev.combo(per["direct"], force).combo(d_shaft, force * share)).chi2["envelope"]
        )

    table = fit_force_per_share(chi2, f0)
    row["share_table"] = {f"{b:.1f}": [round(x, 1), round(v, 1)] for b, (x, v) in table.items()}
    row["ln_n"] = math.log(max(cal.n_total, 2))
    row["chosen_share"] = choose_share(table, row["ln_n"])
    cal.runner.direct_path_anti_alias = True
    d = cal._full_features(cal._raw((*others, dataclasses.replace(unit, shaft_path_share=0.0))))
    row["direct_fir"] = envelope_fit(cal, f_prev, d.combo(f_prev, -1.0), f0)[0]
    if mimic:
        # the library's defect with the generator's pulse train (0.4 mm spall, 1 % slip) through the
        # anti-aliasing decimation, share 0: what is left is the transfer and the slip realisation
        like = dataclasses.replace(
            unit, shaft_path_share=0.0, spall_width_m=lbear.SPALL_WIDTH, slip=lbear.SLIP
        )
        d = cal._full_features(cal._raw((*others, like))).combo(f_prev, -1.0)
        row["mimic"], row["mimic_chi2"] = envelope_fit(cal, f_prev, d, f0)
    cal.runner.direct_path_anti_alias = False
    if mimic:
        # one difference of the pulse train at a time, share 0, the default direct path
        for label, kw in (
            ("direct", {}),
            ("slip", {"slip": lbear.SLIP}),
            ("spall", {"spall_width_m": lbear.SPALL_WIDTH}),
        ):
            like = dataclasses.replace(unit, shaft_path_share=0.0, **kw)
            d = cal._full_features(cal._raw((*others, like))).combo(f_prev, -1.0)
            row[f"{label}_only"] = envelope_fit(cal, f_prev, d, f0)
    return row


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="+", required=True, help="substrings of the record tags")
    ap.add_argument("--out", default="out/bearing_bias")
    ap.add_argument("--table", action="store_true", help="the 28-row table's records (default: held-out)")
    ap.add_argument("--baseline", default=None, help="reference JSON (as --baseline of the CLI)")
    ap.add_argument(
        "--mimic", action="store_true", help="also the library defect with the generator's pulse train"
    )
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    ci.SAMPLING = "daq"
    for case in _cases(args.table):
        if not any(s in case.tag for s in args.cases):
            continue
        row = diagnose(case, out, Path(args.baseline) if args.baseline else None, args.mimic)
        if "truth" in row:
            tr, lt = row["truth"], row["library_terms"]
            rel = {
                k: row[k] / tr - 1.0 for k in ("cli_force", "oracle", "direct", "direct_fir", "share", "full")
            }
            print(
                f"{row['record']}: truth {tr:g} N (library terms {lt:.4g} N); CLI {row['cli_force']:.4g} N "
                f"share {row['cli_share']:.2g}; envelope fits / truth - 1: "
                + ", ".join(f"{k} {v:+.1%}" for k, v in rel.items())
                + f"; bands {row['bands']}; cpu {row['cpu_s']:.0f} s\n  share: (force N, envelope chi^2) "
                + f"{row['share_table']}; ln N {row['ln_n']:.3g}; chosen {row['chosen_share']}; oracle chi^2 "
                + f"{row['oracle_chi2']:.4g}; mimic chi^2 {row.get('mimic_chi2', math.nan):.4g}",
                flush=True,
            )
        else:
            print(f"{row['record']}: no bearing defect found ({row.get('first')})", flush=True)
        (out / f"{row['record']}.bias.json").write_text(json.dumps(row, indent=1, default=str))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
