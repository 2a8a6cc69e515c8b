"""A coarser step at high speed? The 20 kHz stream at 24-32 located steps per mesh period against
1024 located steps (docs/solver.md, "Session 10").

Paper gearbox, default reduced basis, the 16 default channels, 15000 / 17500 / 20000 rpm at 25 / 125 /
225 C. Every run starts from the static equilibrium (the same start as the reference) and the
statistics are taken over 0.3-0.5 s of the 20 kHz stream:

* ``rms``: the RMS of the DTE, mean included (the convergence table's and issue 13's criterion, 0.5 %);
* ``fluct``: the fluctuating RMS (standard deviation) of the DTE;
* ``ch rms`` / ``ch fluct``: the worst channel's RMS (mean included) / fluctuating RMS, over the
  channels that fluctuate (fluctuating RMS >= ``MIN_FLUCT`` of the RMS in the reference: the axial
  bearing forces of the spur pair are constant, 0 at 25 C);
* ``spec``: the worst such bearing-force channel's amplitude-spectrum distance (Welch, 1024 samples,
  0-8 kHz: ``sqrt(sum (sqrt(P) - sqrt(P_ref))^2 / sum P_ref)``, phase-free), in % of the reference's
  content in that band;
* ``wave``: the DTE sample by sample (RMS of the difference in % of the reference's fluctuating RMS).

All errors in %, relative to the reference's value. The settings: ``rule`` (the default dt rule:
33.1 steps per mesh period at 20000 rpm, 44.1 at 15000) and ``N`` steps per mesh period
(``steps_per_mesh = N``, ``contact_loss_rate_hz = N f_mesh``: both parts of the rule at N, events
located while the teeth separate) for N = 32, 28, 26 and 24; the actual steps per mesh period are
``k`` times the output rate over the mesh frequency (``k`` whole).

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/convergence_highspeed.py [--json PATH]``
(about 2-4 minutes on one core; ``--speeds``, ``--temperatures``, ``--settings``).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from scipy.signal import welch

from gear_rotor_sim.examples import paper_gearbox
from gear_rotor_sim.simulator import Simulator
from gear_rotor_sim.solver.newmark import mesh_frequency_hz

OUTPUT_RATE_HZ = 20000.0
DURATION_S = 0.5
WINDOW_S = (0.3, 0.5)
REFERENCE = 1024
SETTINGS = (0, 32, 28, 26, 24)  # 0: the default dt rule
MIN_FLUCT = 1e-4
SPEC_BAND_HZ = 8000.0


def _run(rpm: float, temp: float, **kw: object) -> tuple[np.ndarray, tuple[str, ...], float, float]:
    cfg = paper_gearbox()
    sim = Simulator(cfg, rpm, temp, OUTPUT_RATE_HZ, **kw)  # type: ignore[arg-type]
    c0 = time.process_time()
    blocks = [sim.advance(0.1) for _ in range(round(DURATION_S / 0.1))]
    cpu = time.process_time() - c0
    data = np.concatenate([np.asarray(b.data) for b in blocks])
    spm = sim.dt**-1 / mesh_frequency_hz(sim._stepper.system, rpm)
    i0, i1 = (round(w * OUTPUT_RATE_HZ) for w in WINDOW_S)
    return data[i0:i1], sim.channels, spm, cpu


def _rel(a: float, b: float) -> float:
    return 100.0 * (a - b) / b if b else 0.0


def _spec(x: np.ndarray, ref: np.ndarray) -> float:
    f, p = welch(x - x.mean(), OUTPUT_RATE_HZ, nperseg=1024)
    _, pr = welch(ref - ref.mean(), OUTPUT_RATE_HZ, nperseg=1024)
    band = f <= SPEC_BAND_HZ
    return 100.0 * float(np.sqrt(np.sum((np.sqrt(p[band]) - np.sqrt(pr[band])) ** 2) / np.sum(pr[band])))


def compare(y: np.ndarray, ref: np.ndarray, channels: tuple[str, ...]) -> dict:
    """The errors of one stream against the reference (see the module docstring)."""
    d = channels.index("dte")
    rms = np.sqrt(np.mean(y**2, axis=0))
    rms_r = np.sqrt(np.mean(ref**2, axis=0))
    sd, sd_r = y.std(axis=0), ref.std(axis=0)
    live = [i for i in range(len(channels)) if sd_r[i] >= MIN_FLUCT * rms_r[i] > 0]
    ch_rms = {i: _rel(rms[i], rms_r[i]) for i in live}
    ch_sd = {i: _rel(sd[i], sd_r[i]) for i in live}
    bear = [i for i in live if channels[i].startswith("bearing")]
    spec = {i: _spec(y[:, i], ref[:, i]) for i in bear}
    ir = max(ch_rms, key=lambda i: abs(ch_rms[i]))
    iw = max(ch_sd, key=lambda i: abs(ch_sd[i]))
    isp = max(spec, key=lambda i: spec[i])
    return {
        "rms": ch_rms[d],
        "fluct": ch_sd[d],
        "ch_rms": ch_rms[ir],
        "ch_rms_name": channels[ir],
        "ch_fluct": ch_sd[iw],
        "ch_fluct_name": channels[iw],
        "spec": spec[isp],
        "spec_name": channels[isp],
        "wave": 100.0 * float(np.sqrt(np.mean((y[:, d] - ref[:, d]) ** 2)) / sd_r[d]),
        "fluct_over_rms_ref": {channels[i]: float(sd_r[i] / rms_r[i]) for i in live},
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--speeds", default="15000,17500,20000")
    ap.add_argument("--temperatures", default="25,125,225")
    ap.add_argument("--settings", default=",".join(str(s) for s in SETTINGS), help="N; 0: the rule")
    ap.add_argument("--json", default="")
    args = ap.parse_args()
    speeds = [float(s) for s in args.speeds.split(",")]
    temps = [float(s) for s in args.temperatures.split(",")]
    settings = [int(s) for s in args.settings.split(",")]
    out: list[dict] = []
    print(
        f"{'T':>4} {'rpm':>6} {'N':>4} {'spm':>6} {'cpu s':>6} {'rms':>7} {'fluct':>7} {'ch rms':>7} "
        f"{'ch fluct':>8} {'(channel)':>14} {'spec':>6} {'(channel)':>14} {'wave':>6}"
    )
    for temp in temps:
        for rpm in speeds:
            f_mesh = mesh_frequency_hz(Simulator(paper_gearbox(), rpm, temp)._stepper.system, rpm)
            ref, names, spm_r, cpu_r = _run(
                rpm, temp, steps_per_mesh=REFERENCE, contact_loss_rate_hz=None, locate_events=True
            )
            print(f"{temp:4.0f} {rpm:6.0f}  ref {spm_r:6.1f} {cpu_r:6.2f}", flush=True)
            for n in settings:
                kw = {"steps_per_mesh": n, "contact_loss_rate_hz": n * f_mesh} if n else {}
                y, _, spm, cpu = _run(rpm, temp, **kw)
                e = compare(y, ref, names)
                e.update(temp_c=temp, rpm=rpm, n=n, steps_per_mesh=spm, cpu_s=cpu)
                out.append(e)
                print(
                    f"{temp:4.0f} {rpm:6.0f} {n if n else 'rule':>4} {spm:6.1f} {cpu:6.2f} {e['rms']:+7.3f} "
                    f"{e['fluct']:+7.2f} {e['ch_rms']:+7.3f} {e['ch_fluct']:+8.2f} "
                    f"{e['ch_fluct_name']:>14s} {e['spec']:6.2f} {e['spec_name']:>14s} {e['wave']:6.1f}",
                    flush=True,
                )
    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump(out, fh, indent=1)


if __name__ == "__main__":
    main()
