"""Rigid gear disc (Sec 3.1, Eqs 19-20).

A gear is modelled as a rigid annulus: outer diameter = pitch diameter ``m z`` (Table 3 gives module,
teeth and face width; the teeth above and below the pitch circle are taken to balance), bore = the
shaft diameter at its node unless configured, width = the face width of its mesh. DOF order (Eq 19):
``x, y, z, theta_x, theta_y, theta_z``.

Gyroscopic sign convention (shared with ``elements/shaft.py``): spin Omega about +z, angular momentum
``I_p Omega`` along the tilted axis ``(theta_y, -theta_x, 1)``; Eq 20 ``M q'' + Omega G q' = F`` with
``G[theta_x, theta_y] = +I_p`` and ``G[theta_y, theta_x] = -I_p``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class GearDisc:
    """Rigid annular disc at one node.

    Parameters
    ----------
    outer_diameter : float
        Outer diameter, m (pitch diameter ``m z`` for a gear).
    bore_diameter : float
        Bore diameter, m.
    width : float
        Axial width, m (face width for a gear).
    density : float
        kg/m^3.

    References
    ----------
    Sun et al. (2021), Sec 3.1, Eqs 19-20; Eq 32 (m, J_d, J_p of the gear pair).
    """

    outer_diameter: float
    bore_diameter: float
    width: float
    density: float

    def __post_init__(self) -> None:
        if not self.outer_diameter > 0.0:
            raise ValueError(f"outer_diameter: {self.outer_diameter} must be > 0 m")
        if not 0.0 <= self.bore_diameter < self.outer_diameter:
            raise ValueError(
                f"bore_diameter: {self.bore_diameter} must satisfy "
                f"0 <= bore < outer ({self.outer_diameter}) m"
            )
        if not self.width > 0.0:
            raise ValueError(f"width: {self.width} must be > 0 m")
        if not self.density > 0.0:
            raise ValueError(f"density: {self.density} must be > 0 kg/m^3")

    @property
    def mass(self) -> float:
        """m = rho pi (D^2 - d^2) w / 4, kg."""
        return self.density * np.pi / 4.0 * (self.outer_diameter**2 - self.bore_diameter**2) * self.width

    @property
    def polar_inertia(self) -> float:
        """I_p = m (R^2 + r^2) / 2 about the spin axis, kg m^2."""
        return self.mass * (self.outer_diameter**2 + self.bore_diameter**2) / 8.0

    @property
    def diametral_inertia(self) -> float:
        """I_d = m (3 (R^2 + r^2) + w^2) / 12 about a diameter through the centre, kg m^2."""
        r2 = (self.outer_diameter**2 + self.bore_diameter**2) / 4.0
        return self.mass * (3.0 * r2 + self.width**2) / 12.0

    def mass_matrix(self) -> np.ndarray:
        """M^d = diag(m, m, m, I_d, I_d, I_p) (Eqs 20, 32), 6x6."""
        m, i_d, i_p = self.mass, self.diametral_inertia, self.polar_inertia
        return np.diag([m, m, m, i_d, i_d, i_p])

    def gyroscopic_matrix(self) -> np.ndarray:
        """G^d per rad/s of spin (Eq 20), 6x6, skew-symmetric; couples theta_x and theta_y."""
        g = np.zeros((6, 6))
        g[3, 4] = self.polar_inertia
        g[4, 3] = -self.polar_inertia
        return g
