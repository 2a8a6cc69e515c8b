"""Temperature-dependent isotropic material (Sec 2.1, Table 1).

E*(T) and nu(T) are least-squares polynomial fits to the tabulated values: quadratic for the elastic
modulus (Table 1 is exactly quadratic in T, so the fit reproduces it exactly) and linear for Poisson's
ratio (Table 1 is exactly linear). G*(T) = E*(T) / (2 (1 + nu(T))) (isotropy). Density and the linear
expansion coefficient are temperature independent, as in the paper.

Outside the tabulated range (25..325 C for Table 1) the behaviour is a configured choice,
``out_of_range``: ``"error"`` raises ``ValueError`` naming ``temperature_c`` and the range;
``"extrapolate"`` evaluates the fitted polynomials and warns once per material.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

OUT_OF_RANGE_POLICIES: tuple[str, ...] = ("error", "extrapolate")


@dataclass(frozen=True)
class Material:
    """Isotropic linear-elastic material with temperature-dependent E and nu.

    Parameters
    ----------
    name : str
        Name used in messages and in the config.
    density : float
        Mass density, kg/m^3.
    expansion_coefficient : float
        Linear thermal expansion coefficient ``a`` of Eq 2, 1/K.
    temperatures_c : tuple of float
        Temperatures of the table, deg C, strictly increasing.
    youngs_moduli : tuple of float
        Elastic modulus at each temperature, Pa.
    poisson_ratios : tuple of float
        Poisson's ratio at each temperature.
    out_of_range : str
        ``"error"`` or ``"extrapolate"``.
    reference_temperature_c : float
        Temperature of the unstressed, as-built state, deg C (Table 2 starts at 25 C).

    References
    ----------
    Sun, Chen, Hu, Lei (2021), Nonlinear Dynamics, Sec 2.1, Table 1, Eqs 11-12 (E*, G*).
    """

    name: str
    density: float
    expansion_coefficient: float
    temperatures_c: tuple[float, ...]
    youngs_moduli: tuple[float, ...]
    poisson_ratios: tuple[float, ...]
    out_of_range: str = "error"
    reference_temperature_c: float = 25.0
    _warned: list[bool] = field(default_factory=lambda: [False], init=False, repr=False, compare=False)
    _fits: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        t = np.asarray(self.temperatures_c, dtype=float)
        if not (len(t) == len(self.youngs_moduli) == len(self.poisson_ratios)) or len(t) == 0:
            raise ValueError(
                f"material {self.name!r}: temperature, modulus and Poisson lists differ in length"
            )
        if len(t) > 1 and np.any(np.diff(t) <= 0.0):
            raise ValueError(f"material {self.name!r}: temperature_c must be strictly increasing")
        if self.out_of_range not in OUT_OF_RANGE_POLICIES:
            raise ValueError(
                f"material {self.name!r}: out_of_range {self.out_of_range!r} is not "
                f"one of {OUT_OF_RANGE_POLICIES}"
            )

    # -- fits -------------------------------------------------------------------------------------
    @property
    def temperature_range_c(self) -> tuple[float, float]:
        """Tabulated temperature range (min, max), deg C."""
        return float(self.temperatures_c[0]), float(self.temperatures_c[-1])

    def _fit(self, values: tuple[float, ...], degree: int) -> np.ndarray:
        # The fits are computed once per material (the dataclass is frozen, its tables immutable).
        key = (id(values), degree)
        hit = self._fits.get(key)
        if hit is None:
            t = np.asarray(self.temperatures_c, dtype=float)
            deg = min(degree, len(t) - 1)
            # Fit in a centred, scaled variable for conditioning; coefficients refer to that variable.
            hit = np.polyfit((t - t.mean()) / 100.0, np.asarray(values, dtype=float), deg)
            self._fits[key] = hit
        return hit

    def _evaluate(self, coeffs: np.ndarray, temperature_c: float | np.ndarray) -> np.ndarray:
        t_mean = float(np.mean(self.temperatures_c))
        return np.polyval(coeffs, (np.asarray(temperature_c, dtype=float) - t_mean) / 100.0)

    def check_temperature(self, temperature_c: float | np.ndarray) -> None:
        """Apply the out-of-range policy to ``temperature_c`` (deg C).

        Raises
        ------
        ValueError
            If a temperature is non-finite, or outside the table and the policy is ``"error"``.
        """
        lo, hi = self.temperature_range_c
        if isinstance(temperature_c, float | int) and lo <= temperature_c <= hi:
            return  # the common scalar case, without array overhead
        tc = np.asarray(temperature_c, dtype=float)
        if not np.all(np.isfinite(tc)):
            raise ValueError(f"temperature_c: {temperature_c} is not finite (material {self.name!r})")
        # round-off of a temperature carried through a recording (24.99999999999999) is in range
        tol = 1e-9 * max(abs(lo), abs(hi), 1.0)
        if np.any(tc < lo - tol) or np.any(tc > hi + tol):
            if self.out_of_range == "error":
                raise ValueError(
                    f"temperature_c: {temperature_c} is outside the material range {lo:g}..{hi:g} C of "
                    f"{self.name!r} (out_of_range: error; allowed {lo:g} <= temperature_c <= {hi:g})"
                )
            if not self._warned[0]:
                self._warned[0] = True
                warnings.warn(
                    f"temperature_c: {temperature_c} is outside the material range {lo:g}..{hi:g} C of "
                    f"{self.name!r}; extrapolating the Table 1 fits (out_of_range: extrapolate)",
                    stacklevel=3,
                )

    def youngs_modulus(self, temperature_c: float) -> float:
        """Elastic modulus E*(T), Pa: quadratic least-squares fit of the table (Table 1, Eq 11)."""
        self.check_temperature(temperature_c)
        return float(self._evaluate(self._fit(self.youngs_moduli, 2), temperature_c))

    def poisson_ratio(self, temperature_c: float) -> float:
        """Poisson's ratio nu(T): linear least-squares fit of the table (Table 1)."""
        self.check_temperature(temperature_c)
        return float(self._evaluate(self._fit(self.poisson_ratios, 1), temperature_c))

    def shear_modulus(self, temperature_c: float) -> float:
        """Shear modulus G*(T) = E*(T) / (2 (1 + nu(T))), Pa (Eq 12)."""
        return self.youngs_modulus(temperature_c) / (2.0 * (1.0 + self.poisson_ratio(temperature_c)))


def carbon_steel(out_of_range: str = "error", reference_temperature_c: float = 25.0) -> Material:
    """Carbon steel of Table 1 (a = 1.17e-5 1/C, rho = 7860 kg/m^3).

    References
    ----------
    Sun et al. (2021), Table 1 (E, nu at 25..325 C), Sec 2.1 (expansion coefficient), Table 3 (density).
    """
    return Material(
        name="carbon_steel",
        density=7860.0,
        expansion_coefficient=1.17e-5,
        temperatures_c=(25.0, 125.0, 225.0, 325.0),
        youngs_moduli=(207e9, 200e9, 189e9, 174e9),
        poisson_ratios=(0.290, 0.294, 0.298, 0.302),
        out_of_range=out_of_range,
        reference_temperature_c=reference_temperature_c,
    )
