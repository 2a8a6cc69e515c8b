"""Where the healthy model's chi^2 sits on one record (the rattle point's model-form floor).

Runs the start of ``Calibrator.run`` (healthy nominal model, rattle rules, held transfer) on a record
and breaks the main metric down: per family, per channel, per shaft and order group (low orders,
mesh carriers, sideband families ``m z +- j``), with the part of each group's uncertainty that is
noise, ensemble (model-form) variance and tolerance. It also checks the order noise model: the
variance of a synchronous-average coefficient is estimated by the scatter between single revolutions
divided by their number, which assumes that consecutive revolutions are independent; the batch-means
estimate (the scatter of averages over blocks of ``--block`` revolutions, the other shafts' synchronous
parts removed first) does not. Their ratio per order group is printed (1: the revolutions are
independent; above 1: the record's revolution-to-revolution variation is correlated over several
revolutions and the scatter estimate is too small).

Usage::

    python -m lumped_gearbox record --speed-rpm 8000 --temperature-c 25 --seed 35 --out out/h8000.csv
    python benchmarks/rattle_floor.py out/h8000.csv [--block 8] [--top 12] [--flat-envelope]
    python benchmarks/rattle_floor.py RECORD.csv --calibrate [--baseline REF.json] [--flat-envelope]
        [--orders 1 2 48 50]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from gear_rotor_sim.calibration.comb_families import sideband_family
from gear_rotor_sim.calibration.features_orders import remove_synchronous
from gear_rotor_sim.calibration.features_rattle import apply_rattle_uncertainty
from gear_rotor_sim.calibration.fit import Calibrator
from gear_rotor_sim.calibration.measurement import load_measurement
from gear_rotor_sim.calibration.residual import ResidualSettings, order_coefficients


def group_of(orders: np.ndarray, teeth: int) -> list[str]:
    """Label of each order: ``low j`` (j <= 6), ``carrier m``, ``family j``."""
    fam = sideband_family(orders, teeth) if teeth else orders
    out = []
    for o, j in zip(orders, fam, strict=True):
        if teeth and o % teeth == 0:
            out.append(f"carrier {o // teeth}")
        elif not teeth or o < teeth - 6:
            out.append(f"low {o}")
        else:
            out.append(f"family {j}")
    return out


def batch_ratio(y: np.ndarray, fs: float, shafts_hz: list[float], s: int, orders: np.ndarray, block: int):
    """Batch-means variance / scatter variance of the synchronous-average coefficients of shaft ``s``."""
    others = [f for k, f in enumerate(shafts_hz) if k != s]
    x = remove_synchronous(y, fs, others) if others else y - y.mean()
    f = shafts_hz[s]
    _, var, n_rev = order_coefficients(x, fs, f, orders, 0.0)
    n_blk = n_rev // block
    if n_blk < 4:
        return np.full(orders.size, np.nan), var
    spb = round(block * fs / f)
    means = []
    for b in range(n_blk):
        i0 = round(b * block * fs / f)
        seg = x[i0 : i0 + spb + 2]
        c, _, _ = order_coefficients(seg, fs, f, orders, b * block)
        means.append(c)
    means = np.array(means)
    # variance of the full-record mean from the block means (block phase referenced to the record start)
    vb = np.sum(np.abs(means - means.mean(axis=0)) ** 2, axis=0) / (n_blk - 1) / n_blk
    return vb / var, var


def after_fit(
    record: Path, baseline: str | None, settings: ResidualSettings, orders: tuple[int, ...] = (1, 2)
) -> int:
    """Run ``Calibrator.run`` and print the residual before and after per family, channel and shaft, and
    every channel's ``orders`` of the output shaft (default 1-2: a misalignment's axial line and 2x
    order; 48 and 50 are the paper gear's first mesh sidebands +-1)."""
    from gear_rotor_sim.calibration.baseline import load_reference

    m = load_measurement(record)
    cal = Calibrator(
        m, settings=settings, **(load_reference(baseline).calibrator_kwargs() if baseline else {})
    )
    res = cal.run()
    cmp = res.comparison
    print("effects:", [(e.label, e.parameters) for e in res.effects])
    print(
        "candidates of round 1:", [(r.get("label"), r.get("explained_fraction")) for r in res.rounds[0][:4]]
    )
    for lab, model, sc in (
        ("before", res.model_before, res.score_before),
        ("after", res.model_after, res.score_after),
    ):
        feats = cmp.apply_shift(cmp.features(model), sc.tau)
        corr = getattr(cal, "_feat_correction", None)
        if lab == "after" and corr is not None:  # the fitted path of an accepted mesh fault
            feats = feats.combo(cmp.apply_shift(corr, sc.tau), 1.0)
        G = np.column_stack([sc.gains, sc.slopes])
        fams = {f: round(sc.chi2[f] / sc.n[f], 3) for f in sc.chi2}
        print(f"\n{lab}: error {sc.error:.3f}, chi2/N per family {fams}")
        per = {}
        for c in range(cmp.nc):
            for s, sh in enumerate(cmp.shafts):
                mg = cmp.order_gain(G, c, s) * feats.order[c][s]
                d = cmp.d_order[c][s]
                s2 = cmp.order_sigma2(c, s, mg)
                chi = np.where(np.isfinite(s2), 2 * np.abs(d - mg) ** 2 / s2, 0.0)
                per[f"{cmp.names[c]}/{sh.name}"] = round(float(chi.sum()))
                if sh.name != cmp.shafts[-1].name:
                    continue
                for o in orders:
                    if not np.any(sh.orders == o):
                        continue
                    k = int(np.flatnonzero(sh.orders == o)[0])
                    print(
                        f"  {cmp.names[c]:12s} {sh.name} order {o}: "
                        f"record {abs(d[k]):.3g} at {np.angle(d[k]):+.2f} rad,"
                        f" model {abs(mg[k]):.3g} at {np.angle(mg[k]):+.2f} rad, sigma {np.sqrt(s2[k]):.2g},"
                        f" chi2 {chi[k]:.3g}"
                    )
        print("  order chi2 per channel/shaft:", per)
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("record", help="CSV + YAML record")
    ap.add_argument("--block", type=int, default=8, help="revolutions per block of the batch-means check")
    ap.add_argument("--top", type=int, default=12, help="orders listed with the largest chi^2")
    ap.add_argument(
        "--calibrate",
        action="store_true",
        help="run the whole calibration instead and break down the residual before and after it",
    )
    ap.add_argument("--baseline", default=None, help="reference baseline JSON (with --calibrate)")
    ap.add_argument(
        "--corrected-envelope",
        action="store_true",
        help="the envelope's corrected noise model (the default since session 11; kept for old commands)",
    )
    ap.add_argument(
        "--flat-envelope",
        action="store_true",
        help="the old envelope noise model: flat floor, 3 independent bins per sum "
        "(ResidualSettings(envelope_noise_corrected=False))",
    )
    ap.add_argument(
        "--orders",
        type=int,
        nargs="+",
        default=[1, 2],
        help="output-shaft orders printed per channel with --calibrate (default 1 2)",
    )
    args = ap.parse_args(argv)
    if args.flat_envelope and args.corrected_envelope:
        ap.error("--flat-envelope and --corrected-envelope exclude each other")
    settings = ResidualSettings(envelope_noise_corrected=not args.flat_envelope)
    if args.calibrate:
        return after_fit(Path(args.record), args.baseline, settings, tuple(args.orders))
    m = load_measurement(Path(args.record))
    cal = Calibrator(m, settings=settings)
    cal._feat_correction = None
    cal._setup()
    nominal = cal._features(cal.base_raw)
    applied = apply_rattle_uncertainty(
        cal.cmp, nominal, lambda e: cal._features(cal._raw((e,))), cal.base_contact_loss, m.issues
    )
    cal._refit_transfer(nominal)
    cmp = cal.cmp
    sc = cmp.score(nominal)
    print(f"record {args.record}: contact loss {cal.base_contact_loss:.3f}, rattle rules {applied}")
    print(f"error {sc.error:.3f}; per family chi2/N:")
    for f in sc.chi2:
        print(f"  {f:9s} chi2 {sc.chi2[f]:10.4g}  N {sc.n[f]:6d}  chi2/N {sc.chi2[f] / sc.n[f]:.3g}")
    print(
        "static residuals (sigma):",
        {
            cmp.names[c]: round(float(v), 2)
            for c, v in zip(np.flatnonzero(cmp.static_mask), sc.static_r, strict=True)
        },
    )
    G = np.column_stack([sc.gains, sc.slopes])
    rows = []
    shafts_hz = [sh.ratio * cmp.speed_hz for sh in cmp.shafts]
    for c in range(cmp.nc):
        for s, sh in enumerate(cmp.shafts):
            mg = cmp.order_gain(G, c, s) * nominal.order[c][s]
            d = cmp.d_order[c][s]
            r2 = np.abs(d - mg) ** 2
            s2 = cmp.order_sigma2(c, s, mg)
            vn = cmp.v_order[c][s]
            vmf = cmp.v_model_form[c][s] if cmp.v_model_form is not None else np.zeros(vn.shape)
            groups = group_of(sh.orders, sh.teeth)
            for k, o in enumerate(sh.orders):
                if not np.isfinite(s2[k]):
                    continue
                rows.append(
                    (
                        cmp.names[c],
                        sh.name,
                        int(o),
                        groups[k],
                        2 * r2[k] / s2[k],
                        abs(d[k]),
                        abs(mg[k]),
                        vn[k],
                        vmf[k],
                        s2[k] - vn[k] - vmf[k],
                    )
                )
    chi_o = sum(r[4] for r in rows)
    print(
        f"\norder chi2 {chi_o:.4g} over {2 * len(rows)} real features; per channel (share of the order chi2):"
    )
    for name in cmp.names:
        sel = [r for r in rows if r[0] == name]
        print(
            f"  {name:12s} {sum(r[4] for r in sel):10.4g} ({100 * sum(r[4] for r in sel) / chi_o:5.1f} %)"
            f"  chi2/N {sum(r[4] for r in sel) / max(2 * len(sel), 1):.3g}"
        )
    print("per shaft and group (chi2, N, chi2/N, share):")
    keys = sorted({(r[1], r[3].split()[0]) for r in rows})
    for sh, g in keys:
        sel = [r for r in rows if r[1] == sh and r[3].split()[0] == g]
        x = sum(r[4] for r in sel)
        print(
            f"  {sh:8s} {g:8s} {x:10.4g} {2 * len(sel):5d} {x / (2 * len(sel)):7.3g} {100 * x / chi_o:5.1f} %"
        )
    print("per shaft and sideband family j (all channels):")
    for sh in cmp.shafts:
        fams = {}
        for r in rows:
            if r[1] != sh.name or r[3].startswith("carrier"):
                continue
            j = int(r[3].split()[1]) if r[3].startswith("family") else int(r[2])
            fams.setdefault(j, []).append(r[4])
        print(
            f"  {sh.name}: " + ", ".join(f"j={j}: {sum(v):.3g}/{2 * len(v)}" for j, v in sorted(fams.items()))
        )
    print(f"\ntop {args.top} orders by chi2 (|d|, |g m|, noise var, ensemble var, tolerance var):")
    for r in sorted(rows, key=lambda r: -r[4])[: args.top]:
        print(
            f"  {r[0]:12s} {r[1]:7s} order {r[2]:4d} {r[3]:10s} chi2 {r[4]:9.3g}"
            f"  |d| {r[5]:.3g}  |gm| {r[6]:.3g}"
            f"  vn {r[7]:.3g} vmf {r[8]:.3g} vtol {r[9]:.3g}"
        )
    # uncertainty composition of the order family: chi2 as if each part were absent
    print(
        "\norder noise model: batch means over blocks of",
        args.block,
        "revolutions / scatter (median per group)",
    )
    for c in range(cmp.nc):
        parts = []
        for s, sh in enumerate(cmp.shafts):
            ratio, _ = batch_ratio(m.data[:, c], cmp.fs, shafts_hz, s, sh.orders, args.block)
            groups = [g.split()[0] for g in group_of(sh.orders, sh.teeth)]
            for g in ("low", "carrier", "family"):
                sel = np.array([x == g for x in groups])
                if sel.any() and np.isfinite(ratio[sel]).any():
                    parts.append(f"{sh.name}/{g} {np.nanmedian(ratio[sel]):.2f}")
        print(f"  {cmp.names[c]:12s} " + ", ".join(parts))
    if "envelope" in sc.chi2:
        print("\nenvelope: per channel chi2/N and the bins with the largest (r/sigma)^2:")
        for c in range(cmp.nc):
            r2 = sc.envelope_r2[c] if c < len(sc.envelope_r2) else np.zeros(0)
            if not r2.size or not r2.any():
                continue
            order = np.argsort(r2)[::-1][:6]
            top_share = float(np.sort(r2)[::-1][: max(1, r2.size // 100)].sum() / r2.sum())
            print(
                f"  {cmp.names[c]:12s} chi2/N {r2.mean():.3g}  top 1 % of bins carry {100 * top_share:.0f} %;"
                f" median (r/s)^2 {np.median(r2):.3g}; largest at "
                + ", ".join(f"{cmp.env_f[i]:.0f} Hz ({r2[i]:.3g})" for i in order)
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
