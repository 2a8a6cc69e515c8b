"""A damaged tooth's record scored against the FE model at several depths (issue 11, history Sec. 8.63).

The record is scored as the calibration scores a candidate in the round after its baseline update: the
healthy FE model with the baseline sets the calibration found held (``--bearing S_K,S_C``, ``--mesh
S_K,S_C``), sensor gains fitted, transfer slopes fitted on that healthy model and held, the carriers'
tolerance from that model's fit. Then the named tooth at each depth of ``--depths`` (full runs): the
main error, chi^2 / N per family, the share of the excess it explains and its Delta BIC against the
healthy model (the parsimony rule of calibration.md Sec. 4: ``Delta BIC > 10`` and at least 25 % of
the excess), the FE model's contact-loss fraction, and where the order residual sits on the damaged
wheel's shaft: its low orders and the sidebands of each mesh harmonic, per channel group, with the
model's sideband energy over the record's at the DTE (``> 1``: the model's signature exceeds the
record's there).

``--share-law pairs`` replaces the library's step share of the damaged tooth (1/2 in double contact, 1
in single, ``faults.gear.tooth_share``) by the FE mesh's own pair share ``k_t,i / sum k_t`` of Eq 14
(``MeshStiffnessTable.load_share``) for the run: a what-if of the damage law, not the library's.

Usage::

    python benchmarks/tooth_depth_trace.py RECORD.csv --wheel pinion --tooth 3 --bearing 0.4405,0.790 \
        --depths 0 0.4 0.5 0.612 0.64
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from gear_rotor_sim.calibration.fit import Calibrator
from gear_rotor_sim.calibration.residual_trace import _order_features
from gear_rotor_sim.calibration.tooth_band_shape import fit_band_shape
from gear_rotor_sim.faults import ToothDamage
from gear_rotor_sim.faults import gear as gear_faults
from gear_rotor_sim.gears import paper_gear_pair
from gear_rotor_sim.materials import carbon_steel

sys.path.insert(0, str(Path(__file__).resolve().parent))

from contact_wear_trace import held_calibrator  # the sibling script's set-up


def pair_share_law(table) -> callable:
    """A ``tooth_share`` that reads the damaged tooth's share from the FE pair stiffnesses (Eq 14).

    At mesh phase ``p`` of the table the pair that entered last has the smallest contact position; a
    tooth ``s`` cycles after it entered (``0 <= s < eps``) is that pair at ``p = s`` (``s < 1``) or the
    older pair at ``p = s - 1``.
    """
    pos = np.asarray(table.contact_position, dtype=float)
    share = np.asarray(table.load_share, dtype=float)
    big = np.where(np.isfinite(pos), pos, np.inf)
    small = np.where(np.isfinite(pos), pos, -np.inf)
    rows = np.arange(pos.shape[0])
    newest = share[rows, np.argmin(big, axis=1)]
    n_pairs = np.isfinite(pos).sum(axis=1)
    oldest = np.where(n_pairs > 1, share[rows, np.argmax(small, axis=1)], 0.0)
    n = pos.shape[0]

    def law(u: np.ndarray, tooth0: int, teeth: int, contact_ratio: float) -> np.ndarray:
        eps = float(np.clip(contact_ratio, 1.0, 2.0))
        s = np.mod(u - tooth0, teeth)
        out = np.zeros_like(s)
        first = s < 1.0
        second = (s >= 1.0) & (s < eps)
        out[first] = newest[np.minimum((s[first] * n).astype(int), n - 1)]
        out[second] = oldest[np.minimum(((s[second] - 1.0) * n).astype(int), n - 1)]
        return out

    return law


def order_breakdown(cal: Calibrator, feats, sc, shaft: str) -> dict[tuple[str, str], float]:
    """Sum of the order features' normalised residual ``r^2`` on ``shaft``, by channel group and band
    (``low``: orders 1-6; ``mzK``: the sidebands of mesh harmonic K), and the DTE's sideband energies."""
    out: dict[tuple[str, str], float] = {}
    for ft in _order_features(cal.cmp, feats, sc, 1.0):
        if ft.shaft != shaft or ft.family == "mesh harmonics":
            continue
        grp = "dte" if ft.channel.startswith("dte") else ("bearing" if "bearing" in ft.channel else "accel")
        if ft.family == "shaft orders":
            band = "low"
        else:
            m = ft.where.split("mesh x")[1].split()[0]
            band = f"mz{m}"
        out[(grp, band)] = out.get((grp, band), 0.0) + ft.r2
        if grp == "dte" and ft.family == "mesh sidebands":
            out[("dte_rec", band)] = out.get(("dte_rec", band), 0.0) + ft.measured**2
            out[("dte_mod", band)] = out.get(("dte_mod", band), 0.0) + ft.model**2
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("record", type=Path)
    ap.add_argument("--wheel", choices=("pinion", "gear"), required=True)
    ap.add_argument("--tooth", type=int, required=True)
    ap.add_argument("--bearing", default=None, help="bearing set held: stiffness,damping scales")
    ap.add_argument("--mesh", default=None, help="mesh set held: stiffness,damping scales")
    ap.add_argument("--depths", type=float, nargs="+", default=[0.0, 0.2, 0.4, 0.6])
    ap.add_argument("--share-law", choices=("library", "pairs"), default="library")
    ap.add_argument(
        "--band-shape", action="store_true", help="also score with the higher bands' shape factors fitted"
    )
    args = ap.parse_args(argv)
    cal, base = held_calibrator(args.record, args.bearing, args.mesh)
    if args.share_law == "pairs":
        temperature = float(cal.m.operating_point.temperature_c)
        table = paper_gear_pair(carbon_steel()).mesh_stiffness_table(temperature)
        gear_faults.tooth_share = pair_share_law(table)
        print(f"share law: FE pair shares of Eq 14 (contact ratio {table.contact_ratio:.4f})", flush=True)
    h = cal.cmp.score(base)
    n = h.n_total
    shaft = cal.cmp.shafts[0 if args.wheel == "pinion" else 1]
    mesh = cal.runner.cfg.meshes[0]
    teeth = int(mesh.pinion_teeth if args.wheel == "pinion" else mesh.gear_teeth)
    print(f"healthy: error {h.error:.4g}, balanced chi2 {h.balanced_chi2:.6g}, N {n}", flush=True)
    bands = ["low", "mz1", "mz2", "mz3"]
    for d in args.depths:
        if d == 0:
            feats, loss = base, float("nan")
        else:
            raw = cal._raw((ToothDamage(tooth=args.tooth, depth=d, wheel=args.wheel),))
            loss = float(cal.runner.last_contact_loss)
            feats = cal._features(raw)
        sc = cal.cmp.score(feats)
        gain = h.balanced_chi2 - sc.balanced_chi2
        dbic = gain - 2 * math.log(n)
        expl = gain / max(h.balanced_chi2 - n, 1e-12)
        fam = ", ".join(f"{f} {sc.chi2[f] / sc.n[f]:.3g}" for f in sc.chi2 if sc.n.get(f, 0) > 0)
        per = ", ".join(f"{c} {v:.3g}" for c, v in sc.per_channel.get("order", {}).items())
        print(
            f"depth {d:.3f}: error {sc.error:.4g} (ratio {sc.error / h.error:.3f}); dBIC {dbic:.4g}, "
            f"{expl:.3f} of the excess; chi2/N {fam}; order per channel {per}; FE contact loss {loss:.3g}",
            flush=True,
        )
        if args.band_shape and d > 0:
            fitted = fit_band_shape(cal.cmp, base, feats, cal.cmp.shafts.index(shaft), teeth)
            if fitted is not None:
                feats, bs = fitted
                sc = cal.cmp.score(feats)
                gain = h.balanced_chi2 - sc.balanced_chi2
                print(
                    f"    band shape: harmonics {bs.harmonics} factors "
                    + ", ".join(f"{v:.3f}" for v in bs.factors)
                    + f": error {sc.error:.4g} (ratio {sc.error / h.error:.3f}), "
                    f"{gain / max(h.balanced_chi2 - n, 1e-12):.3f} of the excess",
                    flush=True,
                )
        br = order_breakdown(cal, feats, sc, shaft.name)
        for grp in ("dte", "bearing", "accel"):
            print(
                f"    {shaft.name} r2 {grp:7s} "
                + ", ".join(f"{b} {br.get((grp, b), 0.0):.4g}" for b in bands),
                flush=True,
            )
        ratios = []
        for b in bands[1:]:
            rec, mod = br.get(("dte_rec", b), 0.0), br.get(("dte_mod", b), 0.0)
            ratios.append(f"{b} {math.sqrt(mod / rec):.3g}" if rec > 0 else f"{b} -")
        print("    DTE sideband amplitude model / record " + ", ".join(ratios), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
