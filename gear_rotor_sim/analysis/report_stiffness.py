"""The mesh-stiffness-scale section of docs/REPRODUCTION.md and the numbers its summary quotes.

The study itself is :func:`~gear_rotor_sim.analysis.reproduce_studies.stiffness_study`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from gear_rotor_sim.analysis.paper_data import INV_ISO_SCALE, ISO_SCALE, PANEL_TITLES, PAPER_FIG7, PAPER_FIG8
from gear_rotor_sim.analysis.report_markdown import fmt_windows


def write_stiffness_section(add: Callable[[str], None], r: dict[str, Any]) -> None:
    """The mesh-stiffness-scale study: Fig 6 band location, Fig 7 and Fig 8 values per scale."""
    st = r["stiffness"]
    iso = st["iso"]
    add("## Sensitivity to the mesh stiffness scale")
    add("")
    add(
        "The paper gives the potential-energy TVMS only as equations. Ours has a mean of "
        f"{iso['k_pe']:.3e} N/m at 25 C, {1 / iso['iso_over_pe']:.3f} of the ISO 6336-1 value "
        f"c_gamma_alpha b = {iso['k_iso']:.3e} N/m "
    )
    add(
        "(`docs/mesh_stiffness.md`). The stiffness scale multiplies k_m(t) at every mesh phase "
        "(the shape over the mesh cycle is unchanged) and the mesh damping by sqrt(scale), "
        "so the damping ratio stays 0.07 "
        "(`Case(..., overrides=(('mesh_stiffness_scale', s),))`, "
        "`gear_rotor_sim.analysis.bifurcation.scale_mesh_stiffness`). "
        f"Scale {ISO_SCALE:g} is the ISO-equivalent stiffness; scale {INV_ISO_SCALE:g} is its inverse."
    )
    add("")
    add("### Fig 6: location of the main chaotic band")
    add("")
    add(
        "Main band = the widest chaotic window (neighbouring chaotic windows separated by one grid speed "
        "merged) reaching above 11000 rpm; the prediction moves the scale-1 band by sqrt(scale) "
        "(a resonance at fixed mass). The grid ends at 20000 rpm, so a band reaching 20000 rpm is cut there."
    )
    add("")
    add(
        "| panel | scale | mean k_m at 25 C (N/m) | model: widest chaotic window above 11000 rpm "
        "| sqrt(scale) x scale-1 band (rpm) "
        "| paper (rpm) | edge errors (rpm) | overlap | model at paper mid-window | wall time (s) |"
    )
    add("|---|---|---|---|---|---|---|---|---|---|")
    for x in st["fig6"]:
        lo, hi = x["main_band"]
        plo, phi = x["paper"]
        band = f"{lo:.0f}-{hi:.0f}" if np.isfinite(lo) else "none"
        err = f"{lo - plo:+.0f} / {hi - phi:+.0f}" if np.isfinite(lo) else "-"
        pred = f"{x['pred_lo']:.0f}-{x['pred_hi']:.0f}" if np.isfinite(x["pred_lo"]) else "-"
        add(
            f"| {PANEL_TITLES[x['panel']]} | {x['scale']:g} | {iso['k_pe'] * x['scale']:.3e} | "
            f"{band} | {pred} | "
            f"{plo:.0f}-{phi:.0f} | {err} | {x['jaccard']:.0%} | {x['label_at_paper_mid']} | "
            f"{x['wall_time_s']:.1f} |"
        )
    add("")
    add("All chaotic windows per run:")
    add("")
    for x in st["fig6"]:
        add(f"- {PANEL_TITLES[x['panel']]}, scale {x['scale']:g}: {fmt_windows(x['chaotic_windows'])}")
    add("")
    add("![band vs scale](figures/fig6_band_vs_stiffness_scale.png)")
    add("")
    add("![Fig 6a per scale](figures/fig6_25C_stiffness_scales.png)")
    add("")
    add("### Figs 7 and 8 against the stiffness scale (bearings A#)")
    add("")
    scales = st["scales"]
    add("| T (C) | speed (rpm) | paper (N) | " + " | ".join(f"k x {sc:g} (N)" for sc in scales) + " |")
    add("|---|---|---|" + "---|" * len(scales))
    f7 = {(x["scale"], x["temperature_c"], x["speed_rpm"]): x for x in st["fig7"]}
    for t, sp, paper_n in PAPER_FIG7:
        cells = " | ".join(f"{f7[(sc, t, sp)]['model_n']:.0f}" for sc in scales)
        add(f"| {t:g} | {sp:g} | {paper_n:g} | {cells} |")
    add("")
    add("Speed of the largest bearing-2 force on the Fig 7 grid (the resonance peak), per scale:")
    add("")
    add("| T (C) | " + " | ".join(f"k x {sc:g}" for sc in scales) + " |")
    add("|---|" + "---|" * len(scales))
    for t in (25.0, 125.0, 225.0):
        cells = " | ".join(
            f"{f7[(sc, t, 1000.0)]['peak_speed_rpm']:.0f} rpm, {f7[(sc, t, 1000.0)]['peak_n']:.0f} N"
            for sc in scales
        )
        add(f"| {t:g} | {cells} |")
    add("")
    add("![Fig 7 per scale](figures/fig7_stiffness_scales.png)")
    add("")
    base8 = {
        x["temperature_c"]: x["model_um"] for x in r["fig8"] if x["node"] == 9 and x["bearing_type"] == "A#"
    }
    f8 = {(x["scale"], x["temperature_c"]): x["model_um"] for x in st["fig8_node9"]}
    f8.update({(1.0, t): v for t, v in base8.items()})
    add("Fig 8, node 9 at 19000 rpm (largest distance from the theoretical position):")
    add("")
    add("| T (C) | paper (um) | " + " | ".join(f"k x {sc:g} (um)" for sc in scales) + " |")
    add("|---|---|" + "---|" * len(scales))
    for bt, t, node, paper_um in PAPER_FIG8:
        if bt == "A#" and node == 9:
            cells = " | ".join(f"{f8[(sc, t)]:.1f}" if (sc, t) in f8 else "-" for sc in scales)
            add(f"| {t:g} | {paper_um:g} | {cells} |")
    add("")
    sv = intro_vars(r)
    for extra in REPORT_STIFFNESS:
        add(extra.format(**sv))
    add("")
    add("| scale | " + " | ".join(["frequency (Hz), mesh energy, speed (rpm)"] * 2) + " |")
    add("|---|---|---|")
    for sc, modes in st.get("modes", {}).items():
        cells = [
            f"{m['f_hz']:.0f}, {m['mesh_energy']:.0%}, {m['speed_rpm']:.0f}"
            for m in modes
            if m["f_hz"] > 2000
        ]
        add(f"| {sc} | " + " | ".join([*cells, "-", "-"][:2]) + " |")
    add("")


def intro_vars(r: dict[str, Any]) -> dict[str, Any]:
    """Numbers quoted in the summary and the stiffness conclusions (empty without the stiffness study)."""
    st = r.get("stiffness")
    if not st:
        return {}
    scales = st["scales"]
    s_lo, s_hi = min(scales), max(scales)
    f7 = {(x["scale"], x["temperature_c"], x["speed_rpm"]): x for x in st["fig7"]}
    rows = {(x["panel"], x["scale"]): x for x in st["fig6"]}
    f8 = {
        x["temperature_c"]: x["model_um"] for x in r["fig8"] if x["node"] == 9 and x["bearing_type"] == "A#"
    }
    u25 = [x["model_um"] for x in st["fig8_node9"] if x["temperature_c"] == 25.0] + [f8[25.0]]
    f1000 = [f7[(sc, t, 1000.0)]["model_n"] for sc in scales for t in (25.0,)]
    base, soft, iso = rows[("25C", 1.0)], rows[("25C", s_lo)], rows[("25C", s_hi)]
    iso_windows = [w for w in iso["chaotic_windows"] if w[1] >= 11000]
    iso_b = rows.get(("225C", s_hi))
    iso_c = rows.get(("225C_fixed", s_hi))
    return {
        "s_lo": s_lo,
        "s_hi": s_hi,
        "peak_lo": f7[(s_lo, 25.0, 1000.0)]["peak_speed_rpm"],
        "peak_hi": f7[(s_hi, 25.0, 1000.0)]["peak_speed_rpm"],
        "u25": f8[25.0],
        "u25_lo": min(u25),
        "u25_hi": max(u25),
        "b_lo": base["main_band"][0],
        "b_hi": base["main_band"][1],
        "soft_lo": soft["main_band"][0],
        "soft_hi": soft["main_band"][1],
        "soft_err": soft["main_band"][0] - soft["paper"][0],
        "base_err": base["main_band"][0] - base["paper"][0],
        "iso_band": f"the range {base['main_band'][0]:.0f}-{base['main_band'][1]:.0f} rpm, "
        "chaotic at scale 1, is no longer chaotic and the highest chaotic window is "
        + (fmt_windows([max(iso_windows)]) + " rpm, near the grid end" if iso_windows else "none"),
        "iso_win": fmt_windows([w for w in iso_windows if w[0] < 16000]) + " rpm",
        "iso_b": f"(b) {fmt_windows([w for w in iso_b['chaotic_windows'] if w[1] >= 11000])} rpm"
        if iso_b
        else "-",
        "iso_c": f"(c) {fmt_windows([w for w in iso_c['chaotic_windows'] if w[1] >= 11000])} rpm"
        if iso_c
        else "-",
        "f7_spread": (max(f1000) - min(f1000)) / min(f1000) * 100.0,
    }


REPORT_STIFFNESS = [
    "What the study shows. (1) The direction of the hint 'ISO stiffness would move the band down to about",
    "13900 rpm' is reversed: a resonance speed grows with sqrt(k), so the ISO-equivalent mesh (x {s_hi:g})",
    "moves the main band up ({iso_band}); a band at the paper's speeds needs a softer mesh. (2) With",
    "the softer mesh (x {s_lo:g}) the main band moves to {soft_lo:.0f}-{soft_hi:.0f} rpm at 25 C, about",
    "{soft_err:.0f} rpm above the paper's lower edge (at scale 1: {base_err:.0f} rpm); the shift is smaller",
    "than the sqrt(scale) law predicts, consistent with a band that involves a mode with little mesh",
    "participation (mode table below). (3) With the ISO stiffness a different chaotic window appears",
    "at 25 C, {iso_win},",
    "which overlaps the paper's 13500-14700 rpm, but in panels (b) and (c) the same stiffness gives windows",
    "({iso_b}; {iso_c}) that do not follow the paper's, so this is not a consistent match. (4) The",
    "1000 rpm bearing forces do not depend on the mesh stiffness (within {f7_spread:.1f} %), the 14400 rpm",
    "forces change by a few per cent and keep 225 C above 125 C at every scale, and the force peak moves",
    "from {peak_lo:.0f} to {peak_hi:.0f} rpm. (5) The cold 19000 rpm amplitude of Fig 8 grows with the",
    "stiffness, not monotonically ({u25_lo:.1f} to {u25_hi:.1f} um; paper 9.8 um). Conclusion: the mesh",
    "stiffness, which the",
    "paper does not give numerically, explains part of the Fig 6 band offset and the location of the",
    "Fig 7 peak; no single scale reproduces the paper's Fig 6 windows, its 14400 rpm points and its cold",
    "Fig 8 amplitude together, so the remaining differences point to other unstated model details (mass",
    "and inertia model of the gears, how load and drive are applied) rather than the mesh stiffness alone.",
    "",
    "Modes of the model linearised with the mean mesh stiffness (25 C; modes with >= 5 % of their strain",
    "energy in the mesh, below 20 kHz; the speed is where the mesh frequency 29 n / 60 equals the mode):",
]
