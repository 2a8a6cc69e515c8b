"""Assembly of the gear-rotor-bearing system (Sec 3.5, Eq 39) and its quasi-static solution.

``GearRotorSystem.from_config(cfg, temperature_c)`` returns an :class:`AssembledSystem`:

* Nodes: each shaft's nodes are numbered consecutively, shafts in config order (Fig 5: input shaft
  nodes 1-9, output shaft 10-18). Global DOF = 6 node0 + dof, dof order x, y, z, theta_x, theta_y,
  theta_z (Eqs 19, 35).
* M, K: Timoshenko shaft elements (Sec 3.3) at the uniform steady temperature (E*, G* of Eqs 11-12),
  rigid discs at gear nodes (Sec 3.1, Eqs 19-20), bearings (Eq 37). A mesh with
  ``gear_mass_in_mesh_matrix`` (the as-published configuration) adds the gear-pair mass matrix of
  Eq 32 at its two gear nodes as well, so those gears' mass and inertia count twice. No mesh terms: meshes are
  ``MeshCoupling`` objects (Eqs 21-33) built by ``elements.mesh.build_mesh_coupling``.
* C: Rayleigh shaft damping ``a M_shaft + b K_shaft`` (not in the paper; configured) + bearing damping.
* G: per rad/s of the input shaft; each shaft's (and its discs') gyroscopic matrix is scaled by the
  shaft's signed speed ratio. The input shaft (the one holding the drive node) has ratio 1; across a
  mesh the gear turns at ``-z_pinion / z_gear`` times the pinion's speed (external spur pair).
* static_load: thermal node loads (Eqs 9-11) at ``temperature_c - reference`` plus the load torque.
  Sign convention: the input shaft spins positive about z, the paper's output shaft negative; the
  resisting load torque acts against the load shaft's spin, ``+theta_z`` on the paper's output node
  (``static_load[dof(load, theta_z)] = -sign(ratio) torque``). With V of Eq 22 the
  mesh's generalised force ``-V F_m`` puts ``-r_bg F_m`` on the gear's theta_z, so statics give
  ``F_m = T2 / r_bg > 0`` (drive-flank contact). A mesh whose pinion turns negative (a second stage)
  is assembled as the mirror image (``build_mesh_coupling(pinion_spin=-1)``), so every driving
  pinion loads its drive flank.
* Drive condition (torsional rigid-body mode of the train): the drive node's theta_z follows the
  commanded rotation exactly (a rigid, constant-speed motor); it is removed from ``free_dofs``. The
  driving torque is the reaction at that DOF and balances the load torque through the mesh.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np

from gear_rotor_sim.config import ConfigError, GearConfig, RigConfig
from gear_rotor_sim.elements.disc import GearDisc
from gear_rotor_sim.elements.shaft import ShaftElement
from gear_rotor_sim.system_data import AssembledSystem, BearingSite, MeshCoupling

THETA_Z = 5


def shaft_speed_ratios(cfg: RigConfig) -> np.ndarray:
    """Signed spin speed of each shaft per unit input (drive) shaft speed.

    Propagated over the meshes from the drive shaft: a gear meshing with a pinion turns at
    ``-z_pinion / z_gear`` times the pinion shaft's speed, and vice versa.

    Raises
    ------
    ConfigError
        If a shaft is connected to the input shaft by no mesh (and there is more than one shaft),
        or if meshes give a shaft two different ratios.

    References
    ----------
    Sun et al. (2021), Eq 39 (Omega G^s), Table 3 (z1 = 29, z2 = 49).
    """
    n = len(cfg.shafts)
    ratios: list[float | None] = [None] * n
    ratios[cfg.shaft_of_node(cfg.drive.node0)] = 1.0
    links = []
    for m in cfg.meshes:
        sp = cfg.shaft_of_node(cfg.gear(m.pinion).node0)
        sg = cfg.shaft_of_node(cfg.gear(m.gear).node0)
        links.append((sp, sg, -m.pinion_teeth / m.gear_teeth))
    changed = True
    while changed:
        changed = False
        for sp, sg, r in links:
            for a, b, f in ((sp, sg, r), (sg, sp, 1.0 / r)):
                ra, rb = ratios[a], ratios[b]
                if ra is None:
                    continue
                if rb is None:
                    ratios[b] = ra * f
                    changed = True
                elif not np.isclose(rb, ra * f, rtol=1e-12):
                    raise ConfigError(
                        f"meshes: shaft {cfg.shafts[b].name!r} gets speed ratios {rb:g} and {ra * f:g} from "
                        "different mesh paths; the gear train must be kinematically consistent"
                    )
    missing = [cfg.shafts[k].name for k, r in enumerate(ratios) if r is None]
    if missing:
        raise ConfigError(
            f"meshes: shafts {missing} are not connected to the input shaft by any mesh; every shaft must be "
            "driven through a mesh from the shaft holding drive.node"
        )
    return np.array(ratios, dtype=float)


def shaft_rates_hz(cfg: RigConfig, speed_rpm: float) -> list[float]:
    """Every shaft's rotation rate (Hz) at input speed ``speed_rpm``: ``|ratio| * speed_rpm / 60``
    (ratios of :func:`shaft_speed_ratios`)."""
    return [abs(float(r)) * speed_rpm / 60.0 for r in shaft_speed_ratios(cfg)]


def drivetrain_metadata(cfg: RigConfig) -> dict[str, str]:
    """Per-shaft speed and per-mesh order information as text entries (recordings' ``custom_data``).

    ``shaft_speed_ratios``: ``name=ratio`` per shaft (signed spin per unit input speed, so the shaft
    speed in rpm is ``ratio * speed_rpm``); ``mesh_orders``: ``mesh{k}=order`` per mesh, the mesh
    frequency in multiples of the input shaft frequency (``f_mesh = order * speed_rpm / 60``), 1-based
    in the order of ``meshes:`` like the ``mesh{k}_*`` channels; ``meshes``: the wheels and teeth.
    """
    ratios = shaft_speed_ratios(cfg)
    shafts = ", ".join(f"{sh.name}={r:.12g}" for sh, r in zip(cfg.shafts, ratios, strict=True))
    orders, pairs = [], []
    for k, m in enumerate(cfg.meshes, start=1):
        gp, gg = cfg.gear(m.pinion), cfg.gear(m.gear)
        order = gp.teeth * abs(float(ratios[cfg.shaft_of_node(gp.node0)]))
        orders.append(f"mesh{k}={order:.12g}")
        pairs.append(f"mesh{k}={gp.name}({gp.teeth})/{gg.name}({gg.teeth})")
    return {"shaft_speed_ratios": shafts, "mesh_orders": ", ".join(orders), "meshes": ", ".join(pairs)}


def shaft_elements(cfg: RigConfig) -> list[tuple[int, int, ShaftElement]]:
    """Every shaft element as (shaft index, global node0 of its node i, element)."""
    out = []
    for k, (off, s) in enumerate(zip(cfg.node_offsets, cfg.shafts, strict=True)):
        for j, e in enumerate(s.elements):
            el = ShaftElement(
                length=e.length_m,
                outer_diameter=e.outer_diameter_m,
                inner_diameter=e.inner_diameter_m,
                material=cfg.materials[e.material],
                shear_coefficient=cfg.shear_coefficient,
            )
            out.append((k, off + j, el))
    return out


def gear_disc(cfg: RigConfig, gear: GearConfig) -> GearDisc:
    """Rigid disc of a gear: pitch diameter m z, bore, face width (Sec 3.1, Eqs 19-20)."""
    density = cfg.materials[gear.material].density
    return GearDisc(gear.pitch_diameter_m, gear.bore_diameter_m, gear.face_width_m, density)


def discs(cfg: RigConfig) -> list[tuple[int, GearDisc]]:
    """Rigid discs (gears and plain discs) as (global node0, disc) (Sec 3.1)."""
    out = [(g.node0, gear_disc(cfg, g)) for g in cfg.gears]
    out += [
        (
            d.node0,
            GearDisc(d.outer_diameter_m, d.bore_diameter_m, d.width_m, cfg.materials[d.material].density),
        )
        for d in cfg.discs
    ]
    return out


class GearRotorSystem:
    """Builder of :class:`AssembledSystem` from a :class:`RigConfig` (Eq 39)."""

    @staticmethod
    def from_config(cfg: RigConfig, temperature_c: float, *, include_meshes: bool = True) -> AssembledSystem:
        """Assemble M, K, C, G, the static load and the meshes at a uniform steady temperature.

        Parameters
        ----------
        cfg : RigConfig
            Validated rig.
        temperature_c : float
            Uniform steady temperature of shafts and gears, deg C (material range per policy).
        include_meshes : bool
            False leaves ``meshes`` empty (the uncoupled rotors, e.g. for modal checks).

        Returns
        -------
        AssembledSystem

        References
        ----------
        Sun et al. (2021), Eq 39 (assembly), Eqs 9-11 (thermal node load), Eqs 19-20 (discs),
        Eqs 34-36 (shaft), Eq 37 (bearings), Eqs 21-33 (mesh, via elements.mesh).
        """
        temperature_c = float(temperature_c)
        for mat in cfg.materials.values():
            mat.check_temperature(temperature_c)
        n_nodes = cfg.n_nodes
        ndof = 6 * n_nodes
        ratios = shaft_speed_ratios(cfg)
        M = np.zeros((ndof, ndof))
        K = np.zeros((ndof, ndof))
        C = np.zeros((ndof, ndof))
        G = np.zeros((ndof, ndof))
        thermal = np.zeros(ndof)
        shaft_of_node = np.zeros(n_nodes, dtype=int)
        positions = np.zeros(n_nodes)
        a_m, b_k = cfg.rayleigh_damping.mass_per_s, cfg.rayleigh_damping.stiffness_s

        for k, (off, s) in enumerate(zip(cfg.node_offsets, cfg.shafts, strict=True)):
            shaft_of_node[off : off + s.n_nodes] = k
            positions[off : off + s.n_nodes] = np.concatenate(
                ([0.0], np.cumsum([e.length_m for e in s.elements]))
            )

        for k, node0, el in shaft_elements(cfg):
            idx = np.arange(6 * node0, 6 * node0 + 12)
            blk = np.ix_(idx, idx)
            me, ke = el.mass_matrix(temperature_c), el.stiffness_matrix(temperature_c)
            M[blk] += me
            K[blk] += ke
            C[blk] += a_m * me + b_k * ke  # Rayleigh shaft damping
            G[blk] += ratios[k] * el.gyroscopic_matrix(temperature_c)
            thermal[idx] += el.thermal_node_load(temperature_c, cfg.reference_temperature_c)  # Eqs 9-11

        for node0, disc in discs(cfg):
            idx = np.arange(6 * node0, 6 * node0 + 6)
            blk = np.ix_(idx, idx)
            M[blk] += disc.mass_matrix()  # Eq 20
            G[blk] += ratios[shaft_of_node[node0]] * disc.gyroscopic_matrix()

        # As published (meshes[].gear_mass_in_mesh_matrix): the gear-pair matrix M^g of Eq 32 added
        # at the two gear nodes on top of Eq 20, so each gear's mass and inertia count twice. Only M
        # changes: the mesh (Eqs 21-33, c_m from the gears' own inertias) is the default one.
        pair_mass: dict[str, int] = {}
        for m in cfg.meshes:
            if m.gear_mass_in_mesh_matrix:
                for name in (m.pinion, m.gear):
                    pair_mass[name] = pair_mass.get(name, 0) + 1
        for name, count in pair_mass.items():
            g = cfg.gear(name)
            idx = np.arange(6 * g.node0, 6 * g.node0 + 6)
            M[np.ix_(idx, idx)] += count * gear_disc(cfg, g).mass_matrix()  # Eq 32

        sites = []
        for number, b in enumerate(cfg.bearings, start=1):
            idx = np.arange(6 * b.node0, 6 * b.node0 + 6)
            blk = np.ix_(idx, idx)
            kb, cb = b.properties.stiffness_matrix(), b.properties.damping_matrix()  # Eq 37
            K[blk] += kb
            C[blk] += cb
            sites.append(
                BearingSite(number=number, node0=b.node0, stiffness=kb, damping=cb, type_name=b.type_name)
            )

        static_load = thermal.copy()
        if cfg.load is not None:
            # resists the spin of the load shaft: +theta_z on a shaft turning negative (the paper's output
            # shaft), -theta_z on one turning positive (e.g. the third shaft of a two-stage train)
            spin = np.sign(ratios[cfg.shaft_of_node(cfg.load.node0)]) or -1.0
            static_load[6 * cfg.load.node0 + THETA_Z] -= spin * cfg.load.torque_nm

        drive_dof = 6 * cfg.drive.node0 + THETA_Z
        free = np.setdiff1d(np.arange(ndof), [drive_dof])

        meshes: list[MeshCoupling] = []
        if include_meshes and cfg.meshes:
            from gear_rotor_sim.elements.mesh import build_mesh_coupling

            disc_of = {g.name: gear_disc(cfg, g) for g in cfg.gears}
            for m in cfg.meshes:
                gp, gg = cfg.gear(m.pinion), cfg.gear(m.gear)
                meshes.append(
                    build_mesh_coupling(
                        m,
                        gp.node0,
                        gg.node0,
                        int(shaft_of_node[gp.node0]),
                        int(shaft_of_node[gg.node0]),
                        ndof,
                        temperature_c,
                        cfg.materials[gp.material],
                        cfg.materials[gg.material],
                        cfg.reference_temperature_c,
                        pinion_polar_inertia=disc_of[gp.name].polar_inertia,
                        gear_polar_inertia=disc_of[gg.name].polar_inertia,
                        pinion_teeth=gp.teeth,
                        gear_teeth=gg.teeth,
                        pinion_bore_diameter=gp.bore_diameter_m,
                        gear_bore_diameter=gg.bore_diameter_m,
                        pinion_spin=float(np.sign(ratios[shaft_of_node[gp.node0]])) or 1.0,
                    )
                )

        return AssembledSystem(
            temperature_c=temperature_c,
            M=M,
            K=K,
            C=C,
            G=G,
            static_load=static_load,
            free_dofs=free,
            meshes=tuple(meshes),
            bearings=tuple(sites),
            shaft_of_node=shaft_of_node,
            shaft_speed_ratios=ratios,
            node_positions=positions,
            thermal_load=thermal,
        )


def _mesh_stiffnesses(system: AssembledSystem, mesh_stiffness: float | Sequence[float] | None) -> list[float]:
    """One stiffness per mesh: the mean of each mesh (None), one value for all, or one per mesh."""
    n_mesh = len(system.meshes)
    if mesh_stiffness is None:
        return [m.mean_stiffness for m in system.meshes]
    if np.isscalar(mesh_stiffness):
        return [float(mesh_stiffness)] * n_mesh  # type: ignore[arg-type]
    ks = [float(k) for k in mesh_stiffness]  # type: ignore[union-attr]
    if len(ks) != n_mesh:
        raise ValueError(f"mesh_stiffness: {len(ks)} values given for {n_mesh} meshes")
    return ks


def mesh_mode_shares(
    system: AssembledSystem, mesh_stiffness: float, mesh: int = 0
) -> tuple[np.ndarray, np.ndarray]:
    """Undamped modes of ``system`` linearised with the stiffness ``mesh_stiffness`` on mesh ``mesh``.

    Solves ``(K + k_m v v^T) x = w^2 M x`` on the free degrees of freedom (Eqs 19-22, 37; ``v`` the mesh's
    line of action, Eq 25) and gives each mode's share of its strain energy in that mesh spring,
    ``k_m (v . x)^2 / w^2`` for a mass-normalised ``x``: the mesh mode is the one with the largest share.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        Frequencies (Hz) and mesh strain-energy shares, in ascending frequency.
    """
    import scipy.linalg as sla

    m = system.meshes[mesh]
    f = system.free_dofs
    v = m.line_of_action[f]
    k = system.K[np.ix_(f, f)] + mesh_stiffness * np.outer(v, v)
    w2, x = sla.eigh(k, system.M[np.ix_(f, f)])
    share = mesh_stiffness * (v @ x) ** 2 / np.abs(w2)
    return np.sqrt(np.abs(w2)) / (2.0 * np.pi), share


def static_solution(
    system: AssembledSystem, mesh_stiffness: float | Sequence[float] | None = None
) -> np.ndarray:
    """Quasi-static displacement with every mesh engaged on its drive flank.

    With e(t) = 0 and delta_m = V q > b*, Eqs 25-26 give ``F_m = k (V q - b*)`` and the generalised
    mesh force ``-V F_m``, so on the free DOFs

        ``(K + sum k V V^T) q = static_load + sum k b* V``.

    Friction (Eq 29) is left out of the static balance. The drive DOF is held at zero.

    Parameters
    ----------
    system : AssembledSystem
    mesh_stiffness : float, sequence of float or None
        Mesh stiffness per mesh, N/m; None uses each mesh's ``mean_stiffness``.

    Returns
    -------
    numpy.ndarray
        (ndof,) displacements, zeros at fixed DOFs.

    Warns
    -----
    UserWarning
        If a mesh's resulting delta is below its b* (the mesh would not be in drive-flank contact,
        e.g. no load torque): the returned state is then the engaged solution, not an equilibrium.

    References
    ----------
    Sun et al. (2021), Eqs 21, 22, 25, 26, 39.
    """
    ks = _mesh_stiffnesses(system, mesh_stiffness)
    K = system.K.copy()
    rhs = system.static_load.copy()
    for m, k in zip(system.meshes, ks, strict=True):
        v = m.line_of_action
        K += k * np.outer(v, v)
        rhs += k * m.half_backlash * v
    f = system.free_dofs
    q = np.zeros(system.ndof)
    q[f] = np.linalg.solve(K[np.ix_(f, f)], rhs[f])
    for i, m in enumerate(system.meshes):
        delta = float(m.line_of_action @ q)
        if delta < m.half_backlash * (1.0 - 1e-9):
            warnings.warn(
                f"mesh {i}: static delta {delta:.3e} m is below the half backlash "
                f"b* {m.half_backlash:.3e} m; "
                "the mesh is not loaded on its drive flank (is there a load torque?)",
                stacklevel=2,
            )
    return q


def mesh_forces(
    system: AssembledSystem, q: np.ndarray, mesh_stiffness: float | Sequence[float] | None = None
) -> np.ndarray:
    """Static mesh forces ``F_m = k (V q - b*)`` (Eq 25 with e = 0, drive flank) for ``q``, N."""
    ks = _mesh_stiffnesses(system, mesh_stiffness)
    return np.array(
        [k * (m.line_of_action @ q - m.half_backlash) for m, k in zip(system.meshes, ks, strict=True)]
    )
