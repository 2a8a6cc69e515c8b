"""Where the error of a record whose speed fluctuates comes from, after order tracking (issue 11;
docs/history/calibration_sessions.md Sec. 8.49).

For each record of ``calibration_speed_variation.py`` named by ``--cases`` (default: the healthy and
the pinion-tooth record at 3000 rpm with the 0.5 % / 2 Hz fluctuation), the record is regenerated
with its noise-free channels and its twin at constant speed (same seed), and the script prints:

1. the **tracking error**: the tracked input angle (``speed_tracking.track_speed``) against the
   generator's true angle ``w0 (t + angle_extra(t))`` (``lumped_gearbox/speed_profile.py``), both less
   their straight line, rms and largest, and the speed's rms error;
2. the **non-synchronous mesh line**: the noisy record resampled to uniform angle along the tracked
   angle (the calibration's path) and along the true one, every shaft's synchronous average removed
   (``features_orders.remove_synchronous``, as the envelope family does): the rms of what is left
   within +-20 Hz of each mesh harmonic, over the rms of the noise band next to it, per channel; the
   constant-speed twin for comparison;
3. the **envelope's low bins**: the squared-envelope spectrum of that non-synchronous part in the
   calibration's band (``--band``, default the healthy record's 1195-2390 Hz) at 10, 20, 30 Hz over
   its median (the noise floor), fluctuating record (tracked, true angle) against the twin;
4. the **physics a fluctuating speed adds**: the mesh fundamental's amplitude through the record
   (demodulated along the true angle, 20 ms Gaussian) regressed on the speed change ``dw`` and the
   angular acceleration ``dw/dt``; the inertia torque's share of the mean mesh force
   ``J2 w2' / (rb2 F_mean)``; the mesh fundamental's amplitude at constant speeds ``w0 (1 +- f)`` (the
   fixed-frequency resonances: the quasi-static modulation).

Usage::

    python benchmarks/speed_variation_trace.py [--out DIR] [--cases TAG ...] [--duration-s S]
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import calibration_speed_variation as sv

from gear_rotor_sim.analysis.signals import analytic_band
from gear_rotor_sim.calibration.features_orders import remove_synchronous
from gear_rotor_sim.calibration.order_tracking import (
    resample_channels,
    resample_to_angle,
    speed_change_on_grid,
)
from gear_rotor_sim.calibration.signal_features import envelope_power_spectrum
from gear_rotor_sim.calibration.speed_estimate import mesh_orders_per_input, slowest_shaft_ratio
from gear_rotor_sim.calibration.speed_modulation import remove_speed_modulated
from gear_rotor_sim.calibration.speed_tracking import refine_track, track_speed
from gear_rotor_sim.config import load_config
from lumped_gearbox import make_record
from lumped_gearbox.params import Gearbox
from lumped_gearbox.speed_profile import angle_extra, relative_speed

DEFAULT_CASES = ["c3000_healthy_fluct0.5at2Hz", "c3000_tooth_pinion_fluct0.5at2Hz"]
CHANNELS = ["dte", "bearing2_fx", "bearing2_fy", "bearing2_fz", "node5_ax", "node5_ay"]


def _detrended(t: np.ndarray, a: np.ndarray) -> np.ndarray:
    c = np.polyfit(t, a, 1)
    return a - np.polyval(c, t)


def _shafts_hz(cfg: Any, rpm: float) -> list[float]:
    ratio = slowest_shaft_ratio(cfg)
    return [rpm / 60.0, ratio * rpm / 60.0]


def _near_mesh_rms(x: np.ndarray, fs: float, f_mesh: float, k_max: int) -> list[float]:
    """Rms within +-20 Hz of each mesh harmonic over the rms of the 40-120 Hz bands beside it."""
    n = x.size
    spec = np.abs(np.fft.rfft(x * np.hanning(n))) ** 2
    f = np.fft.rfftfreq(n, 1.0 / fs)
    out = []
    for k in range(1, k_max + 1):
        fk = k * f_mesh
        if fk > 0.45 * fs:
            break
        near = np.abs(f - fk) <= 20.0
        side = (np.abs(f - fk) >= 40.0) & (np.abs(f - fk) <= 120.0)
        out.append(math.sqrt(spec[near].sum() / max(spec[side].mean() * near.sum(), 1e-300)))
    return out


def _envelope_low_bins(x: np.ndarray, fs: float, band: tuple[float, float]) -> list[float]:
    a = analytic_band(x, fs, band)
    f, p, _ = envelope_power_spectrum(a, fs, 5.0, 400.0, 0.1)
    med = float(np.median(p))
    return [float(p[np.argmin(np.abs(f - fb))] / med) for fb in (10.0, 20.0, 30.0)]


def _amplitude_track(x: np.ndarray, theta: np.ndarray, k: float, fs: float, sigma_s: float) -> np.ndarray:
    """|x exp(-i k theta)| low-passed by a Gaussian of ``sigma_s``: the line's amplitude through time."""
    z = x * np.exp(-1j * k * theta)
    h = np.exp(-0.5 * (np.arange(-int(4 * sigma_s * fs), int(4 * sigma_s * fs) + 1) / (sigma_s * fs)) ** 2)
    h /= h.sum()
    return 2.0 * np.abs(np.convolve(z, h, mode="same"))


