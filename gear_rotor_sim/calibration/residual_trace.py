"""Where the final residual is: the final error traced to channels, feature families and lines (issue 11).

When no effect of the library explains a record, "the remaining error is not explained by the library"
does not tell a user which effect the model lacks. This module decomposes the FINAL residual of a
calibration (the model after its baseline updates and effects, with the fitted gains and time shift) and
names where it is (docs/calibration.md Sec. 5 "Residual trace"):

1. **Shares of the main metric.** ``E^2 = (1 / F) sum_f chi2_f / N_f`` (Sec. 2, "Metrics"; ``F`` the
   families scored), so every feature's ``r^2 / sigma^2`` adds ``(r^2 / sigma^2) / (F N_f)`` to ``E^2``.
   The features are grouped by channel and family: each shaft's low orders (1-6), the mesh harmonics
   (carriers), the mesh sidebands of each shaft, the envelope's bearing-defect lines, its shaft-rate lines,
   its other (non-synchronous) lines and its broadband bins, and the channel means. The shares of
   ``E^2`` sum to 1 (checked: the per-family sums equal the score's ``chi2_f``).
2. **Dominant components, concretely.** For each of the largest components: the channel, the family, the
   order or frequency of its largest feature, the measured and model amplitude in units of the feature's
   noise standard deviation, and the normalised residual.
3. **Readings.** The largest components (>= 10 % of ``E^2``, one per family and shaft) are read by
   ``residual_signatures.py``: a shaft's low orders and its mesh sidebands as a 1x-6x profile over every
   channel (1x, 2x, 1x-3x, even orders, broad), each pattern with the library effects whose signature it
   is and the physical effects outside the library that produce it, and whether the library's were
   fitted on this record (their best Delta BIC in ``candidates_by_round``) or claimed.
4. **Outside the scored features.** The measured record's non-synchronous part (every shaft's synchronous
   average removed) is searched for lines standing 10 x (10 dB) above the local spectral median and
   10 x above the final model's non-synchronous spectrum at that frequency: lines that no scored feature
   holds (fractional orders such as 0.5x of a shaft, a structural resonance, an electrical line).
   They carry no share of ``E`` (they are not in it); each is given in Hz and in orders of every shaft.

The trace reads the calibration's state and changes none of it (effects, baseline updates, errors and
verdicts are those of the calibration); it costs one pass over the features and one non-synchronous
spectrum per channel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.signal import welch

from gear_rotor_sim.calibration.features_orders import remove_synchronous
from gear_rotor_sim.calibration.residual_signatures import reading, tried_candidates

#: a component is read only if its largest feature where the record exceeds the model stands this many
#: uncertainties out (the healthy records' final residual against a reference: 2-3 sigma)
READING_MIN_RESIDUAL = 5.0


@dataclass
class _Feature:
    channel: str
    family: str  # shaft orders, mesh harmonics, mesh sidebands, envelope: ..., channel mean
    shaft: str
    where: str  # "order 2", "29 +- 1", "312.5 Hz", "mean"
    r2: float  # (r / sigma)^2 as scored
    share: float  # of E^2
    measured: float  # in units of the feature's noise standard deviation
    model: float
    order: int = 0  # shaft orders: the order; mesh sidebands: the spacing |k - m z|

    @property
    def model_lacks(self) -> bool:
        """The record holds more here than the model (content the model lacks), not the reverse."""
        return abs(self.measured) > abs(self.model)


def _order_features(cmp: Any, feats: Any, score: Any, fam_w: float) -> list[_Feature]:
    """Every order feature's normalised residual, as ``Comparison.score`` scores it."""
    out: list[_Feature] = []
    G = np.column_stack([score.gains, score.slopes])
    sh_feats = cmp.apply_shift(feats, score.tau)
    for c in range(cmp.nc):
        for s, sh in enumerate(cmp.shafts):
            mg = cmp.order_gain(G, c, s) * sh_feats.order[c][s]
            d = cmp.d_order[c][s]
            s2 = cmp.order_sigma2(c, s, mg)
            noise = np.sqrt(cmp.v_order[c][s] / 2.0)  # per real component
            r2 = 2.0 * np.abs(d - mg) ** 2 / s2
            carriers = cmp.carriers(s)
            for i, k in enumerate(sh.orders):
                if not np.isfinite(s2[i]):
                    continue
                k = int(k)
                if carriers[i]:
                    fam, where = "mesh harmonics", f"order {k} (mesh x{k // max(sh.teeth, 1)})"
                elif k <= cmp.s.low_orders and not _in_mesh_band(k, sh, cmp.s.sidebands):
                    fam, where = "shaft orders", f"order {k}"
                else:
                    z = max(sh.teeth, 1)
                    m = max(round(k / z), 1)
                    fam, where = "mesh sidebands", f"order {k} (mesh x{m} {k - m * z:+d})"
                    k = abs(k - m * z)  # the sideband's spacing in orders of this shaft
                out.append(
                    _Feature(
                        cmp.names[c],
                        fam,
                        sh.name,
                        where,
                        float(r2[i]),
                        float(r2[i]) * fam_w,
                        float(abs(d[i]) / noise[i]) if noise[i] > 0 else math.inf,
                        float(abs(mg[i]) / noise[i]) if noise[i] > 0 else math.inf,
                        k,
                    )
                )
    return out


