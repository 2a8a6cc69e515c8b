"""An eccentric wheel in the two models: clean responses at the wheel's shaft order 1, channel by channel.

Runs the independent generator (``lumped_gearbox``, clean channels, no noise, no gains) and the FE
model (the calibration's own model run, ``calibration.residual.ModelRunner``) at the same operating
point, once healthy and once with the eccentricity, and prints the complex amplitude of the
difference at order 1 of the eccentric wheel's shaft for each of the six channels the records hold
(docs/history/calibration_sessions.md Sec. 8.33). Amplitudes are per channel (m, N, m/s^2); the phase is
referred to the shaft angle (both models start at shaft angle 0 at time 0).

    python benchmarks/eccentricity_order1.py                       # pinion 15 um, gear 20 um at 3000 rpm
    python benchmarks/eccentricity_order1.py --speed-rpm 4500 --temperature-c 75
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from lumped_gearbox.faults import parse_fault
from lumped_gearbox.params import Gearbox
from lumped_gearbox.simulate import CHANNELS, build, run

RATE = 20000.0
Z_PINION, Z_GEAR = 29, 49


def order1(x: np.ndarray, t: np.ndarray, shaft_hz: float, revolutions: int) -> complex:
    """Complex amplitude at ``shaft_hz`` over the last whole ``revolutions`` of ``x`` (peak, phase of
    ``A cos(2 pi f t + phi)``)."""
    n = round(revolutions * RATE / shaft_hz)
    xs, ts = x[-n:], t[-n:]
    return complex(2.0 / n * np.sum((xs - xs.mean()) * np.exp(-2j * math.pi * shaft_hz * ts)))


def lumped_response(fault: str, speed: float, temp: float, duration: float) -> tuple[np.ndarray, dict]:
    gb = Gearbox()
    healthy = run(build(gb, speed, temp, []), duration, RATE)
    faulty = run(build(gb, speed, temp, [parse_fault(fault)]), duration, RATE)
    return healthy["time_s"], {c: faulty[c] - healthy[c] for c in CHANNELS}


def fe_response(effect: object, speed: float, temp: float, duration: float) -> tuple[np.ndarray, dict]:
    from gear_rotor_sim.calibration.measurement import OperatingPoint
    from gear_rotor_sim.calibration.residual import ModelRunner
    from gear_rotor_sim.config import load_config

    n = round(duration * RATE)
    runner = ModelRunner(
        load_config("paper_sun2021"), OperatingPoint(speed, temp), RATE, n, 0.3, list(CHANNELS)
    )
    healthy = runner.signals(())
    faulty = runner.signals((effect,))
    t = runner.start_time + np.arange(n) / RATE
    return t, {c: faulty[:, k] - healthy[:, k] for k, c in enumerate(CHANNELS)}


def compare(member: str, e: float, phase: float, speed: float, temp: float, duration: float) -> dict:
    """``channel -> (lumped, FE)`` complex amplitudes at order 1 of the eccentric wheel's shaft, over
    the last half of ``duration`` in whole revolutions; ``_shaft_hz`` and ``_revolutions`` too."""
    from gear_rotor_sim.faults.gear import GearEccentricity

    fs = speed / 60.0 * (1.0 if member == "pinion" else Z_PINION / Z_GEAR)
    tl, lum = lumped_response(
        f"{member}_eccentricity:eccentricity_m={e},phase_rad={phase}", speed, temp, duration
    )
    tf, fe = fe_response(GearEccentricity(member, e, phase), speed, temp, duration)
    revs = int(0.5 * duration * fs)
    out: dict = {c: (order1(lum[c], tl, fs, revs), order1(fe[c], tf, fs, revs)) for c in CHANNELS}
    out["_shaft_hz"], out["_revolutions"] = fs, revs
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--speed-rpm", type=float, default=3000.0)
    ap.add_argument("--temperature-c", type=float, default=25.0)
    ap.add_argument("--duration-s", type=float, default=1.0)
    args = ap.parse_args(argv)
    speed, temp = args.speed_rpm, args.temperature_c
    for member, e, phase in (("pinion", 15e-6, 0.5), ("gear", 20e-6, -1.0)):
        t0 = time.process_time()
        res = compare(member, e, phase, speed, temp, args.duration_s)
        print(
            f"\n{member} eccentricity {e * 1e6:g} um, phase {phase} rad, {speed:g} rpm, {temp:g} C: "
            f"order 1 of the {member} shaft ({res['_shaft_hz']:.2f} Hz), last {res['_revolutions']} "
            f"revolutions (CPU {time.process_time() - t0:.0f} s)"
        )
        print(
            f"{'channel':12s} {'lumped |A|':>12s} {'arg':>7s} {'FE |A|':>12s} {'arg':>7s} {'FE/lumped':>9s}"
        )
        for c in CHANNELS:
            a, b = res[c]
            ratio = abs(b) / abs(a) if abs(a) > 0 else float("nan")
            print(
                f"{c:12s} {abs(a):12.4g} {math.degrees(np.angle(a)):7.1f} {abs(b):12.4g} "
                f"{math.degrees(np.angle(b)):7.1f} {ratio:9.3f}"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
