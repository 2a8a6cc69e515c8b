"""Support bearing: diagonal stiffness and damping (Sec 3.4, Eqs 37-38, Table 5).

The coupling between directions and the rotational stiffness and damping about the shaft axis are
ignored (Sec 3.4): the theta_z entries are zero. Radial values apply to x and y, tilt values to
theta_x and theta_y.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Bearing:
    """Linear bearing of Eq 37.

    Parameters
    ----------
    k_radial, k_axial : float
        k_xx = k_yy and k_zz, N/m.
    k_tilt : float
        k_theta_x = k_theta_y, N m/rad.
    c_radial, c_axial : float
        c_xx = c_yy and c_zz, N s/m.
    c_tilt : float
        c_theta_x = c_theta_y, N m s/rad.
    name : str
        Type name (``"A#"``, ...).

    References
    ----------
    Sun et al. (2021), Eqs 37-38, Table 5.
    """

    k_radial: float
    k_axial: float
    k_tilt: float
    c_radial: float
    c_axial: float
    c_tilt: float
    name: str = ""

    def stiffness_matrix(self) -> np.ndarray:
        """K^b = diag(k_xx, k_yy, k_zz, k_tx, k_ty, 0) (Eq 37), 6x6."""
        return np.diag([self.k_radial, self.k_radial, self.k_axial, self.k_tilt, self.k_tilt, 0.0])

    def damping_matrix(self) -> np.ndarray:
        """C^b = diag(c_xx, c_yy, c_zz, c_tx, c_ty, 0) (Eq 37), 6x6."""
        return np.diag([self.c_radial, self.c_radial, self.c_axial, self.c_tilt, self.c_tilt, 0.0])


BearingProperties = Bearing

#: Table 5 of Sun et al. (2021). A#: deep-groove ball bearing (small axial stiffness); B#, C#: angular
#: contact ball bearings (C# with the larger radial stiffness).
BEARING_TYPES: dict[str, Bearing] = {
    "A#": Bearing(
        k_radial=1.15e8, k_axial=2.28e7, k_tilt=2.08e4, c_radial=1e3, c_axial=1e3, c_tilt=1e3, name="A#"
    ),
    "B#": Bearing(
        k_radial=1.15e8, k_axial=1.02e8, k_tilt=2.08e4, c_radial=1e3, c_axial=1e3, c_tilt=1e3, name="B#"
    ),
    "C#": Bearing(
        k_radial=2.35e8, k_axial=1.02e8, k_tilt=2.08e4, c_radial=1e3, c_axial=1e3, c_tilt=1e3, name="C#"
    ),
}
