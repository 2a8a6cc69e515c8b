"""The gain-modulation check's statistic on saved records: where it would fire (issue 11).

For every ``*.csv`` (with its ``.yaml`` sidecar) in the given directories and the 4 CWRU files when present,
load the record as ``gear-rotor-sim calibrate`` does and print per record the channel whose slow relative gain
stands out most (``calibration/gain_modulation.py``: ``chi2_n`` of the common gain over its noise, its rms
depth, the carriers that resolve it with their correlation), the largest share another channel carries of it,
and the channels the check would divide out; besides, for each pair of x and y channels at one place
(``node5_ax`` / ``node5_ay``), the ratio y / x of their mesh-harmonic amplitudes (Hann window, harmonics 1-3
below 0.45 fs, power-weighted): what an exchange of x and y or a sensitivity x2 would move. Optionally each
record again with a gain modulation ``1 + depth sin(2 pi hz t + 0.4)`` put on one column (``--modulate
COLUMN``), to read the check's power, and (``--model-xy``) the same ratios of the healthy FE model at each
record's operating point (0.5 s after 0.15 s from rest).
Docs: docs/history/calibration_sessions.md Sec. 8.50.

Usage::

    python benchmarks/sensor_transfer_stats.py DIR [DIR ...] [--no-cwru | --cwru-dir DIR] [--modulate COLUMN]
        [--depth 0.08] [--model-xy]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from gear_rotor_sim.calibration import gain_modulation as gm
from gear_rotor_sim.calibration.channel_conventions import DYNAMIC_ONLY
from gear_rotor_sim.calibration.measurement import Measurement, load_measurement
from gear_rotor_sim.config import load_config
from gear_rotor_sim.system import shaft_speed_ratios


def slowest_shaft_hz(m: Measurement) -> float:
    """The slowest shaft's rate (Hz) of the record's rig at its declared speed."""
    cfg = load_config(m.gearbox)
    ratios = np.abs(np.asarray(shaft_speed_ratios(cfg), float))
    return float(ratios.min()) * m.operating_point.speed_rpm / 60.0


def xy_ratios(data: np.ndarray, columns: list[str], fs: float, f_mesh: float) -> dict[str, float]:
    """y / x amplitude ratio at the mesh harmonics of each ``<place>_?x`` / ``<place>_?y`` column pair."""
    n = data.shape[0]
    f = np.fft.rfftfreq(n, 1.0 / fs)
    win = np.hanning(n)
    bins = [int(np.argmin(np.abs(f - h * f_mesh))) for h in (1, 2, 3) if h * f_mesh < 0.45 * fs]

    def line_power(k: int) -> float:
        spec = np.abs(np.fft.rfft((data[:, k] - data[:, k].mean()) * win)) ** 2
        return float(sum(spec[i - 2 : i + 3].sum() for i in bins))

    out = {}
    for kx, cx in enumerate(columns):
        cy = cx[:-1] + "y"
        if cx.endswith("x") and cy in columns:
            out[cx.rsplit("_", 1)[0]] = float(np.sqrt(line_power(columns.index(cy)) / line_power(kx)))
    return out


def model_xy(m: Measurement) -> dict[str, float]:
    """:func:`xy_ratios` of the healthy FE model at ``m``'s operating point (0.5 s after 0.15 s)."""
    from gear_rotor_sim.simulator import Simulator

    cfg = load_config(m.gearbox)
    op = m.operating_point
    sim = Simulator(
        cfg,
        speed_rpm=op.speed_rpm,
        temperature_c=op.temperature_c,
        output_rate_hz=m.sample_rate_hz,
        channels=list(m.model_channels),
    )
    sim.advance(0.15)
    block = sim.advance(0.5)
    return xy_ratios(np.asarray(block.data), [c.column for c in m.channels], m.sample_rate_hz, mesh_hz(m))


def mesh_hz(m: Measurement) -> float:
    """The first mesh's frequency (Hz) at the declared speed."""
    cfg = load_config(m.gearbox)
    mesh = cfg.meshes[0]
    ratio = abs(float(shaft_speed_ratios(cfg)[cfg.shaft_of_node(cfg.gear(mesh.pinion).node0)]))
    return ratio * m.operating_point.speed_rpm / 60.0 * mesh.pinion_teeth


