"""Where the DTE mean sits at rattle, and how tooth wear moves it (docs/history/calibration_sessions.md
Sec. 8.20).

The DTE mean over a rattling mesh is the time average over three states: contact on the drive flank,
free flight across the backlash, contact on the back (coast) flank. This script runs the FE model
(``Simulator``) and the independent lumped gearbox (``lumped_gearbox``, clean signals) at one
operating point, healthy and with tooth wear, and splits the DTE mean into those states:
``mean = sum_s f_s m_s`` (``f_s`` the time fraction of state ``s``, ``m_s`` the DTE mean in it), and
the change with wear into ``sum_s (df_s m_s + f_s dm_s)`` plus the cross term.

The state is read from the sign of the mesh force (positive: drive flank, zero: free flight,
negative: back flank) at a high output rate (``--rate``, default 100 kHz) so that the output filter
does not smear the impacts. FE wear runs are started on the healthy rattle branch (whole hunting
periods without the wear, then with it, as ``ModelRunner.grown_effects``). FE baseline scales
(``--mesh-stiffness`` etc.) set the reference-updated model; several ``--fe`` rows may be given as
``label:mesh_k,mesh_c,bearing_k`` (scales).

Usage::

    python benchmarks/rattle_wear_trace.py [--speed-rpm 8000] [--depths-um 0 10 20] [--duration-s 1.0]
        [--fe nominal:1,1,1 ref:1.199,1.0,0.521] [--no-lumped] [--no-profile]
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass

import numpy as np

#: |mesh force| below this fraction of its largest value counts as free flight (the FE force channel
#: passes the output's anti-aliasing filter, which rings around the impacts)
TINY = 0.02


@dataclass
class Split:
    """DTE statistics of one run (um, fractions)."""

    label: str
    mean: float
    frac: tuple[float, float, float]  # drive, free, back
    means: tuple[float, float, float]  # DTE mean in each state
    h1: float  # amplitude at the mesh frequency
    h2: float  # amplitude at twice the mesh frequency
    loss: float  # contact-loss fraction (free + back)


def split(label: str, dte: np.ndarray, force: np.ndarray, fs: float, f_mesh: float) -> Split:
    """Split the DTE mean by the contact state read from the mesh force's sign."""
    scale = max(float(np.max(np.abs(force))), 1.0)
    tiny = TINY * scale
    states = (force > tiny, np.abs(force) <= tiny, force < -tiny)
    frac = tuple(float(np.mean(s)) for s in states)
    means = tuple(float(np.mean(dte[s])) * 1e6 if np.any(s) else float("nan") for s in states)
    t = np.arange(dte.size) / fs
    h1, h2 = (
        2.0 * abs(np.mean((dte - dte.mean()) * np.exp(-2j * np.pi * m * f_mesh * t))) * 1e6 for m in (1, 2)
    )
    return Split(label, float(np.mean(dte)) * 1e6, frac, means, h1, h2, frac[1] + frac[2])


def lumped_run(speed: float, temp: float, h: float, duration: float, fs: float, start: float) -> Split:
    from lumped_gearbox import Gearbox
    from lumped_gearbox.faults import ToothWear as LWear
    from lumped_gearbox.simulate import build, run

    gb = Gearbox()
    setup = build(gb, speed, temp, [LWear(h)] if h > 0 else [])
    out = run(setup, start + duration, fs, substeps=max(2, round(160e3 / fs)))
    i0 = round(start * fs)
    f_mesh = gb.z1 * speed / 60.0
    return split(f"lumped {1e6 * h:.0f} um", out["dte"][i0:], out["mesh_force"][i0:], fs, f_mesh)


