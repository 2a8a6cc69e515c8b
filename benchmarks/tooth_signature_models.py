"""A damaged tooth's signature in the two models, band by band (docs/history/calibration_sessions.md
Sec. 8.35).

The signature is the change of the damaged wheel's synchronous-average coefficients (every channel,
orders 1-6 and the sidebands ``m z +- 6`` of the mesh harmonics ``m = 1..3``) that one tooth of depth
0.4 makes: damaged minus healthy. It is taken from noise-free, gain-free ``lumped_gearbox`` records
(the independent generator, the truth the calibration is judged on) and from the FE model through
the calibration's own :class:`~gear_rotor_sim.calibration.residual.ModelRunner` at the same
operating point, the latter at the mesh stiffness scales given (the baseline set a fit can take).

Printed per channel and band: ``sqrt(sum |lumped|^2 / sum |FE|^2)`` (1: the FE model holds the
record's signature there), and for the DTE the tooth each band points to: the record's signature
against the FE signature shifted by whole teeth, with one least-squares complex gain per band
(relative residual at the best shift and at the next one).

Usage::

    python benchmarks/tooth_signature_models.py --speed-rpm 4500 --temperature-c 75 --wheel pinion \
        --tooth 7 --scales 1,1.342,1.512 [--damping 1.0] [--out DIR]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from gear_rotor_sim.calibration.fit import Calibrator
from gear_rotor_sim.calibration.measurement import load_measurement
from gear_rotor_sim.calibration.residual import order_coefficients
from gear_rotor_sim.faults import MeshStiffnessDamping, ToothDamage
from lumped_gearbox import make_record, write_record

TEETH = {"pinion": 29, "gear": 49}


def bands(orders: np.ndarray, z: int) -> dict[str, np.ndarray]:
    """Order bands: the low orders 1-6; per mesh harmonic its lower sidebands, carrier, upper sidebands."""
    out = {"low 1-6": orders <= 6}
    for h in (1, 2, 3):
        out[f"m{h}-"] = (orders >= h * z - 6) & (orders < h * z)
        out[f"m{h}"] = orders == h * z
        out[f"m{h}+"] = (orders > h * z) & (orders <= h * z + 6)
    return out


def tooth_shift(rec: np.ndarray, fe: np.ndarray, orders: np.ndarray, z: int) -> list[tuple[float, int]]:
    """Relative residual of ``rec`` against ``g * fe`` shifted by whole teeth (-3..3), ``g`` complex LS."""
    out = []
    for sh in range(-3, 4):
        m = fe * np.exp(-2j * np.pi * orders * sh / z)
        g = np.vdot(m, rec) / max(float(np.vdot(m, m).real), 1e-300)
        out.append((float(np.sum(np.abs(rec - g * m) ** 2) / np.sum(np.abs(rec) ** 2)), sh))
    return sorted(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--speed-rpm", type=float, default=4500.0)
    ap.add_argument("--temperature-c", type=float, default=75.0)
    ap.add_argument("--wheel", choices=sorted(TEETH), default="pinion")
    ap.add_argument("--tooth", type=int, default=7)
    ap.add_argument("--depth", type=float, default=0.4)
    ap.add_argument("--scales", default="1,1.342", help="FE mesh stiffness scales, comma-separated")
    ap.add_argument("--damping", type=float, default=1.0, help="FE mesh damping scale with them")
    ap.add_argument("--out", default="out/tooth_signature")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t_cpu = time.process_time()
    fault = f"tooth_damage:wheel={args.wheel},tooth={args.tooth},depth={args.depth}"
    rec = {}
    for name, faults in (("healthy", []), ("damaged", [fault])):
        p = out / f"{args.speed_rpm:.0f}rpm_{args.temperature_c:.0f}C_{name}_{args.wheel}{args.tooth}.csv"
        r = make_record(
            args.speed_rpm, args.temperature_c, faults, duration_s=2.0, noise=(0.0, 0.0), gain_error=0.0
        )
        rec[name] = load_measurement(str(write_record(p, r)))
    m = rec["damaged"]
    z = TEETH[args.wheel]
    f_shaft = args.speed_rpm / 60.0 * (1.0 if args.wheel == "pinion" else TEETH["pinion"] / TEETH["gear"])
    orders = np.arange(1, 3 * z + 7)
    names = list(m.model_channels)

    def coefs(x: np.ndarray, t0: float) -> np.ndarray:
        return order_coefficients(x, m.sample_rate_hz, f_shaft, orders, (f_shaft * t0) % 1.0)[0]

    dmg, hea = rec["damaged"], rec["healthy"]
    lum = np.array([coefs(dmg.data[:, c], dmg.t0) - coefs(hea.data[:, c], hea.t0) for c in range(len(names))])
    runner = Calibrator(m, steps_per_mesh=64).runner
    t0 = runner.start_time
    sel = bands(orders, z)
    c_dte = names.index("dte") if "dte" in names else None
    print(
        f"{args.speed_rpm:.0f} rpm, {args.temperature_c:.0f} C, {fault}; mesh frequency "
        f"{args.speed_rpm / 60.0 * TEETH['pinion']:.0f} Hz; FE at 64 steps per mesh period"
    )
    for s in (float(v) for v in args.scales.split(",")):
        pre = (MeshStiffnessDamping(stiffness_scale=s, damping_scale=args.damping),)
        xh = runner.outputs(runner.force_signals(pre))
        xd = runner.outputs(
            runner.force_signals((*pre, ToothDamage(tooth=args.tooth, depth=args.depth, wheel=args.wheel)))
        )
        fe = np.array([coefs(xd[:, c], t0) - coefs(xh[:, c], t0) for c in range(len(names))])
        print(f"\nFE mesh x{s:g}, damping x{args.damping:g}: sqrt(energy lumped / energy FE) per band")
        print("channel".ljust(12) + " ".join(b.rjust(8) for b in sel))
        for c, n in enumerate(names):
            row = []
            for b in sel.values():
                ef = float(np.sum(np.abs(fe[c][b]) ** 2))
                row.append(f"{np.sqrt(np.sum(np.abs(lum[c][b]) ** 2) / ef):8.2f}" if ef > 0 else "       -")
            print(n.ljust(12) + " ".join(row))
        if c_dte is not None:
            parts = []
            near = [(f"m{h} +-6", np.abs(orders - h * z) <= 6) for h in (1, 2, 3)]
            for label, b in (("low 1-6", sel["low 1-6"]), *near):
                r = tooth_shift(lum[c_dte][b], fe[c_dte][b], orders[b], z)
                parts.append(f"{label}: shift {r[0][1]:+d} ({r[0][0]:.2f}; next {r[1][1]:+d} {r[1][0]:.2f})")
            print("DTE, tooth shift of the record against the FE signature: " + "; ".join(parts))
        np.savez(out / f"signature_x{s:g}.npz", orders=orders, names=names, lumped=lum, fe=fe)
    print(f"\nCPU {time.process_time() - t_cpu:.1f} s")


if __name__ == "__main__":
    main()
