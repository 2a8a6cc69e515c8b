"""What the features say about tooth wear on a record where the teeth stay in contact (Sec. 8.32).

The record is scored as the calibration scores a candidate: the healthy FE model with the given
baseline sets held (``--bearing S_K,S_C``, ``--mesh S_K,S_C``: the sets the calibration found on the
record), sensor gains fitted, transfer slopes fitted on that healthy model and held. Then tooth wear at
each depth of ``--depths-um`` (full runs; the carriers' tolerance from the held sets' fit, as after a
baseline update in the rounds): the main error, chi^2 / N per family, the static chi^2 and
the DTE mean's residual in sigma (``candidates_wear_reference.dte_mean_residual``: at unit gain, the
static feature's variance), and the depth the DTE mean alone reads (its slope from two runs). It shows
which features prefer which depth: the channel means (wear's model-robust signature in contact,
Sec. 8.8) or the dynamic families.

Usage::

    python benchmarks/contact_wear_trace.py RECORD.csv --bearing 0.471,1.029 --depths-um 0 6 12 18 24 32 40
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from gear_rotor_sim.calibration.candidates_wear_reference import dte_channel, dte_mean_residual
from gear_rotor_sim.calibration.fit import Calibrator
from gear_rotor_sim.calibration.measurement import load_measurement
from gear_rotor_sim.faults import BearingStiffnessDamping, MeshStiffnessDamping, ToothWear


def _pair(text: str | None) -> tuple[float, float] | None:
    if not text:
        return None
    a, b = (float(x) for x in text.split(","))
    return a, b


def held_calibrator(record: Path, bearing: str | None, mesh: str | None) -> tuple[Calibrator, object]:
    """The record's calibrator at the healthy model with the baseline sets ``bearing`` / ``mesh``
    (``"S_K,S_C"`` or None) held, its transfer slopes fitted on that model and held, and the carriers'
    tolerance after a baseline update (no set held: the settings' tolerance, the nominal model's as in
    round 0); returns it and that model's features."""
    cal = Calibrator(load_measurement(record))
    cal._feat_correction = None
    cal._setup()
    held = []
    if (p := _pair(mesh)) is not None:
        held.append(MeshStiffnessDamping(stiffness_scale=p[0], damping_scale=p[1]))
    if (p := _pair(bearing)) is not None:
        held.append(BearingStiffnessDamping(stiffness_scale=p[0], damping_scale=p[1]))
    cal.baseline = held
    cal.base_raw = cal._raw(())
    base = cal._features(cal.base_raw)
    cal._refit_transfer(base)
    if held:
        # the carriers' model-form tolerance after a baseline update, as in the calibration's rounds
        cal.cmp.set_carrier_tolerance(cal._carrier_floor(base, cal.cmp.score(base)))
    return cal, base


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("record", type=Path)
    ap.add_argument("--bearing", default=None, help="bearing set held: stiffness,damping scales")
    ap.add_argument("--mesh", default=None, help="mesh set held: stiffness,damping scales")
    ap.add_argument("--depths-um", type=float, nargs="+", default=[0.0, 6.0, 12.0, 18.0, 24.0, 32.0, 40.0])
    args = ap.parse_args(argv)
    cal, base = held_calibrator(args.record, args.bearing, args.mesh)
    tol = getattr(cal.cmp, "carrier_tolerance", cal.settings.tolerance)
    print(f"carrier tolerance {tol:.3g}", flush=True)
    c = dte_channel(list(cal.cmp.names), 1, 1)
    rows = []
    for h in args.depths_um:
        feats = base if h == 0 else cal._features(cal._raw((ToothWear(wear_depth_m=1e-6 * h),)))
        loss = float(cal.runner.last_contact_loss)
        sc = cal.cmp.score(feats)
        r, s = dte_mean_residual(cal, feats, c)
        rows.append((h, sc, r, s, float(feats.static[c])))
        fam = ", ".join(f"{f} {sc.chi2[f] / sc.n[f]:.3g}" for f in sc.chi2 if sc.n.get(f, 0) > 0)
        zs = ", ".join(f"{k} {v:.2g}" for k, v in sc.per_channel.get("static", {}).items())
        print(
            f"wear {h:4.0f} um: error {sc.error:.4g}, balanced chi2 {sc.balanced_chi2:.6g}; chi2/N {fam}; "
            f"static chi2 {sc.chi2.get('static', float('nan')):.3g} (|z| {zs}); DTE mean model "
            f"{1e6 * rows[-1][4]:.2f} um, record - model {1e6 * r:.2f} um = {r / s:.2f} sigma "
            f"(sigma {1e6 * s:.2f} um); FE contact loss {loss:.3g}; DTE gain {sc.gains[c]:.3g}",
            flush=True,
        )
    h0, _, r0, _, m0 = rows[0]
    if len(rows) > 1 and h0 == 0:
        h1, _, _, _, m1 = rows[1]
        slope = (m1 - m0) / (1e-6 * h1)
        print(
            f"DTE mean slope {slope:.3g} um/um (0 -> {h1:.0f} um); record {1e6 * (m0 + r0):.2f} um; "
            f"the mean alone reads {1e6 * r0 / slope:.3g} um",
            flush=True,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
