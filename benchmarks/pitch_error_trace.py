"""Where manufacturing pitch errors put their content in the calibration's features (issue 11, session 23;
docs/history/calibration_sessions.md Sec. 8.65).

Two figures, no calibration:

``--hunting-stats DIR [DIR ...]``
    For every saved record (``*.csv`` with its sidecar) the share of each bearing channel's
    non-synchronous power (every shaft's synchronous average removed, as the envelope family's input) that
    is periodic in the hunting period (``calibration/envelope_hunting.py``), and whether the envelope rule
    fires (largest share at least ``MIN_SHARE``). Run on the table's and the held-out set's records (the
    rule must fire on none) and on the pitch-error records.

``--window-stats DIR [DIR ...]``
    For every saved record whose ``.truth.json`` holds a damaged tooth, the tooth window's statistic
    (``calibration/features_tooth_window.py``): the share of the DTE's non-carrier average of the tooth's
    wheel (noise removed) outside the window round the tooth, the window placed where the nominal model puts
    the tooth (its depth-0.9 run minus the healthy one), and whether the rule fires. The DTE comb is read
    only where the teeth stay in contact; records above 6000 rpm are skipped.

``--ser``
    The sideband energy ratios ``SER_m`` of the pinion's synchronous average (``features_sidebands``, the
    tooth candidate's ratio depth reads them) on generator records at 3000 rpm: exact teeth, pitch errors of
    3 and 6 um, each healthy (seed 34) and with the table's damaged pinion tooth 7 at depth 0.4 (seed 11),
    and the same split into the teeth's own contributions: the residual of the pinion's average (mesh
    carriers removed) per tooth slot against the pinion's drawn flank positions.

Usage::

    python benchmarks/pitch_error_trace.py --hunting-stats DIR [DIR ...]
    python benchmarks/pitch_error_trace.py --window-stats DIR [DIR ...]
    python benchmarks/pitch_error_trace.py --ser
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np


def hunting_stats(dirs: list[Path]) -> str:
    """The envelope rule's statistic on saved records (module docstring)."""
    from gear_rotor_sim.calibration.envelope_hunting import MIN_SHARE, hunting_part, hunting_share
    from gear_rotor_sim.calibration.features_orders import remove_synchronous
    from gear_rotor_sim.calibration.measurement import load_measurement
    from gear_rotor_sim.calibration.model_window import hunting_period_s
    from gear_rotor_sim.config import load_config
    from gear_rotor_sim.system import shaft_speed_ratios

    lines, fired, worst = [], [], (0.0, "")
    for d in dirs:
        for csv in sorted(d.glob("*.csv")):
            try:
                m = load_measurement(csv)
            except (ValueError, OSError, KeyError) as exc:
                lines.append(f"{csv.name}: not read ({exc})")
                continue
            cfg = load_config(m.gearbox)
            rpm = m.operating_point.speed_rpm
            th = hunting_period_s(cfg, rpm)
            if th is None:
                continue
            shafts = [abs(float(r)) * rpm / 60.0 for r in shaft_speed_ratios(cfg)]
            shares = {}
            for c, name in enumerate(m.model_channels):
                if not name.startswith("bearing"):
                    continue
                x = remove_synchronous(m.data[:, c], m.sample_rate_hz, shafts)
                if np.any(x):
                    shares[name] = hunting_share(x, hunting_part(x, m.sample_rate_hz, 1.0 / th))
            top = max(shares.values(), default=0.0)
            tag = f"{d.name}/{csv.stem}"
            if top >= MIN_SHARE:
                fired.append(tag)
            else:
                worst = max(worst, (top, tag))
            lines.append(f"{tag}: " + ", ".join(f"{k} {v:.3g}" for k, v in shares.items()))
    lines.append(f"rule fires (share >= {MIN_SHARE:g}) on {len(fired)}: {', '.join(fired) or 'none'}")
    lines.append(f"largest share where it does not fire: {worst[0]:.3g} ({worst[1]})")
    return "\n".join(lines) + "\n"


