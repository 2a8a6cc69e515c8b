"""The JSON object ``gear-rotor-sim reproduce --json`` prints, from the numbers of
:func:`~gear_rotor_sim.analysis.reproduce.compute` (or their saved copy)."""

from __future__ import annotations

from typing import Any

from gear_rotor_sim.analysis.paper_data import PANELS


def _fig7_rows(r: dict[str, Any], speed_rpm: float) -> list[dict[str, Any]]:
    keys = ("temperature_c", "paper_n", "model_n", "rel_error")
    return [{k: x[k] for k in keys} for x in r["fig7"] if x["speed_rpm"] == speed_rpm]


def summary_json(r: dict[str, Any]) -> dict[str, Any]:
    """The JSON object printed by ``--json``."""
    b = r["benchmark"]
    return {
        "level": r["level"],
        "fig7_1000rpm": _fig7_rows(r, 1000.0),
        "fig7_14400rpm": _fig7_rows(r, 14400.0),
        "fig8_19000rpm_node9": [
            {
                "temperature_c": x["temperature_c"],
                "paper_um": x["paper_um"],
                "model_um": x["model_um"],
                "rel_error": x["rel_error"],
            }
            for x in r["fig8"]
            if x["node"] == 9 and x["bearing_type"] == "A#"
        ],
        "fig8_19000rpm_node1_225c": [
            {"bearing_type": x["bearing_type"], "paper_um": x["paper_um"], "model_um": x["model_um"]}
            for x in r["fig8"]
            if x["node"] == 1
        ],
        "fig9_axial_share_19000rpm": {k: v["rms"][2] for k, v in r["fig9_19000rpm"].items()},
        "fig6": {
            k: {
                "chaotic_windows": r["fig6"][k]["chaotic_windows"],
                "paper": r["fig6"][k]["paper_chaotic_windows"],
                "wall_time_s": r["fig6"][k]["wall_time_s"],
            }
            for k in PANELS
        },
        "stiffness_scale": _stiffness_json(r),
        "benchmark": {
            "steps_per_s": b["steps_per_s"],
            "rtf_3000rpm": b["rtf_3000rpm"],
            "rtf_20000rpm": b["rtf_20000rpm"],
            "speedup_vs_full": b.get("speedup_vs_full"),
            "max_rms_dte_error_pct": b.get("max_rms_dte_error_pct"),
            "default_model": b.get("default_model"),
        },
    }


def _stiffness_json(r: dict[str, Any]) -> dict[str, Any] | None:
    """Main chaotic band and the Fig 7 points per mesh-stiffness scale (None when not run)."""
    st = r.get("stiffness")
    if not st:
        return None
    return {
        "iso_over_potential_energy": st["iso"]["iso_over_pe"],
        "fig6_main_band": [
            {"panel": x["panel"], "scale": x["scale"], "model_rpm": x["main_band"], "paper_rpm": x["paper"]}
            for x in st["fig6"]
        ],
        "fig7": [
            {k: x[k] for k in ("scale", "temperature_c", "speed_rpm", "paper_n", "model_n")}
            for x in st["fig7"]
        ],
    }


def printed_json(r: dict[str, Any]) -> dict[str, Any]:
    """The object printed by ``--json``: :func:`summary_json`, plus ``fig6_25c_main_chaotic_band_rpm``
    (the finely resolved Fig 6a main band,
    :func:`~gear_rotor_sim.analysis.reproduce_studies.refine_main_band`) for a non-default configuration.
    """
    s = summary_json(r)
    fine = r.get("fig6_25c_main_band_fine")
    if fine is not None:
        s["fig6_25c_main_chaotic_band_rpm"] = fine["band_rpm"]
    return s
