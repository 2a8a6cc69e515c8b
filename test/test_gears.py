"""Gear geometry, potential-energy mesh stiffness, thermal backlash (Eqs 13-18, 27) vs independent truth."""

from __future__ import annotations

import math

import numpy as np
import pytest
from roundoff import roundoff
from scipy.integrate import quad
from scipy.optimize import brentq

from gear_rotor_sim.gears import (
    SpurGearPair,
    beam_compliances,
    paper_gear_pair,
    validate_pair,
)
from gear_rotor_sim.materials import carbon_steel
from gear_rotor_sim.validation_report import gear_rows

ALPHA = math.radians(20.0)
E25, E225 = 207e9, 189e9  # Table 1
NU25, NU225 = 0.290, 0.298  # Table 1


@pytest.fixture(scope="module")
def pair() -> SpurGearPair:
    return paper_gear_pair(carbon_steel())


def test_geometry_and_contact_ratio_by_hand(pair: SpurGearPair) -> None:
    # Textbook closed form for 29/49 teeth, m = 3 mm, 20 deg, h_a* = 1 (radii in mm).
    ra1, ra2 = 43.5 + 3.0, 73.5 + 3.0
    rb1, rb2 = 43.5 * math.cos(ALPHA), 73.5 * math.cos(ALPHA)
    eps = (math.sqrt(ra1**2 - rb1**2) + math.sqrt(ra2**2 - rb2**2) - 117.0 * math.sin(ALPHA)) / (
        math.pi * 3.0 * math.cos(ALPHA)
    )
    assert pair.contact_ratio == pytest.approx(eps, rel=1e-12)
    assert 1.69 < eps < 1.71
    assert pair.base_radius(False) == pytest.approx(0.06906741, rel=1e-6)
    assert pair.root_radius(True) == pytest.approx(0.03975, rel=1e-12)
    assert pair.root_radius(False) == pytest.approx(0.06975, rel=1e-12)
    assert pair.base_pitch == pytest.approx(math.pi * 3e-3 * math.cos(ALPHA), rel=1e-12)


def test_double_contact_fraction_equals_contact_ratio_minus_one(pair: SpurGearPair) -> None:
    n = 2000
    table = pair.mesh_stiffness_table(25.0, n_points=n)
    assert table.double_contact_fraction == pytest.approx(pair.contact_ratio - 1.0, abs=1.5 / n)
    assert set(np.unique(table.n_pairs)) == {1, 2}
    # Double contact is stiffer than single contact everywhere.
    assert table.stiffness[table.n_pairs == 2].min() > table.stiffness[table.n_pairs == 1].max()
    np.testing.assert_allclose(table.load_share.sum(axis=1), 1.0, rtol=1e-12)
    np.testing.assert_allclose(table.load_share[table.n_pairs == 1].max(axis=1), 1.0, rtol=1e-12)


def test_rectangular_cantilever_limits() -> None:
    # Constant section 2h x L, length d: tip deflection d^3/(3EI) bending, 1.2 d/(GA) shear, d/(EA) axial.
    e, g, L, h, d = 200e9, 80e9, 0.02, 0.002, 0.01
    x, w = np.polynomial.legendre.leggauss(8)
    y = (d * (x + 1) / 2)[None, :]
    wy = (w * d / 2)[None, :]
    hh = np.full_like(y, h)
    inertia, area = 2 * h**3 * L / 3, 2 * h * L
    kb, ks, ka = beam_compliances(y, wy, hh, np.array([d]), np.array([h]), np.array([0.0]), e, g, L)
    assert kb[0] == pytest.approx(d**3 / (3 * e * inertia), rel=1e-12)
    assert ks[0] == pytest.approx(1.2 * d / (g * area), rel=1e-12)
    assert abs(ka[0]) <= roundoff(d / (e * area))  # sin(0) = 0: no axial part
    kb, ks, ka = beam_compliances(y, wy, hh, np.array([d]), np.array([0.0]), np.array([math.pi / 2]), e, g, L)
    assert ka[0] == pytest.approx(d / (e * area), rel=1e-12)
    assert abs(kb[0]) <= roundoff(d**3 / (3 * e * inertia))  # cos(pi/2) = 6e-17, not 0: round-off


