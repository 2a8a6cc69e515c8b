"""Aliasing of the point-sampled channels on the integration grid (docs/solver.md, "Session 10").

The channels reach the decimator as samples at the end of each integration step. Where a signal has
jumps (the mesh force at the table jumps and impacts; with the reduced basis every channel through
the dropped modes' static part), its high harmonics fold into the output band at
``|n f_mesh - m f_raw|`` in the sampling itself, which no decimation filter removes.

Part 1 (``--speeds``): spectra of the 20 kHz stream of the default rule, as it is and with
``Simulator(event_average=True)``, against the same model at 1024 located steps per mesh period
(25 C, 0.3-0.5 s from the static equilibrium, Hann window): per channel the largest line of the
reference and the largest line of the rule's stream that the reference does not hold (below a
tenth of it there), the fluctuating RMS and the sample-by-sample difference (in % of the
reference's fluctuating RMS); the RMS DTE error in %.

Part 2 (``--box``): one converged trajectory at 20000 rpm (1024 located steps per mesh period, raw
samples at 31 x 320 kHz) put onto the rule's 320 kHz grid three ways, end-of-step samples, averages
over each step and the mean of each step's two end values, then decimated by the same k = 16 FIR:
the 1000 Hz fold (``33 f_mesh - 320 kHz``) of the mesh force in each.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/alias_highspeed.py [--speeds 20000,14000,7000,3000]
[--box]`` (about 1 minute per speed, 1 minute for ``--box`` on one core).
"""

from __future__ import annotations

import argparse

import numpy as np
from convergence_highspeed import _run

from gear_rotor_sim.examples import paper_gearbox
from gear_rotor_sim.simulator import Simulator
from gear_rotor_sim.solver.decimate import design_taps, fir_decimate

OUTPUT_RATE_HZ = 20000.0
CHANNELS = ("mesh_force", "bearing2_fx", "dte")


def amplitude_spectrum(y: np.ndarray, rate_hz: float = OUTPUT_RATE_HZ) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies and line amplitudes (Hann window, amplitude-corrected) of ``y`` minus its mean."""
    y = y - y.mean()
    return np.fft.rfftfreq(y.size, 1.0 / rate_hz), np.abs(np.fft.rfft(y * np.hanning(y.size))) * 4.0 / y.size


def spurious_lines(rpm: float) -> None:
    """Part 1 at one speed: the rule as it is, and with ``Simulator(event_average=True)``."""
    ref, names, _, _ = _run(rpm, 25.0, steps_per_mesh=1024, contact_loss_rate_hz=None, locate_events=True)
    for label, kw in (("rule", {}), ("rule, event_average", {"event_average": True})):
        y, _, spm, cpu = _run(rpm, 25.0, **kw)
        d = names.index("dte")
        rms_err = 100.0 * (np.sqrt(np.mean(y[:, d] ** 2)) / np.sqrt(np.mean(ref[:, d] ** 2)) - 1.0)
        print(f"{rpm:6.0f} rpm, {label} ({spm:5.1f} steps/mesh): RMS DTE {rms_err:+.3f} %, CPU {cpu:.2f} s")
        for ch in CHANNELS:
            i = names.index(ch)
            f, r = amplitude_spectrum(ref[:, i])
            _, a = amplitude_spectrum(y[:, i])
            spur = np.where(r < 0.1 * a, a, 0.0)
            j, m = int(np.argmax(spur)), int(np.argmax(r))
            ratio = y[:, i].std() / ref[:, i].std()
            wave = np.sqrt(np.mean((y[:, i] - ref[:, i]) ** 2)) / ref[:, i].std()
            print(
                f"    {ch:12s} reference's largest line {r[m]:.3g} at {f[m]:.0f} Hz; the largest line "
                f"absent from it {a[j]:.3g} at {f[j]:.0f} Hz (ratio {a[j] / r[m]:.3f}); fluctuating RMS / "
                f"reference's {ratio:.3f}; sample by sample {100 * wave:.1f} % of it",
                flush=True,
            )


def box_average() -> None:
    """Part 2."""
    m, k = 31, 16
    raw_hz = 320000.0
    sim = Simulator(
        paper_gearbox(), 20000.0, 25.0, raw_hz * m, channels=["mesh_force", "dte"],
        steps_per_mesh=1024, contact_loss_rate_hz=None, locate_events=True,
    )  # fmt: skip
    sim.advance(0.3)
    x = np.asarray(sim.advance(0.2).data)  # the fine raw samples (k = 1: no filter)
    x = x[: (x.shape[0] // (m * k)) * m * k]
    end = x[m - 1 :: m]
    ways = {
        "end of step": end,
        "step average": x.reshape(-1, m, x.shape[1]).mean(axis=1),
        "mean of the two ends": 0.5 * (np.vstack([end[:1], end[:-1]]) + end),
    }
    h = design_taps(k)
    d = (h.size - 1) // 2
    for name, r in ways.items():
        y = fir_decimate(r, h, d, k, (r.shape[0] - 2 * d) // k)[8:-8, 0]
        f, a = amplitude_spectrum(y)
        at = {hz: float(a[np.abs(f - hz) <= 2.5 * (f[1] - f[0])].max()) for hz in (1000.0, 9666.7)}
        print(
            f"mesh force, {name:22s}: 1000 Hz line {at[1000.0]:.3g} N, mesh line {at[9666.7]:.3g} N, "
            f"fluctuating RMS {y.std():.3g} N",
            flush=True,
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--speeds", default="20000,14000,7000,3000")
    ap.add_argument("--box", action="store_true", help="part 2 only")
    args = ap.parse_args()
    if args.box:
        box_average()
        return
    for rpm in (float(v) for v in args.speeds.split(",") if v):
        spurious_lines(rpm)


if __name__ == "__main__":
    main()