def window_stats(dirs: list[Path]) -> str:
    """The tooth window's statistic on saved records with a damaged tooth (module docstring)."""
    import json

    from gear_rotor_sim.calibration.candidates_tooth import wheel_shaft
    from gear_rotor_sim.calibration.candidates_tooth_dte import dte_channel
    from gear_rotor_sim.calibration.features_tooth_window import named_tooth_window
    from gear_rotor_sim.calibration.fit import Calibrator
    from gear_rotor_sim.calibration.measurement import load_measurement
    from gear_rotor_sim.faults import ToothDamage

    lines = []
    for d in dirs:
        for csv in sorted(d.glob("*.csv")):
            truth = csv.with_suffix(".truth.json")
            faults = json.loads(truth.read_text())["faults"] if truth.exists() else []
            teeth = [f["parameters"] for f in faults if f["name"] == "tooth_damage"]
            if not teeth or json.loads(truth.read_text())["speed_rpm"] > 6000:
                continue
            cal = Calibrator(load_measurement(csv))
            cal._setup()
            e = ToothDamage(tooth=int(teeth[0]["tooth"]), depth=0.9, wheel=teeth[0]["wheel"])
            c, shaft = dte_channel(cal), wheel_shaft(cal, e)
            if c is None or shaft is None:
                continue
            f_shaft, z = shaft
            lead = f_shaft * (cal.runner.start_time - float(getattr(cal.m, "t0", 0.0)))
            run = [cal.runner.outputs(cal._raw(x))[:, c] for x in ((e,), ())]
            center, share = named_tooth_window(cal.m.data[:, c], *run, cal.m.sample_rate_hz, f_shaft, z, lead)
            lines.append(f"{d.name}/{csv.stem}: outside share {share:.3g}, fires {center is not None}")
    return "\n".join(lines) + "\n"


def ser_table() -> str:
    """Pinion sideband energy ratios and per-tooth residual levels with and without pitch errors."""
    from gear_rotor_sim.calibration.features_sidebands import sideband_energy_ratios
    from lumped_gearbox import CONTACT_RPM, make_record
    from lumped_gearbox.pitch import PitchErrors

    tooth = "tooth_damage:wheel=pinion,tooth=7,depth=0.4"
    z1, fs, f1 = 29, 20000.0, CONTACT_RPM / 60.0
    head = "| record | SER_1..3 dte | SER_1..3 bearing2_fy | DTE pinion residual per tooth slot, RMS: "
    lines = [head + "tooth 7 / others' median (um) |", "|---|---|---|---|"]
    for f_pt in (0.0, 3.0, 6.0):
        pe = PitchErrors(f_pt_um=f_pt, seed=7) if f_pt else None
        for faults, seed in (((), 34), ((tooth,), 11)):
            r = make_record(CONTACT_RPM, 25.0, list(faults), seed=seed, pitch_errors=pe)
            x = np.column_stack([r.data["dte"], r.data["bearing2_fy"]])
            ser, _ = sideband_energy_ratios(x, fs, f1, z1)
            slots = _slot_rms(r.data["dte"], fs, f1, z1)
            name = f"f_pt {f_pt:g} um, {'tooth 7 depth 0.4' if faults else 'healthy'}"
            cells = [" ".join(f"{v:.3g}" for v in row) for row in ser]
            lines.append(
                f"| {name} | {cells[0]} | {cells[1]} | {1e6 * slots[7]:.3g} / "
                f"{1e6 * float(np.median(np.delete(slots, 7))):.3g} |"
            )
    return "\n".join(lines) + "\n"


def _slot_rms(x: np.ndarray, fs: float, shaft_hz: float, teeth: int) -> np.ndarray:
    """RMS of a wheel's synchronous average without its mesh carriers, per tooth slot (the slot's
    angular interval of one mesh period, starting at the record's angle origin)."""
    from gear_rotor_sim.analysis.signals import resample_to_angle

    spr = 32 * teeth
    _, xa = resample_to_angle(x - x.mean(), fs, shaft_hz * 60.0, spr)
    n = (xa.size - 1) // spr
    c = np.fft.rfft(xa[: n * spr].reshape(n, spr).mean(axis=0))
    c[np.arange(c.size) % teeth == 0] = 0.0
    r = np.fft.irfft(c, spr)
    return np.sqrt(np.mean(r.reshape(teeth, -1) ** 2, axis=1))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--hunting-stats", nargs="+", metavar="DIR", help="the envelope rule's statistic")
    ap.add_argument("--window-stats", nargs="+", metavar="DIR", help="the tooth window's statistic")
    ap.add_argument("--ser", action="store_true", help="pinion sideband energy ratios with pitch errors")
    args = ap.parse_args(argv)
    if args.hunting_stats:
        print(hunting_stats([Path(d) for d in args.hunting_stats]))
    if args.window_stats:
        print(window_stats([Path(d) for d in args.window_stats]))
    if args.ser:
        print(ser_table())
    return 0


if __name__ == "__main__":
    sys.exit(main())
