"""``gear-rotor-sim validate``: Table 2 reproduction and the mesh-stiffness summary.

Prints the axial thermal node load of the paper's 20 mm, 30 mm diameter beam element for temperature
rises of 50..300 C from 25 C against Table 2, and the mesh stiffness (mean, min, max over one mesh
period), contact ratio and the ratio of the mean to ISO 6336-1 ``c_gamma_alpha b`` for the paper's gears
at 25, 125 and 225 C. ``--json`` prints one JSON object with ``table2`` and ``mesh_stiffness`` lists.

References
----------
Sun, Chen, Hu, Lei (2021), Nonlinear Dynamics, Table 2 (Eqs 9-11), Table 3, Eqs 13-15; ISO 6336-1:2019.
"""

from __future__ import annotations

import argparse
import json
import math
from typing import Any

from gear_rotor_sim.gears import SpurGearPair

# Table 2, "Numerical calculation" row: axial thermal node load (N) for rises 50..300 C.
TABLE2_PAPER_N: tuple[tuple[float, float], ...] = (
    (50.0, 0.84346e5),
    (100.0, 1.6538e5),
    (150.0, 2.4187e5),
    (200.0, 3.1257e5),
    (250.0, 3.7624e5),
    (300.0, 4.3164e5),
)
MESH_TEMPERATURES_C: tuple[float, ...] = (25.0, 125.0, 225.0)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the options of ``gear-rotor-sim validate``."""
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of tables")
    parser.add_argument(
        "--config", default="paper_sun2021", help="config name or path (default: paper_sun2021)"
    )
    parser.add_argument("--points", type=int, default=512, help="mesh-phase grid points (default 512)")


def _material(cfg: Any, ref: Any) -> Any:
    if isinstance(ref, str):
        mats = cfg.materials
        return mats[ref] if isinstance(mats, dict) else next(m for m in mats if m.name == ref)
    return ref


def _paper_inputs(config: str) -> tuple[Any, SpurGearPair, float]:
    """Material of the first shaft, the first mesh as a SpurGearPair, and the reference temperature."""
    from gear_rotor_sim.config import load_config

    cfg = load_config(config)
    mesh = cfg.meshes[0]
    gears = {g.name: g for g in cfg.gears}
    gp, gg = gears[mesh.pinion], gears[mesh.gear]
    shaft_material = _material(cfg, cfg.shafts[0].elements[0].material)
    pair = SpurGearPair(
        pinion_teeth=int(gp.teeth),
        gear_teeth=int(gg.teeth),
        module=mesh.module_m,
        pressure_angle=mesh.pressure_angle_rad,
        face_width=mesh.face_width_m,
        addendum_coefficient=mesh.addendum_coefficient,
        clearance_coefficient=mesh.clearance_coefficient,
        material_pinion=_material(cfg, gp.material),
        material_gear=_material(cfg, gg.material),
        bore_diameter_pinion=gp.bore_diameter_m,
        bore_diameter_gear=gg.bore_diameter_m,
    )
    return shaft_material, pair, float(cfg.reference_temperature_c)


def table2_rows(material: Any, reference_temperature_c: float = 25.0) -> list[dict[str, float]]:
    """Axial thermal node load of the Table 2 element (20 mm long, 15 mm radius) vs the paper.

    References
    ----------
    Sun et al. (2021) Eqs 9-11, Table 2.
    """
    from gear_rotor_sim.elements.shaft import ShaftElement

    element = ShaftElement(length=0.02, outer_diameter=0.03, inner_diameter=0.0, material=material)
    rows = []
    for rise, paper in TABLE2_PAPER_N:
        load = element.thermal_node_load(reference_temperature_c + rise, reference_temperature_c)
        model = float(abs(load[8]))  # axial entry z_j of Eq 35
        rows.append(
            {"temperature_rise_c": rise, "paper_n": paper, "model_n": model, "rel_error": model / paper - 1.0}
        )
    return rows


def mesh_rows(pair: SpurGearPair, n_points: int = 512) -> list[dict[str, float]]:
    """Mesh stiffness summary at 25, 125, 225 C with the ISO 6336-1 ratio (Eqs 13-15)."""
    rows = []
    for t in MESH_TEMPERATURES_C:
        table = pair.mesh_stiffness_table(t, n_points=n_points)
        iso = pair.iso_mesh_stiffness(t)["mesh_stiffness"]
        rows.append(
            {
                "temperature_c": t,
                "mean_n_per_m": table.mean,
                "min_n_per_m": table.min,
                "max_n_per_m": table.max,
                "contact_ratio": table.contact_ratio,
                "iso_ratio": table.mean / iso,
                "iso_n_per_m": iso,
            }
        )
    return rows


def collect(config: str = "paper_sun2021", n_points: int = 512) -> dict[str, Any]:
    """All validation numbers as one JSON-serialisable dict."""
    material, pair, t_ref = _paper_inputs(config)
    b = 35e-6
    return {
        "config": config,
        "table2": table2_rows(material, t_ref),
        "mesh_stiffness": mesh_rows(pair, n_points),
        "thermal_half_backlash_um": [
            {"temperature_c": t, "b_star_um": pair.thermal_half_backlash(b, t, t_ref) * 1e6, "b_um": b * 1e6}
            for t in MESH_TEMPERATURES_C
        ],
    }


def run(args: argparse.Namespace) -> int:
    """Print the validation tables (or one JSON object with ``--json``); returns 0, or 1 if Table 2 is off."""
    data = collect(getattr(args, "config", "paper_sun2021"), getattr(args, "points", 512))
    worst = max(abs(r["rel_error"]) for r in data["table2"])
    if getattr(args, "json", False):
        print(json.dumps(data))
        return 0 if worst <= 1e-3 else 1
    print("Table 2: axial thermal node load of a 20 mm, d = 30 mm beam element (Eqs 9-11)")
    print(f"{'rise (C)':>9} {'paper (N)':>12} {'model (N)':>12} {'error':>9}")
    for r in data["table2"]:
        print(
            f"{r['temperature_rise_c']:9.0f} {r['paper_n']:12.1f} {r['model_n']:12.1f} "
            f"{100.0 * r['rel_error']:+8.4f}%"
        )
    print(f"max |error| {100.0 * worst:.4f} % (limit 0.1 %)")
    print()
    print("Mesh stiffness of the paper's gears (Eqs 13-15) vs ISO 6336-1 c_gamma_alpha b")
    print(f"{'T (C)':>6} {'mean (N/m)':>12} {'min (N/m)':>12} {'max (N/m)':>12} {'eps':>7} {'ISO ratio':>10}")
    for r in data["mesh_stiffness"]:
        print(
            f"{r['temperature_c']:6.0f} {r['mean_n_per_m']:12.4e} {r['min_n_per_m']:12.4e} "
            f"{r['max_n_per_m']:12.4e} {r['contact_ratio']:7.4f} {r['iso_ratio']:10.3f}"
        )
    print()
    print("Thermal half backlash b* (Eq 27), b = 35 um, pitch point")
    for r in data["thermal_half_backlash_um"]:
        print(f"{r['temperature_c']:6.0f} C  b* = {r['b_star_um']:.4f} um")
    return 0 if worst <= 1e-3 and math.isfinite(worst) else 1