def _in_mesh_band(k: int, sh: Any, sidebands: int) -> bool:
    teeth = sh.carrier_teeth or ((sh.teeth,) if sh.teeth else ())
    return any(abs(k - round(k / z) * z) <= sidebands and round(k / z) >= 1 for z in teeth)


def _envelope_features(cal: Any, cmp: Any, feats: Any, score: Any, fam_w: float) -> list[_Feature]:
    """Every envelope bin's normalised residual, grouped into defect lines, shaft-rate lines, other lines
    and broadband."""
    out: list[_Feature] = []
    f = np.asarray(cmp.env_f, dtype=float)
    if f.size == 0:
        return out
    defect_hz = []
    for e in getattr(cal, "candidates", ()):
        if hasattr(e, "key_frequencies_hz") and hasattr(cal, "_bearing_shaft_rad_s"):
            defect_hz += e.key_frequencies_hz(cal._bearing_shaft_rad_s(e) / (2.0 * math.pi))
    shaft_hz = [sh.ratio * cmp.speed_hz for sh in cmp.shafts]
    rate_hz = [k * fs for fs in shaft_hz for k in range(1, int(f[-1] / fs) + 2)] if shaft_hz else []
    defect = cmp.line_mask(defect_hz) if defect_hz else np.zeros(f.size, dtype=bool)
    rate = cmp.line_mask(rate_hz) & ~defect if rate_hz else np.zeros(f.size, dtype=bool)
    for c in range(cmp.nc):
        r2 = score.envelope_r2[c] if c < len(score.envelope_r2) else np.zeros(0)
        if r2.size != f.size or not np.any(r2):
            continue
        expect = cmp.envelope_expected(c, cmp.envelope_model(feats, c), cmp.envelope_gain(c, score.gains))
        floor = cmp.envelope_noise_floor(c)
        for i in range(f.size):
            if defect[i]:
                fam = "envelope: bearing-defect lines"
            elif rate[i]:
                fam = "envelope: shaft-rate lines"
            elif r2[i] > 9.0:
                fam = "envelope: other lines"
            else:
                fam = "envelope: broadband"
            fl = float(floor[i]) if floor[i] > 0 else math.inf
            out.append(
                _Feature(
                    cmp.names[c],
                    fam,
                    "",
                    f"{f[i]:.4g} Hz",
                    float(r2[i]),
                    float(r2[i]) * fam_w,
                    float(cmp.d_env[c][i] / fl),
                    float(expect[i] / fl),
                )
            )
    return out


def _static_features(cmp: Any, feats: Any, score: Any, fam_w: float) -> list[_Feature]:
    idx = np.flatnonzero(getattr(cmp, "static_mask", np.zeros(0, dtype=bool)))
    if score.static_r.size != idx.size:
        return []
    out = []
    for c, z in zip(idx, score.static_r, strict=True):
        sd = math.sqrt(cmp.v_static[c]) if cmp.v_static[c] > 0 else math.inf
        out.append(
            _Feature(
                cmp.names[c],
                "channel mean",
                "",
                "mean",
                float(z * z),
                float(z * z) * fam_w,
                float(cmp.d_static[c] / sd),
                float(score.gains[c] * feats.static[c] / sd),
            )
        )
    return out