def test_tooth_energy_integrals_match_tian_closed_form() -> None:
    # Root circle on the base circle (z = 42, c* chosen so r_f = r_b): Tian's (2004) angular integrals apply.
    z, m, ha = 42, 3e-3, 1.0
    c = z / 2 * (1 - math.cos(ALPHA)) - ha
    mat = carbon_steel()
    p = SpurGearPair(z, 60, m, ALPHA, 0.02, ha, c, mat, mat, 0.03, 0.03)
    assert p.root_radius(True) == pytest.approx(p.base_radius(True), rel=1e-12)
    e, nu, L = mat.youngs_modulus(25.0), mat.poisson_ratio(25.0), 0.02
    a2 = math.pi / (2 * z) + math.tan(ALPHA) - ALPHA
    for roll in (0.15, 0.36, 0.5):
        a1 = roll - a2  # tan(alpha_r) - alpha_2

        def den(a: float) -> float:
            return math.sin(a) + (a2 - a) * math.cos(a)

        kb = quad(
            lambda a, a1=a1: 3 * (1 + math.cos(a1) * ((a2 - a) * math.sin(a) - math.cos(a))) ** 2
            * (a2 - a) * math.cos(a) / (2 * e * L * den(a) ** 3),
            -a1, a2,
        )[0]  # fmt: skip
        ks = quad(
            lambda a, a1=a1: 1.2 * (1 + nu) * (a2 - a) * math.cos(a) * math.cos(a1) ** 2 / (e * L * den(a)),
            -a1, a2,
        )[0]  # fmt: skip
        ka = quad(
            lambda a, a1=a1: (a2 - a) * math.cos(a) * math.sin(a1) ** 2 / (2 * e * L * den(a)), -a1, a2
        )[0]
        tc = p.tooth_compliance(np.array([roll]), True, 25.0)
        assert tc.bending[0] == pytest.approx(kb, rel=1e-6)
        assert tc.shear[0] == pytest.approx(ks, rel=1e-6)
        assert tc.axial[0] == pytest.approx(ka, rel=1e-6)


def test_hertz_stiffness_and_series_limit(pair: SpurGearPair) -> None:
    kh = math.pi * E25 * 0.02 / (4 * (1 - NU25**2))
    assert pair.hertz_stiffness(25.0) == pytest.approx(kh, rel=1e-9)
    table = pair.mesh_stiffness_table(25.0)
    # Springs in series: a single pair is softer than its Hertzian contact alone.
    assert table.stiffness[table.n_pairs == 1].max() < kh


def test_mean_stiffness_within_iso_6336_band(pair: SpurGearPair) -> None:
    # ISO 6336-1: q' = C1 + C2/z1 + C3/z2 (mm um/N), c' = 0.8/q', c_gamma = c' (0.75 eps + 0.25), times b.
    q = 0.04723 + 0.15551 / 29 + 0.25791 / 49
    c_gamma_b = 0.8 / q * (0.75 * pair.contact_ratio + 0.25) * 20.0 * 1e6  # N/um -> N/m
    iso = pair.iso_mesh_stiffness()
    assert iso["mesh_stiffness"] == pytest.approx(c_gamma_b, rel=1e-9)
    ratio = pair.mesh_stiffness_table(25.0).mean / c_gamma_b
    # Band 0.70..1.30: ISO's c_gamma is an empirical mean for standard gears; potential-energy models with
    # the Sainsot fillet foundation are reported within about +-30 % of it (Ma et al. 2015, Chaari 2009).
    assert 0.70 <= ratio <= 1.30


def test_stiffness_scales_with_elastic_modulus(pair: SpurGearPair) -> None:
    r = pair.mesh_stiffness_table(225.0).mean / pair.mesh_stiffness_table(25.0).mean
    e_ratio = E225 / E25
    # Bending/axial/fillet scale with E, shear with E/(1+nu), Hertz with E/(1-nu^2): the series/parallel
    # combination lies between the extreme factors.
    factors = [1.0, (1 + NU25) / (1 + NU225), (1 - NU25**2) / (1 - NU225**2)]
    assert e_ratio * min(factors) - 1e-12 <= r <= e_ratio * max(factors) + 1e-12
    assert r == pytest.approx(e_ratio, rel=0.01)