def trace(case: sv.VarCase, duration_s: float, band: tuple[float, float]) -> dict[str, Any]:
    prof = dict(sv.PROFILES)[case.profile]
    faults = [case.fault] if case.fault else []
    t0 = time.perf_counter()
    rec = make_record(case.speed_rpm, 25.0, faults, duration_s=duration_s, seed=case.seed, speed_profile=prof)
    twin = make_record(case.speed_rpm, 25.0, faults, duration_s=duration_s, seed=case.seed)
    gen_s = time.perf_counter() - t0
    fs = 1.0 / float(rec.time_s[1] - rec.time_s[0])
    t = rec.time_s - rec.time_s[0]
    cfg = load_config("paper_sun2021")
    orders = mesh_orders_per_input(cfg)
    w0 = case.speed_rpm * math.pi / 30.0
    p = rec.speed_profile.vector(duration_s)
    true_angle = w0 * (rec.time_s + angle_extra(p, rec.time_s))
    true_angle = true_angle - true_angle[0]
    y = np.column_stack([rec.data[c] for c in CHANNELS])
    yc = np.column_stack([rec.clean[c] for c in CHANNELS])
    y_twin = np.column_stack([twin.data[c] for c in CHANNELS])
    t1 = time.perf_counter()
    tr = track_speed(y, fs, case.speed_rpm, orders, slowest_shaft_ratio(cfg))
    track_s = time.perf_counter() - t1
    out: dict[str, Any] = {"case": case.tag, "generate_s": gen_s, "track_s": track_s}
    # 1. tracking error (interior: 2 kernel widths from each end)
    edge = 2.0 * tr.kernel_s
    inner = (t >= edge) & (t <= t[-1] - edge)
    err = _detrended(t, tr.angle_rad) - _detrended(t, true_angle)
    err = err - err[inner].mean()
    true_rpm = case.speed_rpm * relative_speed(p, rec.time_s)
    out["angle_err_rms"] = float(np.sqrt(np.mean(err[inner] ** 2)))
    out["angle_err_max"] = float(np.max(np.abs(err[inner])))
    out["angle_dev_rms"] = float(np.sqrt(np.mean(_detrended(t, true_angle)[inner] ** 2)))
    out["speed_err_rms_rpm"] = float(np.sqrt(np.mean((tr.speed_rpm - true_rpm)[inner] ** 2)))
    out["channel_delay_ms"] = [
        1e3 * float(d) for d in (tr.channel_delay_s if tr.channel_delay_s is not None else [])
    ]
    # 2./3. non-synchronous part after resampling (tracked / true angle), and the constant-speed twin
    sh = _shafts_hz(cfg, tr.mean_rpm)
    grid = np.linspace(true_angle[0], true_angle[-1], y.shape[0])
    t2 = time.perf_counter()
    refined = refine_track(y, fs, tr, orders)
    out["refine_s"] = time.perf_counter() - t2
    u3 = speed_change_on_grid(tr, y.shape[0])
    u_ref = speed_change_on_grid(refined, y.shape[0])
    u_true = np.interp(grid, true_angle, relative_speed(p, rec.time_s))
    u_true = u_true / u_true.mean() - 1.0
    x3 = resample_channels(y, tr)
    xt = resample_to_angle(y, true_angle, grid)
    # (data, speed change whose synchronous response is removed or None, shaft rates)
    sh0 = _shafts_hz(cfg, case.speed_rpm)
    variants = {
        "tracked, 3 passes (session 18)": (x3, None, sh),
        "tracked, 3 passes, u D removed": (x3, u3, sh),
        "refined, u D removed (this code)": (
            resample_channels(y, refined),
            u_ref,
            _shafts_hz(cfg, refined.mean_rpm),
        ),
        "true angle": (xt, None, sh),
        "true angle, u D removed (true u)": (xt, u_true, sh),
        "true angle, clean": (resample_to_angle(yc, true_angle, grid), None, sh),
        "constant-speed twin": (y_twin, None, sh0),
    }
    out["near_mesh"] = {}
    out["env_low"] = {}
    for name, (data, u, shz) in variants.items():
        rows = {}
        env = {}
        fm = orders[0] * shz[0]
        for c, ch in enumerate(CHANNELS):
            ns = remove_synchronous(data[:, c], fs, shz)
            if u is not None:
                ns = remove_speed_modulated(ns, fs, shz, u)
            rows[ch] = _near_mesh_rms(ns, fs, fm, 3)
            if ch in ("bearing2_fx", "bearing2_fy"):
                env[ch] = _envelope_low_bins(ns, fs, band)
        out["near_mesh"][name] = rows
        out["env_low"][name] = env
    # 4. physics: the mesh fundamental's amplitude through the record, clean channels, true angle
    dw = w0 * (relative_speed(p, rec.time_s) - 1.0)
    acc = np.gradient(dw, 1.0 / fs)
    phys = {}
    for c, ch in enumerate(CHANNELS):
        amp = _amplitude_track(yc[:, c], true_angle, float(orders[0]), fs, 0.02)
        if not np.mean(amp) > 0:
            continue  # a channel without the line (the axial force of an aligned gearbox)
        sel = inner
        a = np.column_stack([np.ones(sel.sum()), dw[sel], acc[sel]])
        coef, *_ = np.linalg.lstsq(a, amp[sel], rcond=None)
        fit = a @ coef
        r2 = 1.0 - np.sum((amp[sel] - fit) ** 2) / max(np.sum((amp[sel] - amp[sel].mean()) ** 2), 1e-300)
        phys[ch] = {
            "am_pct_rms": 100.0 * float(np.std(amp[sel]) / np.mean(amp[sel])),
            "per_pct_speed": float(coef[1] * w0 / 100.0 / np.mean(amp[sel]) * 100.0),
            "per_acc_pct": float(coef[2] * float(np.max(np.abs(acc))) / np.mean(amp[sel]) * 100.0),
            "r2": float(r2),
        }
    out["am"] = phys
    gb = Gearbox()
    _, _, _, j2 = gb.masses()
    rb2 = gb.base_radii[1]
    f_mean = float(np.mean(rec.clean["mesh_force"]))
    # the gear's angular acceleration is the input's times z1 / z2 (model.py: +psi'' z1 / z2)
    out["inertia_force_pct"] = (
        100.0 * j2 * float(np.max(np.abs(acc))) * slowest_shaft_ratio(cfg) / rb2 / f_mean
    )
    return out