def row(name: str, m: Measurement, model: bool = False) -> str:
    """One record's line: the most prominent channel's statistic and what the check does."""
    f_slow = slowest_shaft_hz(m)
    cols = [c.column for c in m.channels]
    static = [c.quantity not in DYNAMIC_ONLY for c in m.channels]
    fs = m.sample_rate_hz
    gains = [gm.channel_gain(m.data[:, k], fs, 0.5 * f_slow, static[k]) for k in range(len(cols))]
    k = max(range(len(cols)), key=lambda i: gains[i].chi2_n)
    g = gains[k]
    shares = [gm.shared_fraction(g, h) for i, h in enumerate(gains) if i != k]
    seen = [b for b, s in shares if s <= gm.BETA_SIGMA_MAX]
    resolved = ", ".join(f"{n} {rho:+.2f}" for n, c2, rho in g.carriers if c2 >= gm.RESOLVE_CHI2) or "-"
    fix = gm.gain_modulation_fix(m.data, cols, m.sample_rate_hz, f_slow, static)
    ratios = xy_ratios(m.data, cols, fs, mesh_hz(m)) if load_config(m.gearbox).meshes else {}
    text = ", ".join(f"{p} {r:.2f}" for p, r in ratios.items()) or "-"
    if model and ratios:
        text += " (FE model: " + ", ".join(f"{p} {r:.2f}" for p, r in model_xy(m).items()) + ")"
    return (
        f"| {name} | {cols[k]} | {g.chi2_n:.3g} | {100 * g.depth:.3g} | {resolved} | "
        f"{max(seen) if seen else float('nan'):.2f} | {', '.join(cols[i] for i in fix.channels) or '-'} | "
        f"{text} |"
    )


def modulated(m: Measurement, column: str, depth: float, hz: float = 3.7) -> Measurement:
    """``m`` with ``column`` times ``1 + depth sin(2 pi hz t + 0.4)``."""
    k = [c.column for c in m.channels].index(column)
    t = np.arange(m.data.shape[0]) / m.sample_rate_hz
    m.data = np.array(m.data, copy=True)
    m.data[:, k] = m.data[:, k] * (1.0 + depth * np.sin(2.0 * np.pi * hz * t + 0.4))
    return m


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dirs", nargs="*", help="directories of CSV records with sidecars")
    ap.add_argument("--no-cwru", action="store_true", help="leave out the 4 CWRU files")
    ap.add_argument("--cwru-dir", help="the CWRU files (default: ../shared/data/cwru of the repository)")
    ap.add_argument("--modulate", metavar="COLUMN", help="put a gain modulation on this column first")
    ap.add_argument("--depth", type=float, default=0.08, help="its depth (default 0.08)")
    ap.add_argument("--model-xy", action="store_true", help="also the healthy FE model's y / x ratios")
    args = ap.parse_args(argv)
    print(
        "| record | channel (largest chi2_n) | chi2_n | depth (% rms) | carriers resolving it "
        "(correlation) | largest share on another channel | divided out | x/y pairs: y / x at the mesh "
        "harmonics |"
    )
    print("|---|---|---|---|---|---|---|---|")
    t0 = time.process_time()
    n = 0
    for d in args.dirs:
        for csv in sorted(Path(d).glob("*.csv")):
            if not csv.with_suffix(".yaml").exists():
                continue
            m = load_measurement(csv)
            if args.modulate:
                if args.modulate not in [c.column for c in m.channels]:
                    continue
                m = modulated(m, args.modulate, args.depth)
            print(row(f"{Path(d).name}/{csv.stem}", m, args.model_xy), flush=True)
            n += 1
    if not args.no_cwru and not args.modulate:
        from gear_rotor_sim.calibration.cwru import CWRU_FILES, cwru_data_dir, load_cwru

        data = Path(args.cwru_dir) if args.cwru_dir else cwru_data_dir(Path(__file__).resolve().parents[1])
        for name in CWRU_FILES:
            if (data / name).exists():
                print(row(f"cwru/{name}", load_cwru(data / name)), flush=True)
                n += 1
    print(f"\n{n} records, {time.process_time() - t0:.1f} s CPU.", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