def fe_run(
    label: str,
    speed: float,
    temp: float,
    h: float,
    scales: tuple[float, float, float],
    duration: float,
    fs: float,
    profile: bool,
) -> Split:
    from gear_rotor_sim.calibration.model_window import hunting_period_s
    from gear_rotor_sim.examples import paper_gearbox
    from gear_rotor_sim.faults import BearingStiffnessDamping, MeshStiffnessDamping, ToothWear
    from gear_rotor_sim.simulator import Simulator

    cfg = paper_gearbox()
    base = []
    if scales[0] != 1.0 or scales[1] != 1.0:
        base.append(MeshStiffnessDamping(stiffness_scale=scales[0], damping_scale=scales[1]))
    if scales[2] != 1.0:
        base.append(BearingStiffnessDamping(stiffness_scale=scales[2]))
    sim = Simulator(
        cfg,
        speed_rpm=speed,
        temperature_c=temp,
        output_rate_hz=fs,
        channels=["dte", "mesh_force"],
        effects=base,
        event_average=False,  # as the calibration's model runs (ModelRunner)
    )
    period = hunting_period_s(cfg, speed)
    pre = period * max(1, math.ceil(0.2 / period))
    sim.advance(pre)
    if h > 0:
        sim.set_effects((*base, ToothWear(h, profile_scale=1.0 if profile else 0.0)))
    sim.advance(period)  # settle on the worn branch
    blk = sim.advance(duration)
    data = np.asarray(blk.data)
    f_mesh = cfg.meshes[0].pinion_teeth * speed / 60.0
    return split(f"FE {label} {1e6 * h:.0f} um", data[:, 0], data[:, 1], fs, f_mesh)


def row(s: Split) -> str:
    f, m = s.frac, s.means
    return (
        f"| {s.label} | {s.mean:.2f} | {s.h1:.1f} | {s.mean / s.h1:.4f} | {s.h2 / s.h1:.3f} | "
        f"{f[0]:.3f} / {f[1]:.3f} / {f[2]:.3f} | "
        f"{m[0]:.1f} / {m[1]:.1f} / {m[2]:.1f} |"
    )


def delta_row(a: Split, b: Split) -> str:
    """Change of the mean a -> b per state: f_s dm_s (position) and df_s m_s (time share)."""
    parts = []
    for k, name in enumerate(("drive", "free", "back")):
        ma, mb = a.means[k], b.means[k]
        fa, fb = a.frac[k], b.frac[k]
        if not (math.isfinite(ma) and math.isfinite(mb)):
            parts.append(f"{name} -")
            continue
        parts.append(
            f"{name} {fa * (mb - ma):+.2f} pos {(fb - fa) * ma:+.2f} share {(fb - fa) * (mb - ma):+.2f} x"
        )
    return f"| {a.label} -> {b.label} | {b.mean - a.mean:+.2f} | " + "; ".join(parts) + " |"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--speed-rpm", type=float, default=8000.0)
    p.add_argument("--temperature-c", type=float, default=25.0)
    p.add_argument("--depths-um", type=float, nargs="+", default=[0.0, 10.0, 20.0])
    p.add_argument("--duration-s", type=float, default=1.0)
    p.add_argument("--rate", type=float, default=100e3, help="output rate, Hz")
    p.add_argument("--fe", nargs="*", default=["nominal:1,1,1"], help="label:mesh_k,mesh_c,bearing_k")
    p.add_argument("--no-lumped", action="store_true")
    p.add_argument("--no-profile", action="store_true", help="FE wear without the sliding profile")
    a = p.parse_args(argv)
    print(
        "| run | DTE mean (um) | H1 (um) | mean / H1 | H2 / H1 | time share drive / free / back "
        "| DTE mean per state (um) |"
    )
    print("|---|---|---|---|---|---|---|")
    groups: list[list[Split]] = []
    if not a.no_lumped:
        g = [
            lumped_run(a.speed_rpm, a.temperature_c, d * 1e-6, a.duration_s, a.rate, 0.2) for d in a.depths_um
        ]
        groups.append(g)
        for s in g:
            print(row(s), flush=True)
    for spec in a.fe:
        label, _, sc = spec.partition(":")
        scales = tuple(float(x) for x in sc.split(",")) if sc else (1.0, 1.0, 1.0)
        if len(scales) != 3:
            raise SystemExit(f"--fe {spec!r}: give label:mesh_k,mesh_c,bearing_k")
        g = []
        for d in a.depths_um:
            s = fe_run(
                label, a.speed_rpm, a.temperature_c, d * 1e-6, scales, a.duration_s, a.rate, not a.no_profile
            )
            g.append(s)
            print(row(s), flush=True)
        groups.append(g)
    print()
    print("| change | d mean (um) | per state: f ds (position), ds f (share), cross |")
    print("|---|---|---|")
    for g in groups:
        for s in g[1:]:
            print(delta_row(g[0], s))
    return 0


if __name__ == "__main__":
    sys.exit(main())
