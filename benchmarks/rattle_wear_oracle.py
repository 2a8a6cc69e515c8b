"""The oracle of a wear record: the calibration's own pipeline with tooth wear forced at a given depth.

What error can the right answer give on a worn record? ``Calibrator.run`` is run on the record with
the library's effects replaced by nothing and tooth wear at ``--depths-um`` forced in before the
rounds (where the screened effects of the calibration enter: ``Calibrator.pre_effects``), the
baseline handled as usual (without ``--baseline``: the baseline sets compete in the rounds and get
their round after the stop; with it: the reference's sets held). Depth 0 is the same pipeline
without the wear: the record's own floor against the library's baseline sets. Printed per depth:
``error_before`` (the nominal model, as the calibration reports it), ``error_after``, their ratio
(the acceptance needs at most 0.5), the chi^2 / N of each family, the baseline updates, and the
chi^2 / N per channel of the order family. A healthy record at the same operating point (``--floor``)
gives the floor the remainder is compared with (docs/history/calibration_sessions.md Sec. 8.26).

Usage::

    python benchmarks/calibration_independent.py --jobs 1 --cases rattle_tooth_wear healthy_8000 --out DIR
    python benchmarks/rattle_wear_oracle.py DIR/rattle_tooth_wear.csv --floor DIR/healthy_8000rpm_25C.csv
    python benchmarks/rattle_wear_oracle.py DIR/rattle_tooth_wear.csv --floor DIR/healthy_8000rpm_25C.csv \
        --baseline DIR/baseline_2000rpm_25C.reference.json
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from gear_rotor_sim.calibration.comb_families import comb_chi2_by_order, sideband_family
from gear_rotor_sim.calibration.fit import Calibrator, FoundEffect, _screen_gain, _screened
from gear_rotor_sim.calibration.measurement import load_measurement
from gear_rotor_sim.calibration.residual import Score
from gear_rotor_sim.faults import ToothWear


class ForcedWearCalibrator(Calibrator):
    """``Calibrator`` whose wear screen returns tooth wear at a fixed depth (0: none) and whose rounds
    offer the baseline sets only."""

    def __init__(self, *args: Any, depth_m: float = 0.0, **kw: Any) -> None:
        super().__init__(*args, candidates=[], **kw)
        self.depth_m = float(depth_m)

    def _wear_screen(self, score: Score) -> FoundEffect | None:
        if self.depth_m <= 0.0:
            return None
        eff = ToothWear(wear_depth_m=self.depth_m)
        sc = self.cmp.score(self._features(self._raw((eff,))))
        dbic, expl = _screen_gain(score, sc)
        return _screened(eff, score, sc, {"wear_depth_m": math.nan}, dbic, expl)


def family_errors(sc: Score) -> dict[str, float]:
    """chi^2 / N of each family with features."""
    return {f: sc.chi2[f] / sc.n[f] for f in sc.chi2 if sc.n.get(f, 0) > 0}


def order_by_channel(cal: Calibrator, sc: Score, feats: Any) -> dict[str, float]:
    """Order chi^2 / N per channel of the score ``sc`` for the model features ``feats``."""
    cmp = cal.cmp
    feats = cmp.apply_shift(feats, sc.tau)
    g = np.column_stack([sc.gains, sc.slopes])
    out = {}
    for c in range(cmp.nc):
        chi, n = 0.0, 0
        for s in range(len(cmp.shafts)):
            mg = cmp.order_gain(g, c, s) * feats.order[c][s]
            s2 = cmp.order_sigma2(c, s, mg)
            ok = np.isfinite(s2)
            chi += float(np.sum(2.0 * np.abs(cmp.d_order[c][s] - mg)[ok] ** 2 / s2[ok]))
            n += int(np.sum(ok)) * 2
        out[cmp.names[c]] = chi / max(n, 1)
    return out


def order_groups(cal: Calibrator, sc: Score, feats: Any) -> dict[str, tuple[float, int]]:
    """Order chi^2 and feature count per shaft and group (``low``: orders below the first sideband
    family, ``carrier``: the mesh orders, ``j<k>``: the sideband family ``m z +- k``), summed over
    channels; orders left out (a locked rattle family) count neither."""
    cmp = cal.cmp
    out: dict[str, tuple[float, int]] = {}
    for s, sh in enumerate(cmp.shafts):
        chi = comb_chi2_by_order(cmp, feats, sc, s)
        n = np.zeros(sh.orders.size, dtype=int)
        g = np.column_stack([sc.gains, sc.slopes])
        for c in range(cmp.nc):
            mg = cmp.order_gain(g, c, s) * cmp.apply_shift(feats, sc.tau).order[c][s]
            n += 2 * np.isfinite(cmp.order_sigma2(c, s, mg)).astype(int)
        if sh.teeth:
            fam = sideband_family(sh.orders, sh.teeth)
            lab = np.where(
                fam == 0, "carrier", np.where(sh.orders < sh.teeth - 6, "low", "j" + fam.astype(str))
            )
        else:
            lab = np.full(sh.orders.size, "low")
        for key in dict.fromkeys(lab):
            sel = lab == key
            out[f"{sh.name}/{key}"] = (float(np.nansum(chi[sel])), int(n[sel].sum()))
    return out


def comb_levels(cal: Calibrator, feats: Any) -> dict[str, tuple[float, float, float, float]]:
    """Per channel, the first toothed shaft's non-carrier comb ``sqrt(2 sum |c|^2)`` of the record and of
    the model (``feats``), in the channel's unit (the content a shaft-locked response puts away from the
    mesh carriers), and the record's and the model's coefficient magnitude at the first mesh order."""
    cmp = cal.cmp
    s = next((k for k, sh in enumerate(cmp.shafts) if sh.teeth), None)
    if s is None:
        return {}
    sh = cmp.shafts[s]
    comb = sideband_family(sh.orders, sh.teeth) > 0
    h1 = int(np.flatnonzero(sh.orders == sh.teeth)[0])
    out = {}
    for c in range(cmp.nc):
        d = cmp.d_order[c][s][comb]
        m = feats.order[c][s][comb]
        out[cmp.names[c]] = (
            float(np.sqrt(2.0 * np.sum(np.abs(d) ** 2))),
            float(np.sqrt(2.0 * np.sum(np.abs(m) ** 2))),
            float(abs(cmp.d_order[c][s][h1])),
            float(abs(feats.order[c][s][h1])),
        )
    return out


def run(record: Path, depth_m: float, kwargs: dict[str, Any]) -> dict[str, Any]:
    m = load_measurement(record)
    cal = ForcedWearCalibrator(m, depth_m=depth_m, **kwargs)
    t = time.process_time()
    res = cal.run()
    cpu = time.process_time() - t
    cmp = res.comparison
    feats_after = cmp.features(res.model_after)
    corr = getattr(cal, "_feat_correction", None)
    if corr is not None:
        feats_after = feats_after.combo(corr, 1.0)
    return {
        "record": record.name,
        "depth_um": 1e6 * depth_m,
        "error_before": res.score_before.error,
        "error_after": res.score_after.error,
        "ratio": res.score_after.error / res.score_before.error,
        "families_before": family_errors(res.score_before),
        "families_after": family_errors(res.score_after),
        "orders_after": order_by_channel(cal, res.score_after, feats_after),
        "groups_after": order_groups(cal, res.score_after, feats_after),
        "comb": comb_levels(cal, feats_after),
        "baseline": [
            f"{b.label} {b.parameters}" for b in res.baseline_updates if b.label != "sensor_transfer"
        ],
        "rounds": [
            [(r.get("label"), r.get("parameters"), r.get("explained_fraction"), r.get("error")) for r in rnd]
            for rnd in res.rounds
        ],
        "cpu_s": cpu,
    }


def show(r: dict[str, Any]) -> None:
    fb = ", ".join(f"{k} {v:.3g}" for k, v in r["families_before"].items())
    fa = ", ".join(f"{k} {v:.3g}" for k, v in r["families_after"].items())
    oc = ", ".join(f"{k} {v:.3g}" for k, v in r["orders_after"].items())
    cb = "input comb record / model after (first mesh order record / model): " + ", ".join(
        f"{k} {v[0]:.3g} / {v[1]:.3g} ({v[2]:.3g} / {v[3]:.3g})" for k, v in r["comb"].items()
    )
    gr = ", ".join(f"{k} {v[0]:.0f} ({v[1]})" for k, v in r["groups_after"].items())
    print(
        f"{r['record']} wear {r['depth_um']:.0f} um: error {r['error_before']:.3f} -> {r['error_after']:.3f} "
        f"(ratio {r['ratio']:.3f}); chi2/N before: {fb}; after: {fa}\n"
        f"    order chi2/N per channel after: {oc}\n"
        f"    order chi2 (N) per shaft and group after: {gr}\n"
        f"    {cb}\n"
        f"    baseline: {r['baseline'] or 'none'}; CPU {r['cpu_s']:.0f} s",
        flush=True,
    )
    for i, rnd in enumerate(r["rounds"]):
        print(f"    round {i + 1}: " + "; ".join(_candidate(*x) for x in rnd), flush=True)


def _candidate(label: str, params: Any, explained: Any, error: Any) -> str:
    ex = "-" if explained is None else f"{explained:.3g}"
    er = "-" if error is None else f"{error:.3g}"
    return f"{label} {params} explained {ex} error {er}"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("record", type=Path, help="the worn record (CSV + YAML)")
    ap.add_argument("--depths-um", type=float, nargs="+", default=[0.0, 15.0, 20.0, 25.0])
    ap.add_argument("--floor", type=Path, default=None, help="a healthy record at the same operating point")
    ap.add_argument("--baseline", default=None, help="reference baseline JSON (as calibrate --baseline)")
    args = ap.parse_args(argv)
    kwargs: dict[str, Any] = {}
    if args.baseline:
        from gear_rotor_sim.calibration.baseline import load_reference

        kwargs = load_reference(args.baseline).calibrator_kwargs()
    if args.floor is not None:
        show(run(args.floor, 0.0, kwargs))
    for d in args.depths_um:
        show(run(args.record, 1e-6 * d, kwargs))
    return 0


if __name__ == "__main__":
    sys.exit(main())
