"""The mesh mode apart from the static mesh compliance: the two models' gear inertias
(docs/history/calibration_sessions.md Sec. 8.41).

Three parts, each printed as a table:

``modes``
    The mesh mode of each model linearised at its mean mesh stiffness: the independent generator's
    (``lumped_gearbox``: 6 in-plane degrees of freedom, its own masses and springs) and the FE model's at
    pairs ``(s_k, s_m)`` of the mesh stiffness scale and the gear discs' inertia scale
    (``faults.mesh_inertia.GearInertia``): frequency, share of the strain energy in the mesh and the mode's
    effective mass ``k_mesh / (2 pi f)^2`` (what the mode reads of the inertia), with the two models'
    torsional equivalent masses ``m_e = 1 / (rb1^2 / J1 + rb2^2 / J2)`` from their parameters.
``scan RECORD.csv``
    The healthy model's score on a record at triples ``s_k:s_c:s_m`` (mesh stiffness, mesh damping, gear
    inertia), the transfer slopes re-fitted at each: per family, per channel, the channel means.
``calibrate RECORD.csv``
    The calibration of a record (no reference) with the ``mesh_inertia`` set fitted after the mesh set off
    and on, or with the mesh sets held from the start (``--held s_k:s_c:s_m``): baseline updates, the tooth
    named, its depth, the depth notes, the error before and after, CPU.

Usage::

    python benchmarks/mesh_inertia_diagnosis.py modes --temperature-c 75 --pairs 1:1,1.342:1,1.512:1,1.342:0.9
    python benchmarks/mesh_inertia_diagnosis.py scan out/heldout/4500rpm_75C_tooth_damage_gear5_x1.csv \
        --triples 1.913:0.74:1,1.342:0.74:0.69
    python benchmarks/mesh_inertia_diagnosis.py calibrate out/heldout/4500rpm_75C_tooth_damage_gear5_x1.csv
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np
import scipy.linalg as sla

from gear_rotor_sim.calibration.fit import Calibrator, CandidateFit, FoundEffect, _logistic
from gear_rotor_sim.calibration.residual import ModelFeatures, Score
from gear_rotor_sim.config import load_config
from gear_rotor_sim.faults import BearingStiffnessDamping, Effect, MeshStiffnessDamping
from gear_rotor_sim.faults.mesh_inertia import GearInertia, MeshInertia
from gear_rotor_sim.system import GearRotorSystem, gear_disc
from lumped_gearbox.params import Gearbox
from lumped_gearbox.simulate import build


def parse_pairs(text: str) -> list[tuple[float, float]]:
    """``"1.342:1,1.512:0.9"`` -> [(1.342, 1.0), (1.512, 0.9)] (mesh stiffness scale, inertia scale)."""
    out = []
    for p in text.split(","):
        a, _, b = p.partition(":")
        out.append((float(a), float(b or 1.0)))
    return out


def lumped_modes(temperature_c: float, min_fraction: float = 0.05) -> tuple[list[dict[str, float]], float]:
    """The generator's in-plane modes (x1, y1, theta1, x2, y2, q2) at its mean mesh stiffness, and its
    torsional equivalent mass ``m_e`` (kg). The mesh acts along ``v = (sin a, cos a, rb1, -sin a, -cos a,
    rb2)`` (``lumped_gearbox/model.py``)."""
    s = build(Gearbox(), 3000.0, temperature_c)
    m1, j1, m2, j2 = s.mass[:4]
    sa, ca, rb1, rb2 = s.geo[5], s.geo[6], s.geo[3], s.geo[4]
    kl1, kl2, kt1 = s.kk[0], s.kk[1], s.kk[4]
    v = np.array([sa, ca, rb1, -sa, -ca, rb2])
    k = np.diag([kl1, kl1, kt1, kl2, kl2, 0.0]) + s.mesh_mean * np.outer(v, v)
    m = np.diag([m1, m1, j1, m2, m2, j2])
    return _modes(k, m, v, s.mesh_mean, min_fraction), 1.0 / (rb1**2 / j1 + rb2**2 / j2)


def _modes(
    k: np.ndarray, m: np.ndarray, v: np.ndarray, k_mesh: float, min_fraction: float
) -> list[dict[str, float]]:
    w2, x = sla.eigh(k, m)
    share = k_mesh * (v @ x) ** 2 / np.abs(w2)
    out = []
    for a, b in zip(w2, share, strict=True):
        f = math.sqrt(abs(a)) / (2 * math.pi)
        if b >= min_fraction and f < 20000.0:
            out.append({"f_hz": f, "mesh_energy": float(b), "m_eff_kg": k_mesh / abs(a)})
    return out


def fe_modes(
    temperature_c: float, s_k: float, s_m: float, min_fraction: float = 0.05
) -> tuple[list[dict[str, float]], float]:
    """The FE model's modes with >= ``min_fraction`` of their strain energy in the mesh at the mean
    mesh stiffness times ``s_k`` and the gear discs' inertia times ``s_m``; and its ``m_e``."""
    cfg = GearInertia(inertia_scale=s_m).modify_config(load_config("paper_sun2021"))
    system = GearRotorSystem.from_config(cfg, temperature_c)
    mesh = system.meshes[0]
    f = system.free_dofs
    v = mesh.line_of_action[f]
    km = s_k * mesh.mean_stiffness
    k = system.K[np.ix_(f, f)] + km * np.outer(v, v)
    rows = _modes(k, system.M[np.ix_(f, f)], v, km, min_fraction)
    mc = cfg.meshes[0]
    jp, jg = (gear_disc(cfg, cfg.gear(n)).polar_inertia for n in (mc.pinion, mc.gear))
    c = math.cos(mc.pressure_angle_rad)
    rbp, rbg = 0.5 * mc.module_m * mc.pinion_teeth * c, 0.5 * mc.module_m * mc.gear_teeth * c
    return rows, 1.0 / (rbp**2 / jp + rbg**2 / jg)


