"""A breathing transverse shaft crack at a node, linearised about the static deflection (load dominance).

Physics
-------
A transverse crack removes bending stiffness about the axis along its front while its mouth is on the
tension side of the bent shaft, and none while it is pressed shut (Gasch 1976, 1993; Dimarogonas 1996).
Where the static deflection of the shaft dominates its vibration (a weight- or load-dominated rotor:
Mayes & Davies 1984; Penny & Friswell 2002, J. Sound Vib. 259(3)), the crack opens and closes under
that deflection, which is fixed in space, so its breathing is a known periodic function of the shaft
angle. Written as an extra load on the healthy shaft (the FE shaft keeps its stiffness; the crack adds
what the lost stiffness no longer resists): ``f`` at the cracked node and ``-w_b f`` at the shaft's bearing
nodes (``P^T f``, ``P`` the map from the state to the bending deflection below; the crack is internal to
the shaft, so the pair is self-equilibrated and the static bearing reactions keep the mesh load), with::

    f(psi) = beta(psi) dk (n . d) n,      n = (cos, sin)(theta_s + phi),      dk = stiffness_loss k_s,

with ``theta_s`` the signed angle of the node's shaft (``n`` turns with it, either way), ``phi`` the crack
mouth's angle at shaft angle 0 (``phase_rad``), ``d`` the shaft's bending deflection at the node (the
node's lateral displacement less the bearing line's, linearly between the shaft's bearing nodes) and
``k_s`` the FE shaft's own lateral bending stiffness at the node (the shaft elements alone, pinned at
its bearing nodes: ``1 / C``, ``C`` the node's static compliance; the two directions of a round shaft
agree, their mean is taken). ``stiffness_loss`` is thus the drop of the shaft's lateral stiffness normal
to the open crack as a fraction of its stiffness at that node: the same quantity as the fraction of a
lumped rotor's shaft spring (Jeffcott, load at the crack), which is how the independent generator
defines its ``stiffness_loss`` (``lumped_gearbox/shaft_faults.py``). The mapping assumes the crack sits
at the node where the load acts (the pinion's seat: the bending moment and the deflection are largest
there) and the FE shaft between its bearings bends like the lumped spring.

Linearisation: ``d`` is the static deflection ``d0`` of the healthy machine under the mean mesh load
(``system.static_solution``) plus the static deflection the crack's own force adds: ``d = d0 + B f``,
``B`` the 2x2 static compliance of the whole FE model (shaft, bearings, mesh) from the crack's load pair
to the node's bending deflection. With ``f = a n`` that gives, per angle, the quasi-static solution

    a(psi) = beta(psi) dk (n . d0) / (1 - beta(psi) dk n^T B n),

exact for a one-spring shaft (``(k I - dk n n^T)^-1``: the extra deflection is ``dk / (k - dk)``, not
``dk / k``, times the load), which is why the 30 % crack of the generator is not read 30 % low.

Breathing law ``beta``: ``switching`` (default; Gasch's hinge crack, open while ``n . d0 > 0``) or
``cosine`` (Mayes & Davies 1984: ``beta = (1 + cos(psi - alpha)) / 2``, ``alpha`` the angle of ``d0``,
a smooth transition). Switching is the default: a straight-front crack under load dominance opens and
closes where the bending stress at its mouth changes sign, the force ``dk (n . d0) n`` is continuous
there (``n . d0 = 0``), and the two laws agree within a few percent on 1x and 2x for shallow cracks
(Penny & Friswell 2002); the cosine law has a larger 1x and no 4x.

Signature, switching law (``g(x) = max(cos x, 0) = 1/pi + cos(x) / 2 + 2 / (3 pi) cos(2x) - ...``,
``A = dk |d0|``): in complex form ``f_x + i f_y = A sum_k g_k e^{ik(psi - alpha)} e^{i psi}``: a constant
force ``A / 4`` along ``d0`` (order 0, a static share), a forward 1x of ``A / pi``, a forward 2x of
``A / 4``, a forward 3x and a backward 1x of ``A / (3 pi)``, then orders 5 and -3 (``A / (15 pi)``): 1x,
2x and 3x of the cracked shaft in fixed ratios and with phases fixed by ``alpha``: the classic crack
signature (Sabnavis et al. 2004, Shock Vib. Digest 36).

The dynamic share (optional, ``mesh_deflection``): the open crack also drops the stiffness against the
shaft's vibration, so to first order in ``dk`` the force holds ``beta(psi) dk (n . d_dyn(t)) n`` with
``d_dyn`` the healthy machine's dynamic bending deflection at the node. Where the teeth stay in contact
that is periodic in the mesh phase ``u`` (the mesh stiffness and transmission error drive it), so it is
given by its mesh harmonics ``D_h``: the crack then modulates the mesh-frequency deflection by the shaft's
breathing, which puts sidebands +-1, +-2, +-3 of the cracked shaft about the mesh harmonics (what a crack
breathing on the instantaneous deflection makes where a lateral mode lies near the mesh frequency). The
opening stays the static one (load dominance) and the dynamic share is not made self-consistent (first
order in ``dk``).

Loss reference (``loss_reference``). ``shaft`` (default): ``stiffness_loss`` is the drop of the shaft's own
bending stiffness ``k_s`` at the node, as above. ``support``: it is the drop of the node's whole lateral
support stiffness ``k_L`` (the shaft in series with its bearings, the lumped spring of a Jeffcott rotor on
flexible supports; 8.92e7 N/m at the paper's pinion seat against ``k_s`` = 1.308e8 N/m), the convention of a
lumped rotor that softens its one lateral spring by the crack (``lumped_gearbox/shaft_faults.py``: its
``stiffness_loss`` is a fraction of the shaft-and-bearing spring). The crack is still the shaft's: the
shaft's loss ``l_s`` is the one that gives the node the same extra static compliance along ``d0`` while
open, ``b l_s / (1 - b l_s) = r l / (1 - l)`` with ``r = k_s / k_L`` and ``b = k_s d^T B d`` (``d`` the unit
vector along ``d0``; :func:`shaft_loss`): ``l_s`` = 1.63 ``l`` for shallow cracks on the paper gearbox, which
is the 1.65 between the two models' responses to one loss when their transfers are otherwise equal
(``benchmarks/crack_transfer.py``; docs/history/calibration_sessions.md Sec. 8.64). ``support_terms`` holds
``(r, b)`` fixed instead of the system's: the calibration holds the nominal machine's, since a reference
baseline's bearing stiffness scale (a model-form nuisance of the lateral modes: x0.52 on the generator's
healthy 2000 rpm record, whose own pinion spring 8.86e7 N/m is the nominal FE node's 8.92e7 within 1 %) would
otherwise rescale the reported loss of one and the same shaft crack (``r`` 1.466 -> 2.035; Sec. 8.67).

Bearing tilt damping (``bearing_tilt_damping``). The paper's Table 5 gives every bearing a tilt damping
``c_theta`` = 1.00e3 (printed in N s/m, the translational damping's unit and value), 0.048 s against its tilt
stiffness 2.08e4 N m/rad: above about 3 Hz the bearings hold the shaft's ends against tilting, so the shaft
bends nearly as a clamped beam at the crack's orders, and its response to the crack's internal load is
0.52 / 0.40 / 0.37 of the same model's without that damping at 1x / 2x / 3x of 3000 rpm (on every channel,
along and across the line of action; ``benchmarks/crack_transfer.py``). A rotor whose bearings carry no tilt
damping (a lumped or pinned-end model; a ball bearing's physical tilt damping is of the order
``c_r w^2`` ~ 0.1 N m s/rad) answers the crack with the quasi-static bending. With
``bearing_tilt_damping=False`` the crack's load carries, besides ``P^T f``, the moments ``C_t q_c'`` at the
bearings' tilt DOFs, ``q_c`` the linear response (mean mesh stiffness) of the model without the bearings'
tilt damping ``C_t`` to the crack's load, line by line of its shaft orders and mesh harmonics
(:meth:`ShaftCrack.tilt_compensation`): by superposition the crack's own response is then the one of the model
without ``C_t`` (exact for the linear model; the rest of the machine keeps its damping). It is the second
model form the calibration offers the crack in (``calibration/candidates_crack.py``).

What the linearisation leaves out: the opening and closing by the vibration itself (beyond load
dominance), the dynamic share's own feedback (the crack's response changes ``d_dyn``), the crack's
effect on the eigenfrequencies (they drop by about ``loss / 2`` of the shaft's share while open), any
coupling to torsion or the axial direction, and a deflection that is not periodic in the mesh phase
(where the teeth separate, only its mesh-synchronous part is in ``D_h``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from gear_rotor_sim.faults.base import Effect, ParameterSpec, node_xy_columns, shaft_index

BREATHING_LAWS = ("switching", "cosine")
LOSS_REFERENCES = ("shaft", "support")
#: shaft orders of the crack's load carried by the tilt compensation (the switching law's lines fall as 1/k^2)
TILT_ORDERS = 8


def _bending_dofs(node0: int) -> list[int]:
    return [6 * node0 + j for j in (0, 1, 3, 4)]  # x, y, theta_x, theta_y


def bearing_line_weights(system: Any, node0: int) -> dict[int, float]:
    """Weights of the shaft's bearing nodes whose lateral displacement, so weighted, is the bearing line
    at ``node0`` (linear between the two outermost bearing nodes of its shaft; one bearing: that node).

    Parameters
    ----------
    system : AssembledSystem
    node0 : int
        0-based node.
    """
    shaft = shaft_index(system, node0)
    nodes = sorted(
        {b.node0 for b in system.bearings if int(system.shaft_of_node[b.node0]) == shaft},
        key=lambda n: float(system.node_positions[n]),
    )
    if not nodes:
        raise ValueError(f"node {node0 + 1}: its shaft has no bearing (a crack needs a supported shaft)")
    if len(nodes) == 1 or nodes[0] == nodes[-1]:
        return {nodes[0]: 1.0}
    a, b = nodes[0], nodes[-1]
    pa, pb, p = (float(system.node_positions[i]) for i in (a, b, node0))
    w = (p - pa) / (pb - pa)
    return {a: 1.0 - w, b: w}


def deflection_map(system: Any, node0: int) -> np.ndarray:
    """``P`` (2, ndof): the lateral (x, y) deflection of ``node0`` from its shaft's bearing line is ``P q``;
    ``P^T f`` is the self-equilibrated load of a force ``f`` acting across the crack."""
    P = node_xy_columns(system, node0).T
    for nb, w in bearing_line_weights(system, node0).items():
        P -= w * node_xy_columns(system, nb).T
    return P


def _node_stiffness(K: np.ndarray, system: Any, node0: int, held: set[int]) -> np.ndarray:
    """(2, 2) inverse of the x-y static compliance of ``node0`` under ``K`` restricted to the bending DOFs of
    its shaft less ``held``."""
    shaft = shaft_index(system, node0)
    nodes = [int(n) for n in np.flatnonzero(np.asarray(system.shaft_of_node) == shaft)]
    dofs = [d for n in nodes for d in _bending_dofs(n) if d not in held]
    pos = {d: i for i, d in enumerate(dofs)}
    rhs = np.zeros((len(dofs), 2))
    rhs[pos[6 * node0], 0] = 1.0
    rhs[pos[6 * node0 + 1], 1] = 1.0
    sol = np.linalg.solve(K[np.ix_(dofs, dofs)], rhs)
    return np.linalg.inv(sol[[pos[6 * node0], pos[6 * node0 + 1]], :])


def shaft_stiffness(system: Any, node0: int) -> np.ndarray:
    """(2, 2) lateral bending stiffness of the shaft elements alone at ``node0``, pinned at the shaft's
    bearing nodes (their x and y held, rotations free; a single bearing also holds its rotations): the
    inverse of the node's static compliance, N/m.
    """
    K = np.array(system.K, dtype=float, copy=True)
    for b in system.bearings:
        idx = np.arange(6 * b.node0, 6 * b.node0 + 6)
        K[np.ix_(idx, idx)] -= b.stiffness
    held = set()
    weights = bearing_line_weights(system, node0)
    for nb in weights:
        held.update((6 * nb, 6 * nb + 1))
        if len(weights) == 1:
            held.update((6 * nb + 3, 6 * nb + 4))
    return _node_stiffness(K, system, node0, held)


def line_sum(ek: np.ndarray, eh: np.ndarray, lines: np.ndarray) -> np.ndarray:
    """``Re sum_kh ek[n, k] eh[n, h] lines[k, h, t]`` (n, t): the tilt moments at the steps from their
    lines (``CrackedShaft.tilt_compensation``), as one matrix product over the ``(k, h)`` pairs (the
    three-operand ``numpy.einsum("nk,nh,kht->nt")`` it replaces loops over ``n k h t`` in Python's
    C einsum kernel without BLAS: 6.8 ms against 0.9 ms per 700-step chunk, docs/history/
    calibration_sessions.md Sec. 8.70).
    """
    pairs = (ek[:, :, None] * eh[:, None, :]).reshape(ek.shape[0], -1)
    return np.real(pairs @ lines.reshape(pairs.shape[1], -1))


def static_terms(system: Any, node0: int) -> tuple[np.ndarray, np.ndarray, float]:
    """``d0`` (2,), ``B`` (2, 2) and the scalar shaft stiffness ``k_s`` of the linearisation (module
    docstring): the healthy static bending deflection at ``node0`` under the mean mesh load, the static
    compliance ``P K^-1 P^T`` of the whole model (shaft, bearings, mean mesh stiffness) from the crack's
    load pair to the bending deflection, and the mean of the shaft stiffness's two diagonal terms.
    """
    import warnings

    from gear_rotor_sim.system import static_solution

    with warnings.catch_warnings():  # an unloaded mesh: the engaged solution is still the deflection
        warnings.filterwarnings("ignore", message=r"mesh \d+: static delta .* below the half backlash")
        q0 = static_solution(system)
    P = deflection_map(system, node0)
    d0 = P @ q0
    K = np.array(system.K, dtype=float, copy=True)
    for m in system.meshes:
        v = m.line_of_action
        K += float(m.mean_stiffness) * np.outer(v, v)
    f = system.free_dofs
    q = np.zeros((system.ndof, 2))
    q[f] = np.linalg.solve(K[np.ix_(f, f)], P.T[f])
    B = P @ q
    ks = shaft_stiffness(system, node0)
    return d0, B, float(0.5 * (ks[0, 0] + ks[1, 1]))


def support_stiffness(system: Any, node0: int) -> float:
    """Lateral static stiffness of ``node0`` on its shaft and the shaft's bearings (no mesh), N/m: the mean of
    the inverse compliance's two diagonal terms (the node's lumped spring of a Jeffcott rotor on flexible
    supports)."""
    ks = _node_stiffness(np.asarray(system.K, dtype=float), system, node0, set())
    return float(0.5 * (ks[0, 0] + ks[1, 1]))


def shaft_loss(loss: float, ratio: float, b: float) -> float:
    """The shaft's loss ``l_s`` whose extra static compliance at the node equals that of a drop ``loss`` of
    the node's support stiffness: ``b l_s / (1 - b l_s) = ratio loss / (1 - loss)`` (module docstring;
    ``ratio = k_s / k_L``, ``b = k_s d^T B d``)."""
    if loss <= 0.0:
        return 0.0
    x = ratio * loss / max(1.0 - loss, 1e-9)
    return x / (b * (1.0 + x))


def support_loss(loss_s: float, ratio: float, b: float) -> float:
    """Inverse of :func:`shaft_loss`: the support loss of a shaft loss ``loss_s``."""
    if loss_s <= 0.0:
        return 0.0
    x = b * loss_s / max(1.0 - b * loss_s, 1e-9)
    return x / (ratio + x)


def tilt_damping_terms(system: Any) -> tuple[list[int], np.ndarray]:
    """Global tilt DOFs (theta_x, theta_y) of the bearing nodes with tilt damping, and that damping."""
    dofs, c = [], []
    for b in system.bearings:
        for d in (3, 4):
            if b.damping[d, d] != 0.0:
                dofs.append(6 * b.node0 + d)
                c.append(float(b.damping[d, d]))
    return dofs, np.asarray(c)


def breathing(law: str, psi: np.ndarray, d0: np.ndarray) -> np.ndarray:
    """Breathing function ``beta(psi)`` in [0, 1] of the crack mouth angle ``psi`` (module docstring)."""
    proj = np.cos(psi) * d0[0] + np.sin(psi) * d0[1]
    if law == "switching":
        return (proj > 0.0).astype(float)
    norm = float(np.hypot(d0[0], d0[1]))
    return 0.5 * (1.0 + proj / norm) if norm > 0 else np.zeros_like(proj)


@dataclass(frozen=True)
class ShaftCrack(Effect):
    """A breathing transverse crack at a shaft node (module docstring).

    Parameters
    ----------
    node : int
        1-based node of the crack (default 5, the paper gearbox's pinion seat).
    stiffness_loss : float
        Drop of the shaft's lateral stiffness normal to the open crack, a fraction of the FE shaft's
        bending stiffness at the node.
    phase_rad : float
        Angle of the crack mouth at shaft angle 0, rad.
    breathing : str
        ``switching`` (default) or ``cosine``.
    mesh_deflection : tuple of complex
        The dynamic share (module docstring): the healthy machine's bending deflection at the node over
        the phase ``u`` of mesh ``mesh``, ``d_dyn(u) = Re sum_h D_h e^{2 pi i h u}``, as ``(D_x1 .. D_xH,
        D_y1 .. D_yH)`` in m; empty (default): the static linearisation alone. The calibration sets it
        from its healthy model run (``calibration/candidates_crack.py``).
    mesh : int
        1-based mesh whose phase ``mesh_deflection`` follows.
    loss_reference : str
        ``shaft`` (default): ``stiffness_loss`` is a fraction of the shaft's bending stiffness at the node;
        ``support``: of the node's stiffness on its shaft and bearings (module docstring).
    bearing_tilt_damping : bool
        True (default): the crack's response feels the bearings' tilt damping of the model; False: the
        moments that remove it from the crack's own response are added (module docstring).
    support_terms : tuple of float
        ``(r, b)`` of :func:`shaft_loss` held for ``loss_reference="support"`` (the calibration holds the
        nominal machine's, so that a reference baseline's bearing scale does not rescale the loss: module
        docstring); empty (default): the system's own (:meth:`reference_terms`).
    """

    node: int = 5
    stiffness_loss: float = 0.0
    phase_rad: float = 0.0
    breathing: str = "switching"
    mesh_deflection: tuple[complex, ...] = ()
    mesh: int = 1
    loss_reference: str = "shaft"
    bearing_tilt_damping: bool = True
    support_terms: tuple[float, ...] = ()
    _cache: dict = field(default_factory=dict, compare=False, repr=False)
    name: ClassVar[str] = "shaft_crack"
    signature: ClassVar[str] = (
        "orders 1x, 2x, 3x of the cracked shaft in fixed ratios (2x strong), a static share, sidebands "
        "at the mesh orders"
    )
    specs: ClassVar[tuple[ParameterSpec, ...]] = (
        ParameterSpec(
            "stiffness_loss", "1", 0.0, 0.8, "scalar", "lateral stiffness drop of the open crack, fraction"
        ),
        ParameterSpec("phase_rad", "rad", -math.pi, math.pi, "phase", "crack mouth angle at shaft angle 0"),
    )

    def __post_init__(self) -> None:
        if self.breathing not in BREATHING_LAWS:
            raise ValueError(f"breathing: {self.breathing!r} is not one of {list(BREATHING_LAWS)}")
        if self.loss_reference not in LOSS_REFERENCES:
            raise ValueError(f"loss_reference: {self.loss_reference!r} is not one of {list(LOSS_REFERENCES)}")
        object.__setattr__(self, "support_terms", tuple(float(x) for x in self.support_terms))
        if self.support_terms and not (
            len(self.support_terms) == 2 and all(math.isfinite(x) and x > 0 for x in self.support_terms)
        ):
            raise ValueError(f"support_terms: {self.support_terms!r} must be empty or two positive numbers")

    @property
    def label(self) -> str:
        return f"shaft_crack@node{self.node}"

    def terms(self, system: Any) -> tuple[np.ndarray, np.ndarray, float]:
        """``static_terms`` of ``system`` at the crack's node, cached per system."""
        key = (id(system), self.node)
        hit = self._cache.get(key)
        if hit is None or hit[0] is not system:
            if len(self._cache) > 8:
                self._cache.clear()
            hit = (system, static_terms(system, self.node - 1))
            self._cache[key] = hit
        return hit[1]

    def reference_terms(self, system: Any) -> tuple[float, float]:
        """``(r, b)`` of :func:`shaft_loss`: ``k_s / k_L`` and ``k_s d^T B d`` at the node, cached;
        :attr:`support_terms` where given."""
        if self.support_terms:
            r, b = self.support_terms
            return float(r), float(b)
        key = (id(system), self.node, "reference")
        hit = self._cache.get(key)
        if hit is None or hit[0] is not system:
            d0, B, ks = self.terms(system)
            d = d0 / max(float(np.hypot(d0[0], d0[1])), 1e-30)
            hit = (system, (ks / support_stiffness(system, self.node - 1), float(ks * d @ B @ d)))
            self._cache[key] = hit
        return hit[1]

    def model_form(self) -> dict[str, Any]:
        """The form the crack was taken in (reported with a fitted crack, ``calibration/fit_types.py``): the
        bearings' tilt damping in its response, the loss's reference and the support terms held."""
        return {
            "bearing_tilt_damping": bool(self.bearing_tilt_damping),
            "loss_reference": self.loss_reference,
            "support_terms": list(self.support_terms),
        }

    def shaft_stiffness_loss(self, system: Any) -> float:
        """``l_s``: the drop of the shaft's bending stiffness at the node, a fraction (``loss_reference``)."""
        if self.loss_reference == "shaft":
            return float(self.stiffness_loss)
        return shaft_loss(float(self.stiffness_loss), *self.reference_terms(system))

    def external_forces(self, system: Any) -> np.ndarray | None:
        """``P^T``: the force ``f`` at the node and ``-w_b f`` at the shaft's bearing nodes (the bearing
        line's weights), a self-equilibrated pair: the crack is internal to the shaft, so it moves no
        static load into the bearings (a force at the node alone would have added ``f`` to their reactions).
        Without the bearings' tilt damping, one more column per damped bearing tilt DOF."""
        if self.stiffness_loss == 0.0:
            return None
        cols = deflection_map(system, self.node - 1).T
        if self.bearing_tilt_damping:
            return cols
        dofs, _ = tilt_damping_terms(system)
        extra = np.zeros((system.ndof, len(dofs)))
        extra[dofs, np.arange(len(dofs))] = 1.0
        return np.hstack([cols, extra])

    def crack_load(
        self, system: Any, psi: np.ndarray, dyn: tuple[np.ndarray, np.ndarray] | None
    ) -> np.ndarray:
        """The crack's load ``f`` (..., 2) at mouth angles ``psi`` with the dynamic deflection ``dyn``."""
        d0, B, ks = self.terms(system)
        c, s = np.cos(psi), np.sin(psi)
        dk = self.shaft_stiffness_loss(system) * ks
        beta = breathing(self.breathing, psi, d0)
        nbn = B[0, 0] * c * c + (B[0, 1] + B[1, 0]) * c * s + B[1, 1] * s * s
        a = beta * dk * (c * d0[0] + s * d0[1]) / (1.0 - beta * dk * nbn)
        if dyn is not None:
            a = a + beta * dk * (c * dyn[0] + s * dyn[1])
        return np.stack([a * c, a * s], axis=-1)

    def force_amplitudes(self, ctx: Any) -> np.ndarray | None:
        if self.stiffness_loss == 0.0:
            return None
        psi = ctx.shaft_angle[:, shaft_index(ctx.system, self.node - 1)] + self.phase_rad
        dyn = self._deflection_at(self._mesh_phase(ctx)) if self.mesh_deflection else None
        f = self.crack_load(ctx.system, psi, dyn)
        if self.bearing_tilt_damping:
            return f
        return np.hstack([f, self.tilt_compensation(ctx)])

    def dynamic_deflection(self, ctx: Any) -> tuple[np.ndarray, np.ndarray]:
        """``d_dyn`` (x, y) at the steps of ``ctx`` from :attr:`mesh_deflection` and the mesh phase."""
        return self._deflection_at(self._mesh_phase(ctx))

    def _mesh_phase(self, ctx: Any) -> np.ndarray:
        phases = ctx.mesh_phases if getattr(ctx, "mesh_phases", None) is not None else ctx.mesh_phase[:, None]
        return phases[:, self.mesh - 1]

    def _deflection_at(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        coef = np.asarray(self.mesh_deflection, dtype=complex).reshape(2, -1)
        rot = np.exp(2j * np.pi * np.multiply.outer(u, np.arange(1, coef.shape[1] + 1)))
        return np.real(rot @ coef[0]), np.real(rot @ coef[1])

    def tilt_compensation(self, ctx: Any) -> np.ndarray:
        """Moments ``C_t q_c'`` (n, n_tilt) at the bearings' damped tilt DOFs (module docstring).

        The crack's load is periodic in its mouth angle ``psi`` and (with a dynamic share) in the mesh phase
        ``u``: sampled on a grid of one turn and one mesh period, its Fourier lines ``F_kh`` (``|k| <=
        TILT_ORDERS``, ``|h|`` up to the dynamic share's harmonics) at the frequencies ``k psi' + 2 pi h u'``
        (the chunk's mean speed) give ``q_c' = sum i w H_0(w) P^T F_kh e^{i(k psi + 2 pi h u)}``, ``H_0`` the
        mean-stiffness linear model without ``C_t`` (``solver.linear_model``, gyroscopic at the input speed).
        """
        system = ctx.system
        shaft = shaft_index(system, self.node - 1)
        ratios = np.asarray(system.shaft_speed_ratios, float)
        psi = ctx.shaft_angle[:, shaft] + self.phase_rad
        w_shaft = float(np.mean(ctx.shaft_speed[:, shaft]))
        w_input = w_shaft / float(ratios[shaft])
        nh = len(self.mesh_deflection) // 2 if self.mesh_deflection else 0
        w_mesh, u = 0.0, np.zeros(psi.size)
        if nh:
            m = system.meshes[self.mesh - 1]
            w_mesh = 2.0 * np.pi * m.pinion_teeth * abs(float(ratios[m.pinion_shaft])) * w_input
            u = self._mesh_phase(ctx)
        ks_ = np.arange(-TILT_ORDERS, TILT_ORDERS + 1)
        hs_ = np.arange(-nh, nh + 1)
        gp, gu = 64, 4 * nh + 4
        grid_psi = np.repeat((2.0 * np.pi * np.arange(gp) / gp)[:, None], gu, axis=1)
        dyn = None
        if nh:
            dx, dy = self._deflection_at(np.arange(gu) / gu)
            dyn = (np.broadcast_to(dx, (gp, gu)), np.broadcast_to(dy, (gp, gu)))
        load = self.crack_load(system, grid_psi, dyn)  # (gp, gu, 2)
        spec = np.fft.fft2(load, axes=(0, 1)) / (gp * gu)  # load = sum spec e^{i(k psi + 2 pi h u)}
        F = spec[np.ix_(ks_ % gp, hs_ % gu)]  # (nk, nh, 2)
        T = self._tilt_transfer(system, w_shaft, w_mesh, w_input, nh)  # (nk, nh, n_tilt, 2)
        R = np.einsum("khtj,khj->kht", T, F)
        ek = np.exp(1j * np.multiply.outer(psi, ks_))
        eh = np.exp(2j * np.pi * np.multiply.outer(u, hs_))
        return line_sum(ek, eh, R)

    def _tilt_transfer(
        self, system: Any, w_shaft: float, w_mesh: float, w_input: float, nh: int
    ) -> np.ndarray:
        """``C_t i w H_0(w) P^T`` (nk, nh, n_tilt, 2) at the lines ``w = k w_shaft + h w_mesh``, cached."""
        key = (id(system), self.node, "tilt", round(w_shaft, 6), round(w_mesh, 6), nh)
        hit = self._cache.get(key)
        if hit is not None and hit[0] is system:
            return hit[1]
        from gear_rotor_sim.solver.linear_model import LinearModel

        lin = LinearModel(system)
        dofs, ct = tilt_damping_terms(system)
        rows = lin.pos[np.asarray(dofs, dtype=np.int64)]
        D = lin.C.copy()
        D[rows, rows] -= ct
        D += w_input * lin.G
        load = deflection_map(system, self.node - 1)[:, lin.free].T  # (n, 2)
        ks_ = np.arange(-TILT_ORDERS, TILT_ORDERS + 1)
        hs_ = np.arange(-nh, nh + 1)
        out = np.zeros((ks_.size, hs_.size, len(dofs), 2), dtype=complex)
        for i, k in enumerate(ks_):
            for j, h in enumerate(hs_):
                w = k * w_shaft + h * w_mesh
                if w == 0.0:
                    continue
                q = np.linalg.solve(lin.K - w * w * lin.M + 1j * w * D, load)
                out[i, j] = (1j * w * ct)[:, None] * q[rows]
        if len(self._cache) > 8:
            self._cache.clear()
        self._cache[key] = (system, out)
        return out