def trace_residual(
    cal: Any,
    feats: Any,
    score: Any,
    rounds: list[list[dict[str, Any]]],
    claimed: list[str],
    model: np.ndarray,
    error_before: float,
) -> dict[str, Any]:
    """The final residual traced to channels, families and lines (module docstring).

    Parameters
    ----------
    cal : Calibrator
        The calibrator after its search (its comparison, candidates and measurement are read).
    feats : ModelFeatures
        The final model's features (``score`` was computed from them).
    score : Score
        The final score (gains, slopes, time shift, envelope and static residuals).
    rounds : list
        The candidate tables of every round (``candidates_by_round``).
    claimed : list of str
        Labels of the effects claimed.
    model : numpy.ndarray
        The final model's time signals (samples, channels), for the non-synchronous lines.
    error_before : float
        The healthy model's error (``error_before``): whether the error was halved.

    Returns
    -------
    dict
        ``error``, ``shares_by_family``, ``shares_by_channel``, ``components`` (the largest, with their
        dominant feature), ``readings`` (``residual_signatures.reading`` of the largest: pattern, library
        effects and effects outside it), ``claims_suspect`` (claimed effects whose own signature's family
        keeps >= 50 % of the final error without the error halved), ``non_synchronous_lines`` and
        ``consistent`` (the per-family sums equal the score's chi^2). Empty if the score has no family.
    """
    cmp = cal.cmp
    fams = [f for f in score.chi2 if score.n.get(f, 0) > 0]
    e2 = score.error**2
    if not fams or not e2 > 0:
        return {}
    w = {f: 1.0 / (len(fams) * score.n[f] * e2) for f in fams}
    feats_all: list[_Feature] = []
    if "order" in w:
        feats_all += _order_features(cmp, feats, score, w["order"])
    if "envelope" in w:
        feats_all += _envelope_features(cal, cmp, cmp.apply_shift(feats, score.tau), score, w["envelope"])
    if "static" in w:
        feats_all += _static_features(cmp, feats, score, w["static"])
    fam_of = {
        "shaft orders": "order",
        "mesh harmonics": "order",
        "mesh sidebands": "order",
        "channel mean": "static",
    }
    sums: dict[str, float] = {}
    for ft in feats_all:
        key = fam_of.get(ft.family, "envelope")
        sums[key] = sums.get(key, 0.0) + ft.r2
    consistent = all(
        math.isclose(sums.get(f, 0.0), score.chi2[f], rel_tol=1e-6, abs_tol=1e-9 * score.n[f]) for f in fams
    )
    comps: dict[tuple[str, str, str], list[_Feature]] = {}
    for ft in feats_all:
        comps.setdefault((ft.channel, ft.family, ft.shaft), []).append(ft)
    rows = []
    for (ch, fam, shaft), lst in comps.items():
        top = max(lst, key=lambda x: x.r2)
        rows.append(
            {
                "channel": ch,
                "family": fam + (f" ({shaft})" if shaft else ""),
                "share": float(sum(x.share for x in lst)),
                # the part where the record holds more than the model (the model lacks content)
                "model_lacks_share": float(sum(x.share for x in lst if x.model_lacks)),
                "largest_lacking_residual": max((math.sqrt(x.r2) for x in lst if x.model_lacks), default=0.0),
                "n_features": len(lst),
                "largest": {
                    "at": top.where,
                    "measured_over_noise": top.measured,
                    "model_over_noise": top.model,
                    "normalised_residual": math.sqrt(top.r2),
                },
            }
        )
    rows.sort(key=lambda r: -r["share"])
    by_family: dict[str, float] = {}
    by_channel: dict[str, float] = {}
    for r in rows:
        by_family[r["family"]] = by_family.get(r["family"], 0.0) + r["share"]
        by_channel[r["channel"]] = by_channel.get(r["channel"], 0.0) + r["share"]
    halved = score.error <= 0.5 * error_before
    readings = _readings(feats_all, rows, tried_candidates(rounds, claimed), by_family, halved)
    return {
        "error": float(score.error),
        "consistent": bool(consistent),
        "shares_by_family": dict(sorted(by_family.items(), key=lambda kv: -kv[1])),
        "shares_by_channel": dict(sorted(by_channel.items(), key=lambda kv: -kv[1])),
        "model_lacks_share": float(sum(r["model_lacks_share"] for r in rows)),
        "components": rows[:8],
        "readings": readings,
        "claims_suspect": sorted(
            {
                lab
                for rd in readings
                if rd["claim_suspect"]
                for lab, v in rd["library_candidates_tried"].items()
                if v["claimed"]
            }
        ),
        "non_synchronous_lines": _nonsync_lines(cmp, model),
    }


def _readings(
    feats_all: list[_Feature],
    rows: list[dict[str, Any]],
    tried: dict[str, Any],
    by_family: dict[str, float],
    halved: bool,
    n_max: int = 3,
) -> list[dict[str, Any]]:
    """Readings (``residual_signatures.reading``) of the components where the record holds content the
    model lacks: >= 10 % of E^2 in features whose measured amplitude exceeds the model's, the largest of
    them at least ``READING_MIN_RESIDUAL`` sigma out; one per family and shaft, largest first. A shaft's
    low orders and sidebands are read on their 1x-6x profile of those features over every channel (the
    shaft's pattern, not one sensor's). Where the model predicts more than the record holds (a model-form
    misfit, or an effect the machine does not have) nothing is read."""
    out: list[dict[str, Any]] = []
    seen: set[str] = set()
    for row in sorted(rows, key=lambda r: -r["model_lacks_share"]):
        if row["model_lacks_share"] < 0.1 or len(out) >= n_max:
            break
        if row["family"] in seen or row["largest_lacking_residual"] < READING_MIN_RESIDUAL:
            continue
        seen.add(row["family"])
        fam, _, shaft = row["family"].partition(" (")
        shaft = shaft[:-1]
        profile = None
        if fam in ("shaft orders", "mesh sidebands"):
            profile = np.zeros(6)
            for ft in feats_all:
                if ft.family == fam and ft.shaft == shaft and 1 <= ft.order <= 6 and ft.model_lacks:
                    profile[ft.order - 1] += ft.r2
        comp = {**row, "share": row["model_lacks_share"]}
        out.append(reading(comp, profile, tried, by_family.get(row["family"], 0.0), halved))
    return out