def _mode_line(r: dict[str, float]) -> str:
    return f"  {r['f_hz']:7.0f} Hz, mesh energy {r['mesh_energy']:.2f}, effective mass {r['m_eff_kg']:.4f} kg"


def cmd_modes(args: argparse.Namespace) -> None:
    t = args.temperature_c
    rows, me = lumped_modes(t)
    print(f"{t:g} C. lumped_gearbox: torsional m_e {me:.4f} kg")
    for r in rows:
        print(_mode_line(r))
    s0 = build(Gearbox(), 3000.0, t)
    for sk, sm in parse_pairs(args.pairs):
        rows, me = fe_modes(t, sk, sm)
        km = sk * GearRotorSystem.from_config(load_config("paper_sun2021"), t).meshes[0].mean_stiffness
        print(
            f"FE mesh x{sk:g}, gear inertia x{sm:g}: torsional m_e {me:.4f} kg, mean mesh stiffness "
            f"{km / 1e6:.1f} MN/m (lumped {s0.mesh_mean / 1e6:.1f})"
        )
        for r in rows:
            print(_mode_line(r))


#: grid of the inertia scale (within MeshInertia's bounds 0.5-2; 1 is the current machine)
INERTIA_GRID: tuple[float, ...] = (0.6, 0.8, 1.25, 1.6)


def fit_mesh_inertia(
    cal: Calibrator, cur: ModelFeatures, score: Score, accepted: list[Effect]
) -> CandidateFit | None:
    """The ``mesh_inertia`` set on the machine whose mesh set was just updated (module docstring).

    Parameters
    ----------
    cal : Calibrator
        The calibration in progress; its baseline holds the mesh set.
    cur : ModelFeatures
        Features of the current model (baseline-updated, accepted effects).
    score : Score
        Its score.
    accepted : list of Effect
        Effects accepted so far (the full runs of the refinement carry them).

    Returns
    -------
    CandidateFit or None
        The verified fit when it passes the BIC rule, else None (a note says why).
    """
    if any(isinstance(b, MeshInertia) for b in cal.baseline):
        return None
    e = MeshInertia()
    if not e.applicable(cal.runner.cfg):
        return None
    spec = e.specs[0]
    fit = cal._fit_grid_scalar(e, spec.name, INERTIA_GRID, 1.0, cur, (spec.lower, spec.upper))
    if fit is None:
        return None
    n = score.n_total
    penalty = fit.k * math.log(n)
    dbic = score.balanced_chi2 - fit.score.balanced_chi2 - penalty
    if dbic <= cal.fit.bic_threshold:
        x = fit.effect.parameters()[spec.name]
        cal.notes.append(f"mesh_inertia: not taken (x{x:.3g} on the grid, dBIC {dbic:.4g})")
        return None
    ver = cal._refine(fit, accepted)
    dbic = score.balanced_chi2 - ver.score.balanced_chi2 - penalty
    if dbic <= cal.fit.bic_threshold:
        cal.notes.append(
            f"mesh_inertia: not taken after the full runs (x{ver.effect.parameters()[spec.name]:.3g}, "
            f"dBIC {dbic:.4g})"
        )
        return None
    ver.delta_bic = float(dbic)
    ver.explained = float(
        (score.balanced_chi2 - ver.score.balanced_chi2) / max(score.balanced_chi2 - n, 1e-12)
    )
    return ver


