"""Calibration report: Markdown + PNG figures + JSON.

Contents: the measurement and its issues; the main error before/after; per channel and per metric
errors before/after; the effects found (parameters, uncertainty, confidence, Delta BIC, explained
fraction); the candidate ranking of every round; residual amplitude spectra and envelope spectra
before/after.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from gear_rotor_sim.calibration.fit import CalibrationResult, model_residual_spectra
from gear_rotor_sim.calibration.residual import envelope_power_spectrum
from gear_rotor_sim.calibration.residual_trace import trace_markdown


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        if not math.isfinite(v):
            return str(v)
        return f"{v:.4g}"
    return str(v)


def _json_safe(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {str(k): _json_safe(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_json_safe(v) for v in obj]
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def result_json(result: CalibrationResult) -> dict[str, Any]:
    """The JSON object (NaN/inf as null)."""
    return _json_safe(result.as_dict())


def _figures(result: CalibrationResult, out: Path, stem: str) -> list[str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = result.comparison.names
    files: list[str] = []
    fs = result.measurement.sample_rate_hz
    nc = len(names)
    fig, axes = plt.subplots(nc, 1, figsize=(8, 2.4 * nc), squeeze=False)
    for c, ax in enumerate(axes[:, 0]):
        spec = model_residual_spectra(result, c)
        f, a0 = spec["before"]
        _, a1 = spec["after"]
        ax.semilogy(f, a0 + 1e-300, lw=0.7, label="residual before")
        ax.semilogy(f, a1 + 1e-300, lw=0.7, label="residual after", alpha=0.8)
        ax.set_xlim(0, 0.5 * fs)
        ax.set_ylabel(names[c])
        ax.grid(alpha=0.3)
    axes[0, 0].legend(loc="upper right", fontsize=8)
    axes[-1, 0].set_xlabel("frequency (Hz)")
    fig.suptitle("Amplitude spectrum of the time residual (measurement - gain x model)")
    fig.tight_layout()
    name = f"{stem}_residual_spectra.png"
    fig.savefig(out / name, dpi=110)
    plt.close(fig)
    files.append(name)
    cmp = result.comparison
    if "envelope" in cmp.families and cmp.bands:
        fig, axes = plt.subplots(nc, 1, figsize=(8, 2.4 * nc), squeeze=False)
        for c, ax in enumerate(axes[:, 0]):
            f = cmp.env_f
            ax.plot(f, cmp.d_env[c], lw=0.8, color="k", label="measured")
            for lab, model, score in (
                ("model before", result.model_before, result.score_before),
                ("model after", result.model_after, result.score_after),
            ):
                feats = cmp.features(model)
                g = float(score.gains[c]) if "order" in cmp.families else 1.0
                exp = cmp.envelope_expected(c, cmp.envelope_model(feats, c), g)
                ax.plot(f, exp, lw=0.8, label=lab, alpha=0.85)
            ax.set_yscale("log")
            ax.set_ylabel(names[c])
            ax.set_title(f"band {cmp.bands[c][0]:.0f}-{cmp.bands[c][1]:.0f} Hz", fontsize=8)
            ax.grid(alpha=0.3)
        axes[0, 0].legend(loc="upper right", fontsize=8)
        axes[-1, 0].set_xlabel("envelope frequency (Hz)")
        fig.suptitle("Squared-envelope spectra: measured vs expected from the model (+ noise floor)")
        fig.tight_layout()
        name = f"{stem}_envelope_spectra.png"
        fig.savefig(out / name, dpi=110)
        plt.close(fig)
        files.append(name)
    return files


def write_report(
    result: CalibrationResult, directory: str | Path, stem: str | None = None, figures: bool = True
) -> dict[str, Path]:
    """Write ``<stem>.md``, ``<stem>.json`` and the figures into ``directory``.

    Returns
    -------
    dict
        ``{"markdown": path, "json": path, "figures": [paths]}``.
    """
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    stem = stem or Path(result.measurement.source).stem
    js = result_json(result)
    (out / f"{stem}.json").write_text(json.dumps(js, indent=2) + "\n", encoding="utf-8")
    figs = _figures(result, out, stem) if figures else []
    m = result.measurement
    op = m.operating_point
    speed = next((b for b in result.baseline_updates if b.name == "operating_speed"), None)
    declared = "declared" if speed is None else "speed measured from the record's mesh lines, declared "
    declared += "" if speed is None else f"{speed.parameters['declared_speed_rpm']:g} rpm"
    lines = [
        f"# Calibration report: `{Path(m.source).name}`",
        "",
        f"- Operating point ({declared}): {op.speed_rpm:g} rpm, {op.temperature_c:g} degC"
        + (f", output torque {op.output_torque_nm:g} N m" if op.output_torque_nm is not None else "")
        + "".join(
            " (measured from the radial bearing-force means, declared "
            f"{b.parameters['declared_output_torque_nm']:g} N m)"
            for b in result.baseline_updates
            if b.name == "operating_torque"
        ),
        f"- Model: `{m.gearbox}`; {m.n_samples} samples at {m.sample_rate_hz:g} Hz ({m.duration_s:.3g} s); "
        f"channels {', '.join(result.comparison.names)}",
        f"- Simulations run: {result.n_simulations}",
        "",
        "## Result",
        "",
        f"**{result.conclusion}.**",
        "",
        f"Main metric (family-balanced normalised RMS residual, 1 = noise level): "
        f"**{result.error_before:.4g} before, {result.error_after:.4g} after**.",
        "",
    ]
    if result.effects:
        lines += [
            "| # | effect | parameters (+- 1 sigma) | confidence | Delta BIC | explained "
            "| error before -> after |",
            "|---|---|---|---|---|---|---|",
        ]
        for i, e in enumerate(result.effects, 1):
            ps = ", ".join(
                f"{k} = {_fmt(v)} +- {_fmt(e.uncertainty.get(k, float('nan')))}"
                for k, v in e.parameters.items()
            )
            lines.append(
                f"| {i} | `{e.label}` | {ps} | {e.confidence:.3f} | {e.delta_bic:.4g} | "
                f"{e.explained_fraction:.2f} | {e.error_before:.4g} -> {e.error_after:.4g} |"
            )
        lines.append("")
    else:
        lines += ["No effect claimed.", ""]
    lines += [f"## Baseline (source: {result.baseline_source})", ""]
    for b in result.baseline_updates:
        ps = ", ".join(f"{k} = {_fmt(v)}" for k, v in b.parameters.items())
        lines.append(f"- `{b.label}`: {ps}")
    for e in result.not_claimed:
        ps = ", ".join(f"{k} = {_fmt(v)}" for k, v in e.parameters.items())
        lines.append(f"- not claimed ({e.status}): `{e.label}`: {ps}")
    lines += ["", "## Errors per family", "", "| family | before | after |", "|---|---|---|"]
    for f in result.score_before.chi2:
        b = math.sqrt(result.score_before.chi2[f] / result.score_before.n[f])
        a = math.sqrt(result.score_after.chi2[f] / result.score_after.n[f])
        lines.append(f"| {f} (normalised RMS) | {b:.4g} | {a:.4g} |")
    lines += [
        "",
        "## Errors per channel and metric",
        "",
        "Normalised: RMS of residual / (noise + tolerance); relative: |residual| / |measured feature|; "
        "time: relative RMS of the aligned time residual; spectrum: relative amplitude-spectrum error.",
        "",
        "| channel | metric | before | after |",
        "|---|---|---|---|",
    ]
    bj, aj = js["per_channel_before"], js["per_channel_after"]
    for ch in bj:
        for k in bj[ch]:
            lines.append(f"| {ch} | {k} | {_fmt(bj[ch][k])} | {_fmt(aj.get(ch, {}).get(k))} |")
    lines += ["", "## Candidates (ranked by Delta BIC)", ""]
    for r, table in enumerate(result.rounds, 1):
        lines += [
            f"Round {r}:",
            "",
            "| candidate | parameters | Delta BIC | explained | error |",
            "|---|---|---|---|---|",
        ]
        for row in table:
            if "delta_bic" not in row:
                lines.append(f"| `{row['label']}` | - | - | - | {row.get('note', '')} |")
                continue
            ps = ", ".join(f"{k} = {_fmt(v)}" for k, v in row["parameters"].items())
            lines.append(
                f"| `{row['label']}` | {ps} | {row['delta_bic']:.4g} | {row['explained_fraction']:.2f} | "
                f"{row['error']:.4g} |"
            )
        lines.append("")
    lines += trace_markdown(result.residual_trace)
    if m.issues or result.notes:
        lines += ["## Data issues and notes", ""] + [f"- {x}" for x in [*m.issues, *result.notes]] + [""]
    if figs:
        lines += ["## Figures", ""] + [f"![{f}]({f})" for f in figs] + [""]
    (out / f"{stem}.md").write_text("\n".join(lines), encoding="utf-8")
    return {"markdown": out / f"{stem}.md", "json": out / f"{stem}.json", "figures": [out / f for f in figs]}


__all__ = ["envelope_power_spectrum", "result_json", "write_report"]