def _nonsync_lines(cmp: Any, model: np.ndarray, n_max: int = 5) -> list[dict[str, Any]]:
    """Lines of the measured non-synchronous part 10 x above its local median and 10 x above the model's."""
    if not cmp.shafts or model.size == 0:
        return []
    fs = cmp.fs
    shafts_hz = [sh.ratio * cmp.speed_hz for sh in cmp.shafts]
    n = min(model.shape[0], cmp.y.shape[0])
    nper = int(min(n, max(round(4.0 * fs / min(shafts_hz)), 256)))  # 4 revolutions of the slowest shaft
    lines = []
    for c in range(cmp.nc):
        y = remove_synchronous(cmp.y[:n, c], fs, shafts_hz)
        m = remove_synchronous(model[:n, c], fs, shafts_hz)
        f, py = welch(y, fs, nperseg=nper)
        _, pm = welch(m, fs, nperseg=nper)
        half = 25
        for i in range(half, f.size - half):
            loc = float(np.median(py[i - half : i + half + 1]))
            if loc <= 0 or py[i] < 10.0 * loc or py[i] < 10.0 * pm[i]:
                continue
            if py[i] < py[i - 1] or py[i] < py[i + 1]:
                continue  # the peak bin only
            lines.append(
                {
                    "channel": cmp.names[c],
                    "frequency_hz": float(f[i]),
                    "orders": {sh.name: float(f[i] / h) for sh, h in zip(cmp.shafts, shafts_hz, strict=True)},
                    "over_local_median": float(py[i] / loc),
                    "over_model": float(py[i] / pm[i]) if pm[i] > 0 else math.inf,
                }
            )
    lines.sort(key=lambda x: -x["over_local_median"])
    return lines[:n_max]


def trace_markdown(trace: dict[str, Any]) -> list[str]:
    """The ``--report`` section of the trace (lines of markdown)."""
    if not trace:
        return []
    out = ["", "## Where the remaining residual is (residual trace)", ""]
    out.append(
        f"Final error {trace['error']:.3g}; shares of E^2 by family: "
        + ", ".join(f"{k} {v:.0%}" for k, v in list(trace["shares_by_family"].items())[:6])
    )
    out.append(
        f"Share of E^2 where the record holds more than the model (content the model lacks): "
        f"{trace.get('model_lacks_share', 0.0):.0%}; the rest is where the model predicts more."
    )
    out += [
        "",
        "| channel | family | share of E^2 | of it, model lacks | largest at | measured / noise "
        "| model / noise | r / sigma |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in trace["components"]:
        lg = r["largest"]
        amps = " | ".join(
            f"{lg[k]:.3g}" for k in ("measured_over_noise", "model_over_noise", "normalised_residual")
        )
        lack = f"{r['model_lacks_share']:.1%}"
        out.append(f"| {r['channel']} | {r['family']} | {r['share']:.1%} | {lack} | {lg['at']} | {amps} |")
    for rd in trace.get("readings") or []:
        out += ["", f"**{rd['component']}** ({rd['share']:.0%} of E^2): {rd['reading']}."]
        if rd.get("profile"):
            prof = ", ".join(f"{k} {v:.0%}" for k, v in rd["profile"].items())
            out.append(
                f"Profile over every channel: {prof} (patterns: {', '.join(rd['patterns']) or 'none'})."
            )
        lib = ", ".join(rd["library_effects_with_this_signature"]) or "none"
        out.append(
            f"Library effects with this signature: {lib}. Outside the library: "
            + (", ".join(rd["outside_the_library"]) or "-")
            + "."
        )
    if trace.get("claims_suspect"):
        out += [
            "",
            f"Claims that explain only part of their own signature: {', '.join(trace['claims_suspect'])}.",
        ]
    if trace.get("non_synchronous_lines"):
        out.append("")
    for ln in trace.get("non_synchronous_lines") or []:
        orders = ", ".join(f"{v:.3f} x {k}" for k, v in ln["orders"].items())
        out.append(
            f"- non-synchronous line on {ln['channel']}: {ln['frequency_hz']:.1f} Hz ({orders}), "
            f"{ln['over_local_median']:.3g} x the local median, {ln['over_model']:.3g} x the model"
        )
    return out