def take_mesh_inertia(
    cal: Calibrator, cur: ModelFeatures, accepted: list[Effect]
) -> tuple[FoundEffect, np.ndarray, ModelFeatures] | None:
    """Fit the ``mesh_inertia`` set (:func:`fit_mesh_inertia`) right after the mesh set was taken and, if
    it passes, update the machine with it as the caller does for any baseline set: the set joins
    ``cal.baseline``, the signatures are dropped, the transfer slopes and (without a reference's) the
    carrier tolerance re-fitted.

    Returns
    -------
    tuple or None
        ``(report entry, raw run, features)`` of the updated model, or None when the set is not taken.
    """
    score = cal.cmp.score(cur)
    ver = fit_mesh_inertia(cal, cur, score, accepted)
    if ver is None:
        return None
    entry = FoundEffect(
        ver.name,
        ver.effect.label,
        ver.effect.parameters(),
        ver.uncertainty,
        _logistic(ver.delta_bic / 2),
        float(ver.delta_bic),
        float(ver.explained),
        score.error,
        ver.score.error,
        ver.effect,
        "baseline",
    )
    cal.log(f"baseline {ver.effect.label} {ver.effect.parameters()}: error -> {ver.score.error:.3g}")
    cal._join_baseline(ver.effect)
    feats = cal._accept_features(ver)
    cal._refit_transfer(feats)
    cal._update_carrier_tolerance(feats)
    return entry, ver.raw, feats


def inertia_calibrator(on: bool):
    """A :class:`Calibrator` that fits the ``mesh_inertia`` set right after taking the mesh set (``on``);
    the diagnosis's stand-in for ``FitSettings.mesh_inertia`` (reported in the notes)."""
    from gear_rotor_sim.calibration.fit import Calibrator

    class InertiaCalibrator(Calibrator):
        def _accept_features(self, ver):
            feats = super()._accept_features(ver)
            if not (on and isinstance(ver.effect, MeshStiffnessDamping) and ver.effect in self.baseline):
                return feats
            self._refit_transfer(feats)
            self._update_carrier_tolerance(feats)
            got = take_mesh_inertia(self, feats, [])
            if got is None:
                return feats
            e = got[0]
            self.notes.append(
                f"mesh_inertia taken: {json.dumps(e.parameters)}, dBIC {e.delta_bic:.4g}, error "
                f"{e.error_before:.3g} -> {e.error_after:.3g}"
            )
            return got[2]

    return InertiaCalibrator


def cmd_calibrate(args: argparse.Namespace) -> None:
    from gear_rotor_sim.calibration.fit import FitSettings
    from gear_rotor_sim.calibration.measurement import load_measurement

    m = load_measurement(args.record)
    for on in [v == "on" for v in args.variants.split(",")]:
        t_cpu = time.process_time()
        held = []
        if args.held:
            sk, sc, sm = (float(v) for v in args.held.split(":"))
            held = [MeshStiffnessDamping(stiffness_scale=sk, damping_scale=sc)]
            held += [GearInertia(inertia_scale=sm)] if sm != 1.0 else []
        kw = {"baseline_sets": [BearingStiffnessDamping()]} if held else {}
        fs = FitSettings(tooth_path_in_contact=args.path_in_contact, mesh_inertia_from_comb=args.comb)
        cal = inertia_calibrator(on)(m, fit_settings=fs, log=print if args.verbose else None, **kw)
        # the mesh sets held from the start, fitted on this record otherwise (the rules of a record
        # without a reference stay: the DTE depth, the bearing set)
        cal.baseline = list(held)
        r = cal.run().as_dict()
        cpu = time.process_time() - t_cpu
        eff = r["effects"][0] if r["effects"] else None
        base = {b["name"]: b["parameters"] for b in r["baseline_updates"] if b["name"] != "sensor_transfer"}
        print(
            f"mesh_inertia {'on' if on else 'off'}: baseline {json.dumps(base)}; first effect "
            + (f"{eff['label']} {json.dumps(eff['parameters'])}" if eff else "none")
            + f"; error {r['error_before']:.3g} -> {r['error_after']:.3g}; "
            + f"{r['n_simulations']} runs, CPU {cpu:.0f} s"
        )
        for n in r["notes"]:
            if "mesh_inertia" in n or "depth" in n or "mesh stiffness" in n or "confirm" in n:
                print("   note:", n)
        if args.out:
            p = Path(args.out) / f"{Path(args.record).stem}.mesh_inertia_{'on' if on else 'off'}.json"
            p.parent.mkdir(parents=True, exist_ok=True)
            p.write_text(json.dumps({**r, "cpu_s": cpu}, indent=1, default=str))