def _rows(title: str, table: dict[str, dict[str, list[float]]]) -> None:
    print(title)
    for name, rows in table.items():
        cells = "; ".join(f"{ch} " + "/".join(f"{v:.3g}" for v in vals) for ch, vals in rows.items())
        print(f"  {name}: {cells}")


def _report(tag: str, r: dict[str, Any]) -> None:
    print(
        f"## {tag} (generate {r['generate_s']:.1f} s, track {r['track_s']:.2f} s, "
        f"refine {r['refine_s']:.2f} s)"
    )
    delays = ", ".join(f"{d:.3f}" for d in r["channel_delay_ms"])
    print(
        f"tracking (3 passes): angle off uniform {r['angle_dev_rms']:.3g} rad rms; tracked - true "
        f"{r['angle_err_rms']:.2g} rad rms (max {r['angle_err_max']:.2g}); speed "
        f"{r['speed_err_rms_rpm']:.3g} rpm rms; channel delays ms {delays}"
    )
    print(f"inertia force J2 w2' z1/z2 / rb2, largest: {r['inertia_force_pct']:.3g} % of the mean mesh force")
    _rows("non-synchronous rms within +-20 Hz of mesh x1/x2/x3 over the noise beside it:", r["near_mesh"])
    _rows("envelope of the non-synchronous part, bins 10/20/30 Hz over the median:", r["env_low"])
    print("mesh x1 amplitude (clean, true angle): AM rms, per % of speed, at the largest acceleration, R^2:")
    for ch, v in r["am"].items():
        print(
            f"  {ch}: {v['am_pct_rms']:.3g} %, {v['per_pct_speed']:+.3g} % per %, "
            f"{v['per_acc_pct']:+.3g} %, R2 {v['r2']:.2f}"
        )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", nargs="*", default=DEFAULT_CASES)
    ap.add_argument("--duration-s", type=float, default=2.0)
    ap.add_argument("--band", nargs=2, type=float, default=[1195.0, 2390.0])
    args = ap.parse_args(argv)
    allc = {c.tag: c for c in sv.cases()}
    for tag in args.cases:
        r = trace(allc[tag], args.duration_s, tuple(args.band))
        _report(tag, r)
        sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
