"""ROSS side of ``bench_ross.py``; runs in a separate interpreter that has ROSS installed.

Not part of the package and never imported by it. Usage (``bench_ross.py`` does this)::

    /tmp/ross-venv/bin/python benchmarks/_ross_side.py PARAMS.json OURS.npz OUT.npz

``PARAMS.json`` describes the rotor, the force and the time grid (see ``bench_ross.py``); ``OURS.npz``
holds our free-DOF matrices (``M``, ``D`` = C + Omega G, ``K``) and the force DOFs, so that ROSS's
Newmark routine can also be run on our model (integrator-only comparison). Writes the disc responses
and ROSS's own matrices to ``OUT.npz`` and prints one JSON line with the wall times.
Only public ROSS API is called (``ShaftElement``, ``DiskElement.from_geometry``, ``BearingElement``,
``Rotor``, ``Rotor.run_time_response``, ``ross.utils.newmark``).
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import sys
import time
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np


def build_rotor(p: dict[str, Any]) -> Any:
    """The same rotor as ``single_rotor(...)``: equal Timoshenko elements, one disc, two bearings."""
    import ross as rs

    mat = rs.Material(name="bench_steel", rho=p["density"], E=p["youngs_modulus"], G_s=p["shear_modulus"])
    n_el = p["n_elements"]
    le = p["length_m"] / n_el
    shafts = [
        rs.ShaftElement(
            L=le,
            idl=0.0,
            odl=p["diameter_m"],
            material=mat,
            n=i,
            shear_effects=True,
            rotary_inertia=True,
            gyroscopic=True,
            shear_method_calc="cowper",
            beta=p["rayleigh_stiffness_s"],
        )
        for i in range(n_el)
    ]
    disc = rs.DiskElement.from_geometry(
        n=p["disc_node0"],
        material=mat,
        width=p["disc_width_m"],
        i_d=p["diameter_m"],
        o_d=p["disc_outer_diameter_m"],
    )
    bearings = [
        rs.BearingElement(
            n=n,
            kxx=p["k_radial"],
            cxx=p["c_radial"],
            kzz=p["k_axial"],
            czz=p["c_axial"],
        )
        for n in p["bearing_nodes0"]
    ]
    return rs.Rotor(shafts, [disc], bearings)


def force_array(p: dict[str, Any], ndof: int, t: np.ndarray, dofs: tuple[int, int]) -> np.ndarray:
    """Rotating (unbalance-like) force at the disc: F0 cos(Omega t) on x, F0 sin(Omega t) on y."""
    f = np.zeros((t.size, ndof))
    f[:, dofs[0]] = p["force_n"] * np.cos(p["omega"] * t)
    f[:, dofs[1]] = p["force_n"] * np.sin(p["omega"] * t)
    return f


def timed(fn: Callable[[], Any], repeats: int) -> tuple[list[float], Any]:
    """Wall times of ``repeats`` calls (stdout of ROSS silenced) and the last result."""
    walls: list[float] = []
    out: Any = None
    for _ in range(repeats):
        with contextlib.redirect_stdout(io.StringIO()):
            t0 = time.perf_counter()
            out = fn()
            walls.append(time.perf_counter() - t0)
    return walls, out


def main(argv: list[str]) -> int:
    params_path, ours_path, out_path = argv[1:4]
    with open(params_path) as fh:
        p = json.load(fh)
    warnings.filterwarnings("ignore")
    t_imp = time.perf_counter()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        import ross
        from ross.utils import newmark
    import_s = time.perf_counter() - t_imp

    rotor = build_rotor(p)
    nd = rotor.number_dof
    dof_x = nd * p["disc_node0"]
    dofs = (dof_x, dof_x + 1)
    n_steps = p["n_steps"]
    t = np.arange(n_steps + 1) * p["dt"]
    force = force_array(p, rotor.ndof, t, dofs)
    omega = p["omega"]
    repeats = p["repeats"]

    # JIT warm-up of ROSS's compiled Newmark helper (not timed in the rates)
    t_w = time.perf_counter()
    with contextlib.redirect_stdout(io.StringIO()):
        rotor.run_time_response(omega, force[:50], t[:50], method="newmark")
    warmup_s = time.perf_counter() - t_w

    walls_rtr, res = timed(lambda: rotor.run_time_response(omega, force, t, method="newmark"), repeats)
    y_rtr = np.asarray(res.yout)[:, list(dofs)]

    # the integration loop alone, on prebuilt matrices (as in ross.utils.newmark's docstring)
    m_r, c_r, k_r, g_r = rotor.M(omega), rotor.C(omega), rotor.K(omega), rotor.G()
    d_r = c_r + omega * g_r

    def ross_loop() -> np.ndarray:
        return newmark(lambda i, **_: (m_r, d_r, k_r, force[i]), t, rotor.ndof)

    walls_loop, y_loop = timed(ross_loop, repeats)

    # ROSS's default path for a constant speed (scipy.signal.lsim on the state space)
    walls_lsim, res_l = timed(lambda: rotor.run_time_response(omega, force, t), max(1, repeats - 2))
    y_lsim = np.asarray(res_l.yout)[:, list(dofs)]

    # ROSS's Newmark routine on OUR matrices (free DOFs): integrator-only comparison
    ours = np.load(ours_path)
    mo, do_, ko = ours["M"], ours["D"], ours["K"]
    fo = np.zeros((t.size, mo.shape[0]))
    ix, iy = (int(v) for v in ours["force_dofs"])
    fo[:, ix] = force[:, dof_x]
    fo[:, iy] = force[:, dof_x + 1]

    def ours_loop() -> np.ndarray:
        return newmark(lambda i, **_: (mo, do_, ko, fo[i]), t, mo.shape[0])

    walls_ours, y_ours_all = timed(ours_loop, repeats)
    y_on_ours = y_ours_all[:, [ix, iy]]

    # frequency-domain steady state of ROSS's model: (K - W^2 M + i W D) X = F0 (1, -i)
    dyn = k_r - omega**2 * m_r + 1j * omega * d_r
    rhs = np.zeros(rotor.ndof, complex)
    rhs[dof_x] = p["force_n"]
    rhs[dof_x + 1] = -1j * p["force_n"]
    x_ss = np.linalg.solve(dyn, rhs)[list(dofs)]

    np.savez(
        out_path,
        t=t,
        y_rtr=y_rtr,
        y_loop=y_loop[:, list(dofs)],
        y_lsim=y_lsim,
        y_on_ours=y_on_ours,
        x_ss=x_ss,
        M=m_r,
        K=k_r,
        C=c_r,
        G=g_r,
    )
    info = {
        "ross_version": ross.__version__,
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "ndof": int(rotor.ndof),
        "import_s": import_s,
        "warmup_s": warmup_s,
        "walls_run_time_response_newmark": walls_rtr,
        "walls_newmark_loop": walls_loop,
        "walls_run_time_response_lsim": walls_lsim,
        "walls_newmark_on_our_matrices": walls_ours,
        "threads": {k: os.environ.get(k, "") for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")},
    }
    print(json.dumps(info))
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv))