def cmd_scan(args: argparse.Namespace) -> None:
    """The healthy model's score on a record at triples (s_k, s_c, s_m): mesh stiffness and damping
    scales, gear inertia scale (``GearInertia``), transfer slopes re-fitted at each; per family and per
    channel, and the channel means (static family: measured / model)."""
    from gear_rotor_sim.calibration.fit import Calibrator
    from gear_rotor_sim.calibration.measurement import load_measurement

    m = load_measurement(args.record)
    cal = Calibrator(m)
    cal._setup()
    t_cpu = time.process_time()
    for trip in args.triples.split(","):
        sk, sc, sm = (float(v) for v in trip.split(":"))
        pre = (MeshStiffnessDamping(stiffness_scale=sk, damping_scale=sc),)
        if sm != 1.0:
            pre = (*pre, GearInertia(inertia_scale=sm))
        feats = cal._features(cal._raw(pre))
        cal._refit_transfer(feats)
        sc_ = cal.cmp.score(feats)
        fam = ", ".join(f"{f} {sc_.chi2[f] / max(sc_.n[f], 1):.3g}" for f in sc_.chi2 if sc_.n[f])
        print(
            f"mesh x{sk:g} / damping x{sc:g} / gear inertia x{sm:g}: error {sc_.error:.3g}, balanced chi2 "
            f"{sc_.balanced_chi2:.4g} (chi2/n: {fam})"
        )
        po = sc_.per_channel.get("order", {})
        print("   order per channel: " + ", ".join(f"{k} {v:.3g}" for k, v in po.items()))
        if len(sc_.static_r):
            print(
                "   static r: "
                + ", ".join(f"{n} {v:+.3g}" for n, v in zip(cal.cmp.names, sc_.static_r, strict=False))
            )
    print(f"CPU {time.process_time() - t_cpu:.0f} s")


def cmd_comb(args: argparse.Namespace) -> None:
    """The named tooth's ratio depth and DTE-comb depth along the line that holds the mesh mode
    (``baseline_mesh_inertia.comb_readings``), on the machine with the record's mesh set held."""
    from gear_rotor_sim.calibration.baseline_mesh_inertia import comb_readings, consistent_scale
    from gear_rotor_sim.calibration.fit import Calibrator
    from gear_rotor_sim.calibration.measurement import load_measurement
    from gear_rotor_sim.faults import ToothDamage

    m = load_measurement(args.record)
    cal = Calibrator(m)
    sk, sc = (float(v) for v in args.mesh.split(":"))
    cal.baseline = [MeshStiffnessDamping(stiffness_scale=sk, damping_scale=sc)] if (sk, sc) != (1, 1) else []
    cal._setup()
    t_cpu = time.process_time()
    n0 = cal.runner.n_runs
    e = ToothDamage(tooth=args.tooth, depth=0.4, wheel=args.wheel)
    rows = comb_readings(cal, e, [], [float(v) for v in args.scales.split(",")])
    print(f"{Path(args.record).stem}: mesh x{sk:g} / damping x{sc:g} held, {e.wheel} tooth {e.tooth}")
    for r in rows:
        print(
            f"  inertia x{r.scale:g} (mesh x{sk * r.scale:.3g}): ratio depth {r.ratio_depth:.3g}, "
            f"DTE-comb depth {r.dte_depth:.3g}"
        )
    s = consistent_scale(rows)
    print(f"  the two agree at inertia x{s:.3g} (mesh x{sk * s:.3g})" if s else "  no crossing")
    print(f"  {cal.runner.n_runs - n0} runs, CPU {time.process_time() - t_cpu:.1f} s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    a = sub.add_parser("modes")
    a.add_argument("--temperature-c", type=float, default=75.0)
    a.add_argument("--pairs", default="1:1,1.342:1,1.512:1,1.913:1,1.342:0.9")
    c = sub.add_parser("calibrate")
    c.add_argument("record")
    c.add_argument("--variants", default="off,on", help="mesh_inertia off/on, comma-separated")
    c.add_argument("--out", default=None)
    c.add_argument("--verbose", action="store_true")
    c.add_argument("--path-in-contact", action="store_true", help="FitSettings.tooth_path_in_contact on")
    c.add_argument("--comb", action="store_true", help="FitSettings.mesh_inertia_from_comb on")
    c.add_argument("--held", default=None, help="s_k:s_c:s_m held as the machine's mesh sets from the start")
    d = sub.add_parser("scan")
    d.add_argument("record")
    d.add_argument("--triples", default="1.913:0.74:1,1.342:0.74:0.69,1.342:0.74:1")
    e = sub.add_parser("comb")
    e.add_argument("record")
    e.add_argument("--wheel", choices=("pinion", "gear"), required=True)
    e.add_argument("--tooth", type=int, required=True)
    e.add_argument("--mesh", default="1:1", help="s_k:s_c of the mesh set held (the record's fit)")
    e.add_argument("--scales", default="1,0.8,0.65,0.5")
    args = ap.parse_args()
    cmds = {"modes": cmd_modes, "calibrate": cmd_calibrate, "scan": cmd_scan, "comb": cmd_comb}
    cmds[args.cmd](args)


if __name__ == "__main__":
    main()