def test_sliding_sign_reverses_at_pitch_point(pair: SpurGearPair) -> None:
    table = pair.mesh_stiffness_table(25.0, n_points=1024)
    s = table.contact_position
    in_contact = np.isfinite(s)
    r_pinion = np.sqrt(pair.base_radius(True) ** 2 + np.where(in_contact, s, 0.0) ** 2)
    r_pitch = 3e-3 * 29 / 2  # m z / 2
    expect = np.where(in_contact, np.sign(r_pinion - r_pitch), 0.0)
    np.testing.assert_array_equal(table.sliding_sign, expect)
    assert (table.sliding_sign == -1).any() and (table.sliding_sign == 1).any()


def test_table_interpolation_is_periodic(pair: SpurGearPair) -> None:
    table = pair.mesh_stiffness_table(125.0, n_points=256)
    np.testing.assert_allclose(table.interpolate(table.phase), table.stiffness)
    assert table.interpolate(1.0 + 0.3) == pytest.approx(table.interpolate(0.3))
    assert table.interpolate(0.999999) == pytest.approx(table.stiffness[0], rel=1e-3)


def _half_thickness_angle_geometric(rb: float, a2: float, radius: float, scale: float) -> float:
    """Half angular tooth thickness at ``radius`` of an involute flank scaled by ``scale`` about the centre.

    The flank is built in Cartesian coordinates by unwinding a string from the base circle, starting at
    polar angle alpha_2 from the tooth centre line, then scaled; the point at ``radius`` is found numerically.
    """

    def point(t: float) -> np.ndarray:
        th = a2 - t
        radial = np.array([math.cos(th), math.sin(th)])
        return scale * rb * (radial + t * np.array([-math.sin(th), math.cos(th)]))

    t = brentq(lambda t: float(np.hypot(*point(t))) - radius, 0.0, 2.0)
    x, y = point(t)
    return math.atan2(y, x)


@pytest.mark.parametrize("pinion", [True, False])
@pytest.mark.parametrize("alpha_k_deg", [None, 24.0])
def test_thermal_profile_error_closed_form_and_geometry(
    pair: SpurGearPair, pinion: bool, alpha_k_deg: float | None
) -> None:
    dt, lam = 200.0, 1.17e-5
    z = 29 if pinion else 49
    rb = 3e-3 * z / 2 * math.cos(ALPHA)
    ak = ALPHA if alpha_k_deg is None else math.radians(alpha_k_deg)
    de = pair.thermal_profile_error(25.0 + dt, 25.0, pinion, None if alpha_k_deg is None else ak)
    if alpha_k_deg is None:
        assert de == pytest.approx(-dt * lam * rb * math.pi / (2 * z), rel=1e-12)  # pitch point
    # Geometry: expand the tooth by (1 + lam dT); growth of the half thickness at point k along the LOA.
    a2 = math.pi / (2 * z) + math.tan(ALPHA) - ALPHA
    rk = rb / math.cos(ak)
    eps = lam * dt
    psi0 = _half_thickness_angle_geometric(rb, a2, rk, 1.0)
    psi1 = _half_thickness_angle_geometric(rb, a2, rk * (1 + eps), 1.0 + eps)
    growth_along_loa = (rk * (1 + eps) * psi1 - rk * psi0) * math.cos(ak)
    assert de == pytest.approx(-growth_along_loa, rel=1e-7)
    assert de < 0.0


