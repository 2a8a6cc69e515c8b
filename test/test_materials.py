"""Material fits against Table 1 (Sun et al. 2021) and the out-of-range policy."""

from __future__ import annotations

import warnings

import pytest

from gear_rotor_sim.materials import carbon_steel

TABLE1 = [(25.0, 207e9, 0.290), (125.0, 200e9, 0.294), (225.0, 189e9, 0.298), (325.0, 174e9, 0.302)]


@pytest.mark.parametrize(("t", "e", "nu"), TABLE1)
def test_table1_reproduced_exactly(t: float, e: float, nu: float) -> None:
    mat = carbon_steel()
    assert mat.youngs_modulus(t) == pytest.approx(e, rel=1e-12)
    assert mat.poisson_ratio(t) == pytest.approx(nu, rel=1e-12)
    assert mat.shear_modulus(t) == pytest.approx(e / (2.0 * (1.0 + nu)), rel=1e-12)


def test_fit_between_table_points_is_the_interpolating_quadratic() -> None:
    # E(T) of Table 1 has constant second difference (-4 GPa per 100 C squared): the parabola through the
    # points is E(T) = 208.125 - 0.04 T - 2e-4 T^2 GPa, so E(75) = 204.0 GPa and E(275) = 182.0 GPa.
    mat = carbon_steel()
    assert mat.youngs_modulus(75.0) == pytest.approx(204.0e9, rel=1e-12)
    assert mat.youngs_modulus(275.0) == pytest.approx(182.0e9, rel=1e-12)
    assert mat.poisson_ratio(175.0) == pytest.approx(0.296, rel=1e-12)
    assert mat.density == 7860.0
    assert mat.expansion_coefficient == 1.17e-5


@pytest.mark.parametrize("t", [24.9, 400.0, -10.0])
def test_out_of_range_error_names_field_and_range(t: float) -> None:
    with pytest.raises(ValueError, match=r"temperature_c.*25\.\.325"):
        carbon_steel().youngs_modulus(t)


def test_round_off_at_the_range_edge_is_in_range() -> None:
    """A temperature carried through a recording comes back as 24.99999999999999: in range; 1e-6 C
    beyond an edge is not."""
    mat = carbon_steel()
    assert mat.youngs_modulus(24.99999999999999) == pytest.approx(mat.youngs_modulus(25.0), rel=1e-12)
    assert mat.youngs_modulus(325.0 + 1e-13) == pytest.approx(mat.youngs_modulus(325.0), rel=1e-12)
    for t in (25.0 - 1e-6, 325.0 + 1e-6):
        with pytest.raises(ValueError, match=r"temperature_c"):
            mat.youngs_modulus(t)


def test_out_of_range_extrapolate_warns_once() -> None:
    mat = carbon_steel(out_of_range="extrapolate")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        e1 = mat.youngs_modulus(400.0)
        mat.youngs_modulus(425.0)
        mat.poisson_ratio(400.0)
    assert len(caught) == 1
    assert "temperature_c" in str(caught[0].message)
    assert e1 == pytest.approx((208.125 - 0.04 * 400.0 - 2e-4 * 400.0**2) * 1e9, rel=1e-12)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mat.youngs_modulus(200.0)  # inside the range: no warning
