"""The same linear rotor (one shaft, no mesh) integrated by ROSS and by us: steps per second and response.

Run from the repository root in the project venv::

    .venv/bin/python benchmarks/bench_ross.py [--ross-python /tmp/ross-venv/bin/python] [--repeats 5]

ROSS is never installed into the project venv. The ROSS side (``benchmarks/_ross_side.py``) runs in a
separate interpreter (default ``/tmp/ross-venv/bin/python``, or ``$ROSS_PYTHON``); without it only our
side is measured and the script says why and how to install ROSS.

Model (both codes, built independently from the same numbers): a uniform solid steel shaft
(0.5 m, 20 mm, 10 Timoshenko elements, Cowper shear coefficient, stiffness-proportional shaft damping
``beta``), one rigid disc (100 mm x 20 mm) at node 6, two isotropic bearings at the shaft ends
(k = 1e8 N/m radial and axial, c = 1e3 N s/m, no tilt stiffness), spin 3000 rpm with the gyroscopic
terms, and a rotating force ``F0 (cos W t, sin W t)`` at the disc (an unbalance of 1e-4 kg m).
Both integrate with Newmark average acceleration (beta = 1/4, gamma = 1/2) at the same dt for the same
number of steps. See docs/bench_ross.md for the method and the measured numbers.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from gear_rotor_sim.examples import single_rotor
from gear_rotor_sim.simulator import Simulator
from gear_rotor_sim.solver.newmark import (
    LinearModel,
    NewmarkStepper,
    StepContext,
    parse_channels,
    static_equilibrium,
)
from gear_rotor_sim.system import GearRotorSystem
from gear_rotor_sim.system_data import AssembledSystem

HERE = Path(__file__).resolve().parent
ROSS_SIDE = HERE / "_ross_side.py"
DEFAULT_ROSS_PYTHON = "/tmp/ross-venv/bin/python"
INSTALL_HINT = (
    "python3 -m venv /tmp/ross-venv && /tmp/ross-venv/bin/pip install ross-rotordynamics 'plotly<7'\n"
    "  (ross-rotordynamics 2.3.0 does not import with plotly 7: its theme uses the removed trace type\n"
    "  'scattermapbox' -> ValueError; pinning plotly<7 fixes it. Never install ROSS into .venv.)"
)

# ------------------------------------------------------------------------------------------ the case
LENGTH_M = 0.5
DIAMETER_M = 0.02
N_ELEMENTS = 10
DISC_NODE = 6  # 1-based (midspan)
DISC_OUTER_DIAMETER_M = 0.1
DISC_WIDTH_M = 0.02
K_BEARING = 1.0e8  # N/m, radial and axial
C_BEARING = 1.0e3  # N s/m, radial and axial
RAYLEIGH_BETA_S = 5.0e-4  # shaft C = beta K (same in ROSS: ShaftElement(beta=...))
SPEED_RPM = 3000.0
UNBALANCE_KG_M = 1.0e-4
TEMPERATURE_C = 25.0
DT_S = 1.0e-5
N_STEPS = 40_000
COMPARE_FROM_S = 0.3  # transient (slowest mode ~ 80 /s decay) is below 1e-9 by then


class RotatingForce:
    """Effect: a rotating force ``F0 (cos W t, sin W t)`` on x, y of one node (unbalance-like)."""

    name = "rotating_force"

    def __init__(self, node0: int, force_n: float, omega: float) -> None:
        self.node0 = node0
        self.force_n = force_n
        self.omega = omega

    def external_forces(self, system: AssembledSystem) -> np.ndarray:
        cols = np.zeros((system.ndof, 2))
        cols[6 * self.node0, 0] = 1.0
        cols[6 * self.node0 + 1, 1] = 1.0
        return cols

    def force_amplitudes(self, ctx: StepContext) -> np.ndarray:
        wt = self.omega * np.asarray(ctx.t)
        return self.force_n * np.column_stack([np.cos(wt), np.sin(wt)])

    def mesh_stiffness_factor(self, ctx: StepContext) -> None:
        return None

    def transmission_error(self, ctx: StepContext) -> None:
        return None

    def modify_config(self, cfg: Any) -> Any:
        return cfg


def case_config() -> Any:
    return single_rotor(
        LENGTH_M,
        DIAMETER_M,
        N_ELEMENTS,
        k_radial_n_per_m=K_BEARING,
        k_axial_n_per_m=K_BEARING,
        c_radial_ns_per_m=C_BEARING,
        c_axial_ns_per_m=C_BEARING,
        disc_node=DISC_NODE,
        disc_outer_diameter_m=DISC_OUTER_DIAMETER_M,
        disc_width_m=DISC_WIDTH_M,
        rayleigh_stiffness_s=RAYLEIGH_BETA_S,
        reference_temperature_c=TEMPERATURE_C,
    )


def omega_rad_s() -> float:
    return SPEED_RPM * 2.0 * np.pi / 60.0


def force_n() -> float:
    return UNBALANCE_KG_M * omega_rad_s() ** 2


# ---------------------------------------------------------------------------------------- our side
def run_raw(stepper: NewmarkStepper, system: AssembledSystem, effect: RotatingForce) -> np.ndarray:
    """Raw runner: NewmarkStepper.run at exactly DT_S (exact speed in the gyroscopic term), every step."""
    omega = omega_rad_s()
    st = static_equilibrium(system, (effect,))
    stepper.set_operating_point(omega, DT_S, st)
    outs = [np.zeros((1, len(stepper.specs)))]  # state at t = 0 (static equilibrium: zero)
    done = 0
    while done < N_STEPS:
        n = min(65536, N_STEPS - done)
        j = np.arange(done, done + n + 2, dtype=float)
        t = j * DT_S
        ch = stepper.run(t, omega * t, np.full(j.size, omega), st)[0]
        outs.append(ch)
        done += n
    return np.concatenate(outs)


def our_side(repeats: int) -> dict[str, Any]:
    cfg = case_config()
    omega = omega_rad_s()
    node0 = DISC_NODE - 1
    effect = RotatingForce(node0, force_n(), omega)
    names = [f"node{DISC_NODE}_x", f"node{DISC_NODE}_y"]

    t0 = time.perf_counter()
    system = GearRotorSystem.from_config(cfg, TEMPERATURE_C)
    assembly_s = time.perf_counter() - t0
    specs = parse_channels(system, names)

    # warm-up: numba kernels (cache=True, so usually a load from the on-disk cache)
    t0 = time.perf_counter()
    stepper = NewmarkStepper(system, specs, (effect,))
    st = static_equilibrium(system, (effect,))
    stepper.set_operating_point(omega, DT_S, st)
    j = np.arange(0, 64, dtype=float) * DT_S
    stepper.run(j, omega * j, np.full(j.size, omega), st)
    warmup_s = time.perf_counter() - t0

    # set-up cost of our method (what is factorised once): LinearModel + eigenbasis + step map
    setup = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        s2 = NewmarkStepper(system, specs, (effect,))
        s2.set_operating_point(omega, DT_S, static_equilibrium(system, (effect,)))
        setup.append(time.perf_counter() - t0)

    raw_walls = []
    y_raw = np.zeros(0)
    for _ in range(repeats):
        t0 = time.perf_counter()
        y_raw = run_raw(stepper, system, effect)
        raw_walls.append(time.perf_counter() - t0)

    # streaming Simulator: gearless rotor -> fixed decimation 4, so output rate = 1 / (4 DT_S)
    out_rate = 1.0 / (4.0 * DT_S)
    sim_walls, sim_build, sim_steps = [], [], []
    y_sim = np.zeros(0)
    for _ in range(repeats):
        t0 = time.perf_counter()
        sim = Simulator(
            cfg,
            speed_rpm=SPEED_RPM,
            temperature_c=TEMPERATURE_C,
            output_rate_hz=out_rate,
            channels=names,
            effects=(effect,),
        )
        sim_build.append(time.perf_counter() - t0)
        if abs(sim.dt - DT_S) > 1e-15:
            raise RuntimeError(f"Simulator chose dt = {sim.dt:g} s, expected {DT_S:g} s")
        t0 = time.perf_counter()
        blk = sim.advance(N_STEPS * DT_S)
        sim_walls.append(time.perf_counter() - t0)
        sim_steps.append(int(sim.last_chunk_stats["steps"]))
        y_sim = np.asarray(blk.data)

    lin = LinearModel(system, np.zeros((system.ndof, 2)))
    ours_mats = {
        "M": lin.M,
        "K": lin.K,
        "D": lin.C + omega * lin.G,
        "C": lin.C,
        "G": lin.G,
        "force_dofs": np.array([lin.pos[6 * node0], lin.pos[6 * node0 + 1]]),
        "free": lin.free,
    }
    # frequency-domain steady state of our model (the same Omega as in the runs)
    dyn = lin.K - omega**2 * lin.M + 1j * omega * (lin.C + omega * lin.G)
    rhs = np.zeros(lin.nfree, complex)
    ix, iy = ours_mats["force_dofs"]
    rhs[ix], rhs[iy] = force_n(), -1j * force_n()
    x_ss = np.linalg.solve(dyn, rhs)[[ix, iy]]
    return {
        "assembly_s": assembly_s,
        "warmup_s": warmup_s,
        "setup_walls": setup,
        "raw_walls": raw_walls,
        "sim_build_walls": sim_build,
        "sim_walls": sim_walls,
        "sim_steps": sim_steps,
        "y_raw": y_raw,
        "y_sim": y_sim,
        "sim_rate_hz": out_rate,
        "mats": ours_mats,
        "x_ss": x_ss,
        "system": system,
    }


# --------------------------------------------------------------------------------------- ROSS side
def ross_available(py: str) -> tuple[bool, str]:
    if not (Path(py).exists() or shutil.which(py)):
        return False, f"{py} does not exist"
    r = subprocess.run(
        [py, "-c", "import ross; print(ross.__version__)"], capture_output=True, text=True, timeout=300
    )
    if r.returncode != 0:
        tail = "\n".join(r.stderr.strip().splitlines()[-3:])
        return False, f"'import ross' fails in {py}:\n{tail}"
    return True, r.stdout.strip().splitlines()[-1]


def ross_side(py: str, ours: dict[str, Any], repeats: int, threads: int | None) -> tuple[dict, Any]:
    params = {
        "length_m": LENGTH_M,
        "diameter_m": DIAMETER_M,
        "n_elements": N_ELEMENTS,
        "disc_node0": DISC_NODE - 1,
        "disc_outer_diameter_m": DISC_OUTER_DIAMETER_M,
        "disc_width_m": DISC_WIDTH_M,
        "k_radial": K_BEARING,
        "c_radial": C_BEARING,
        "k_axial": K_BEARING,
        "c_axial": C_BEARING,
        "bearing_nodes0": [0, N_ELEMENTS],
        "rayleigh_stiffness_s": RAYLEIGH_BETA_S,
        "omega": omega_rad_s(),
        "force_n": force_n(),
        "dt": DT_S,
        "n_steps": N_STEPS,
        "repeats": repeats,
    }
    m = case_config().materials["carbon_steel"]  # constants at the run temperature, as our elements use
    params.update(
        density=float(m.density),
        youngs_modulus=float(m.youngs_modulus(TEMPERATURE_C)),
        shear_modulus=float(m.shear_modulus(TEMPERATURE_C)),
    )
    env = dict(os.environ)
    if threads is not None:
        for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
            env[k] = str(threads)
    with tempfile.TemporaryDirectory(prefix="bench_ross_") as tmp:
        pj, po, pr = Path(tmp, "params.json"), Path(tmp, "ours.npz"), Path(tmp, "ross.npz")
        pj.write_text(json.dumps(params))
        np.savez(po, **ours["mats"])
        r = subprocess.run(
            [py, str(ROSS_SIDE), str(pj), str(po), str(pr)],
            capture_output=True,
            text=True,
            env=env,
            timeout=3600,
        )
        if r.returncode != 0:
            raise RuntimeError(f"ROSS side failed:\n{r.stderr[-3000:]}")
        info = json.loads(r.stdout.strip().splitlines()[-1])
        with np.load(pr) as z:
            data = {k: z[k] for k in z.files}
    return info, data


# ------------------------------------------------------------------------------------------ report
def med(x: list[float]) -> float:
    return float(np.median(x))


def rel_diff(a: np.ndarray, b: np.ndarray) -> float:
    """max |a - b| / max |b| (both x and y of the disc)."""
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def bending_frequencies_hz(m: np.ndarray, k: np.ndarray, dofs: np.ndarray, n: int) -> np.ndarray:
    """Lowest undamped frequencies of the sub-model on ``dofs`` (one bending plane), Hz."""
    import scipy.linalg as sla

    ix = np.ix_(dofs, dofs)
    w2 = sla.eigh(k[ix], m[ix], eigvals_only=True)
    f = np.sqrt(np.clip(w2, 0, None)) / (2 * np.pi)
    return f[:n]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--ross-python", default=os.environ.get("ROSS_PYTHON", DEFAULT_ROSS_PYTHON))
    ap.add_argument("--repeats", type=int, default=5, help="timed runs per variant (median reported, >= 3)")
    ap.add_argument(
        "--threads",
        type=int,
        default=0,
        help="BLAS/OpenMP threads of the ROSS interpreter (0: leave the environment alone)",
    )
    args = ap.parse_args()
    repeats = max(3, args.repeats)
    ours_repeats = max(15, 3 * repeats)  # a run of ours lasts ~20 ms: more repeats against load bursts
    print(
        f"case: {N_ELEMENTS} Timoshenko elements, disc at node {DISC_NODE}, 2 bearings, {SPEED_RPM:g} rpm, "
        f"F0 = {force_n():.4g} N rotating, dt = {DT_S:g} s, {N_STEPS} steps; medians of {ours_repeats} "
        f"runs (ours) and {repeats} runs (ROSS)"
    )
    print(
        f"machine: {platform.machine()} {os.cpu_count()} cpus, python {platform.python_version()}, "
        f"numpy {np.__version__}"
    )

    ours = our_side(ours_repeats)
    ok, why = ross_available(args.ross_python)
    rows: list[tuple[str, float, str]] = []
    rate_raw = N_STEPS / med(ours["raw_walls"])
    rate_sim = med(ours["sim_steps"]) / med(ours["sim_walls"])
    setup_ms, asm_ms = med(ours["setup_walls"]) * 1e3, ours["assembly_s"] * 1e3
    rows.append(
        (
            "ours: NewmarkStepper.run (raw, every step output)",
            rate_raw,
            f"set-up {setup_ms:.1f} ms (assembly {asm_ms:.1f} ms), warm-up {ours['warmup_s']:.2f} s",
        )
    )
    rows.append(
        (
            "ours: Simulator.advance (streaming, FIR-decimated /4)",
            rate_sim,
            f"construction {med(ours['sim_build_walls']) * 1e3:.1f} ms",
        )
    )
    if not ok:
        print(f"\nROSS side skipped: {why}\nInstall it outside the project venv:\n  {INSTALL_HINT}")
        for name, rate, note in rows:
            print(f"{name:58s} {rate:14,.0f} steps/s  {note}")
        return 0

    print(f"ROSS: {why} ({args.ross_python})")
    info, rd = ross_side(args.ross_python, ours, repeats, args.threads or None)
    rate_rtr = N_STEPS / med(info["walls_run_time_response_newmark"])
    rate_loop = N_STEPS / med(info["walls_newmark_loop"])
    rate_lsim = N_STEPS / med(info["walls_run_time_response_lsim"])
    rate_on_ours = N_STEPS / med(info["walls_newmark_on_our_matrices"])
    rows += [
        (
            "ROSS: run_time_response(method='newmark')",
            rate_rtr,
            f"JIT warm-up {info['warmup_s']:.1f} s, import {info['import_s']:.1f} s",
        ),
        ("ROSS: utils.newmark loop only (prebuilt M, C, K)", rate_loop, ""),
        ("ROSS: newmark loop on our matrices (65 free DOFs)", rate_on_ours, ""),
        ("ROSS: run_time_response default (signal.lsim)", rate_lsim, "different integrator (ZOH/FOH)"),
    ]
    print(f"\n{'variant':58s} {'steps/s':>14s}")
    for name, rate, note in rows:
        print(f"{name:58s} {rate:14,.0f}  {note}")
    print(f"\nratio ours raw / ROSS run_time_response(newmark): {rate_raw / rate_rtr:,.0f}x")
    print(f"ratio ours Simulator.advance / ROSS run_time_response(newmark): {rate_sim / rate_rtr:,.0f}x")
    print(f"ratio ours raw / ROSS newmark loop only: {rate_raw / rate_loop:,.0f}x")

    # responses after the transient
    t = rd["t"]
    w = t >= COMPARE_FROM_S
    y_raw = ours["y_raw"]
    print(f"\nresponse at the disc (x, y), t >= {COMPARE_FROM_S} s: max |a - b| / max |b|")
    amp_ours = np.abs(ours["x_ss"])
    amp_ross = np.abs(rd["x_ss"])
    print(
        f"  steady-state amplitude (frequency domain): ours {amp_ours[0] * 1e6:.4f} um, "
        f"ROSS {amp_ross[0] * 1e6:.4f} um, ratio {amp_ross[0] / amp_ours[0]:.5f}"
    )
    pairs = [
        ("ROSS newmark (ROSS model) vs ours raw", rd["y_rtr"][w], y_raw[w]),
        ("ROSS newmark on our matrices vs ours raw", rd["y_on_ours"][w], y_raw[w]),
        ("ROSS lsim vs ROSS newmark (same model)", rd["y_lsim"][w], rd["y_rtr"][w]),
    ]
    ss_ours = np.real(ours["x_ss"][None, :] * np.exp(1j * omega_rad_s() * t[w])[:, None])
    ss_ross = np.real(rd["x_ss"][None, :] * np.exp(1j * omega_rad_s() * t[w])[:, None])
    pairs += [
        ("ours raw vs our frequency-domain steady state", y_raw[w], ss_ours),
        ("ROSS newmark vs ROSS frequency-domain steady state", rd["y_rtr"][w], ss_ross),
        ("ROSS steady state vs ours steady state (model only)", ss_ross, ss_ours),
    ]
    ys = ours["y_sim"]
    ts = np.arange(ys.shape[0]) / ours["sim_rate_hz"]
    ws = ts >= COMPARE_FROM_S
    idx = np.rint(ts[ws] / DT_S).astype(int)
    pairs.append(("ours Simulator (decimated) vs ours raw at its time stamps", ys[ws], y_raw[idx]))
    pairs.append(("ours Simulator vs ours raw one step (dt) earlier", ys[ws], y_raw[idx - 1]))
    for name, a, b in pairs:
        print(f"  {name:58s} {rel_diff(a, b):.3e}")

    # model comparison: bending frequencies at standstill on the lateral DOFs
    free = ours["mats"]["free"]
    lat_full = np.array([6 * i + d for i in range(N_ELEMENTS + 1) for d in (0, 4)])  # x-z plane: x, theta_y
    lat_free = np.searchsorted(free, lat_full)
    f_ours = bending_frequencies_hz(ours["mats"]["M"], ours["mats"]["K"], lat_free, 4)
    f_ross = bending_frequencies_hz(rd["M"], rd["K"], lat_full, 4)
    print("\nundamped x-z bending frequencies at standstill, Hz (ours | ROSS | rel. diff):")
    for a, b in zip(f_ours, f_ross, strict=True):
        print(f"  {a:10.3f} | {b:10.3f} | {(b - a) / a:+.2e}")
    print(
        f"\nthreads of the ROSS interpreter: {info['threads']}; ROSS {info['ross_version']}, "
        f"python {info['python']}, numpy {info['numpy']}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