def test_thermal_half_backlash(pair: SpurGearPair) -> None:
    b = 35e-6
    assert pair.thermal_half_backlash(b, 25.0, 25.0) == b  # zero rise: exactly b
    assert pair.thermal_half_backlash(b, 225.0, 25.0, thermal_backlash=False) == b
    expect = b - 200.0 * 1.17e-5 * math.pi * 3e-3 * math.cos(ALPHA) / 4  # |2 de|/2, de = -dT l pi m cos/4
    assert pair.thermal_half_backlash(b, 225.0, 25.0) == pytest.approx(expect, rel=1e-12)
    with pytest.raises(ValueError, match="temperature_c"):
        pair.thermal_half_backlash(1e-6, 225.0, 25.0)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"pinion_teeth": 12}, "pinion_teeth"),
        ({"pinion_teeth": 20.5}, "pinion_teeth"),
        ({"module": 0.0}, "module"),
        ({"face_width": -1e-3}, "face_width"),
        ({"pressure_angle": math.radians(45.0)}, "pressure_angle"),
        ({"clearance_coefficient": 0.0}, "clearance_coefficient"),
        (
            {"pinion_teeth": 6, "gear_teeth": 6, "addendum_coefficient": 1.5, "allow_undercut": True},
            "pointed",
        ),
        ({"pinion_teeth": 40, "gear_teeth": 40, "addendum_coefficient": 0.5}, "contact ratio"),
    ],
)
def test_validate_pair_rejects_invalid_gears(kwargs: dict, field: str) -> None:
    args = {
        "pinion_teeth": 29,
        "gear_teeth": 49,
        "module": 3e-3,
        "pressure_angle": ALPHA,
        "face_width": 0.02,
        "addendum_coefficient": 1.0,
        "clearance_coefficient": 0.25,
    }
    args.update(kwargs)
    with pytest.raises(ValueError, match=field):
        validate_pair(**args)


def test_undercut_allowed_on_request() -> None:
    z_min = 2 / math.sin(ALPHA) ** 2  # 17.1 for 20 deg
    validate_pair(18, 49, 3e-3, ALPHA, 0.02)
    assert 17 < z_min < 18
    with pytest.raises(ValueError, match="undercut"):
        validate_pair(17, 49, 3e-3, ALPHA, 0.02)
    validate_pair(17, 49, 3e-3, ALPHA, 0.02, allow_undercut=True)


def test_missing_bore_is_named() -> None:
    mat = carbon_steel()
    p = SpurGearPair(29, 49, 3e-3, ALPHA, 0.02, material_pinion=mat, material_gear=mat)
    with pytest.raises(ValueError, match="bore_diameter_pinion"):
        p.mesh_stiffness_table(25.0)


def test_validation_rows_against_hand_values() -> None:
    """The gear rows of docs/validation.md (validation_report.gear_rows) hold the numbers worked out by
    hand for Table 3's pair: contact ratio 1.6985 (textbook closed form); ISO 6336-1
    q' = 0.04723 + 0.15551/29 + 0.25791/49 = 0.057856 mm um/N, c' = 0.8 / q' x 207/206 = 13.895 N/(mm um),
    c_gamma b = c' (0.75 x 1.6985 + 0.25) x 20 mm = 4.2347e8 N/m; E(225)/E(25) = 189/207 (Table 1); at
    225 C (dT = 200 C, l = 1.17e-5) the pitch-point profile error -dT l m cos(20 deg) pi / 4 = -5.1810 um
    on both wheels (r_b / z is the same) and b* = 35 - 5.1810 = 29.8190 um."""
    rows = {r["check"].split(" (")[0].split(",")[0]: r for r in gear_rows()}
    assert all(set(r) == {"check", "reference", "ours", "error"} for r in rows.values())

    def first(text: str) -> float:
        return float(text.split()[0])

    eps = rows["contact ratio 29/49"]
    assert first(eps["reference"]) == pytest.approx(1.6985, abs=5e-5)
    assert abs(first(eps["ours"]) - 1.6985) <= 1.0 / 512  # the 512-point phase grid
    iso = rows["mean mesh stiffness at 25 C vs ISO 6336-1 c_gamma_alpha b"]
    assert first(iso["reference"]) == pytest.approx(4.2347e8, rel=2e-4)
    assert 0.70 <= first(iso["ours"]) / first(iso["reference"]) <= 1.30
    assert first(rows["mean stiffness ratio k(225 C)/k(25 C) vs E(225)/E(25)"]["reference"]) == pytest.approx(
        189.0 / 207.0, abs=5e-5
    )
    de = -200.0 * 1.17e-5 * 3e-3 * math.cos(ALPHA) * math.pi / 4.0 * 1e6  # um
    assert de == pytest.approx(-5.1810, abs=5e-5)
    for wheel in ("pinion", "gear"):
        assert first(rows[f"thermal profile error {wheel} at 225 C"]["ours"]) == pytest.approx(de, abs=5e-5)
    b_star = rows["thermal half backlash b* at 225 C"]
    assert first(b_star["ours"]) == pytest.approx(35.0 + de, abs=5e-5)
