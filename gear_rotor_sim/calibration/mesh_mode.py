"""The FE model's mesh mode at its mean mesh stiffness (history/calibration_sessions.md Secs. 8.41, 8.71).

The mesh mode is the undamped mode of the linearised system ``(K + k_m v v^T) x = w^2 M x`` that holds the
largest share of its strain energy in the mesh spring (``k_m (v . x)^2 / w^2`` for a mass-normalised ``x``),
with ``K`` and ``M`` the assembled shaft, bearing and disc matrices on the free degrees of freedom (Sun et al.
2021, Eqs 19-22 and 37), ``v`` the mesh's line of action (Eq 25) and ``k_m`` its mean stiffness (Eq 13) times
the mesh stiffness scale of the baseline sets. It is the mode the mesh harmonics of a record excite when
they come near it, and what the gear pair's inertia moves without touching the static compliance ``F / k``
(``faults.mesh_inertia``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from gear_rotor_sim.config import RigConfig
from gear_rotor_sim.faults import Effect, MeshStiffnessDamping
from gear_rotor_sim.faults.mesh_inertia import MeshInertia
from gear_rotor_sim.system import mesh_mode_shares


def mesh_stiffness_scale(effects: Sequence[Effect]) -> float:
    """The product of the constant mesh stiffness factors of ``effects`` (the mesh set's stiffness scale,
    the mode-holding inertia's scale)."""
    s = 1.0
    for e in effects:
        if isinstance(e, MeshStiffnessDamping):
            s *= float(e.stiffness_scale)
        elif isinstance(e, MeshInertia):
            s *= float(e.inertia_scale)
    return s


def mesh_mode_hz(
    cfg: RigConfig, temperature_c: float, effects: Sequence[Effect] = (), mesh: int = 0
) -> float:
    """Frequency (Hz) of the FE model's mesh mode of mesh ``mesh`` on the machine ``cfg`` with ``effects``.

    Parameters
    ----------
    cfg : RigConfig
        The rig.
    temperature_c : float
        Operating temperature (E(T) and the thermal preload of the assembly).
    effects : sequence of Effect
        Baseline sets (and any other effects): their ``modify_config`` is applied, the mesh stiffness is
        scaled by :func:`mesh_stiffness_scale`.
    mesh : int
        Index of the mesh.

    Returns
    -------
    float
        The frequency of the mode with the largest share of its strain energy in that mesh.
    """
    from gear_rotor_sim.calibration.model_runner import cached_system

    for e in effects:
        cfg = e.modify_config(cfg)
    system = cached_system(cfg, temperature_c)
    km = mesh_stiffness_scale(effects) * system.meshes[mesh].mean_stiffness
    f_hz, share = mesh_mode_shares(system, km, mesh)
    return float(f_hz[int(np.argmax(share))])
