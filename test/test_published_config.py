"""The as-published configuration (gear mass in Eq 20 and Eq 32) and the unchanged default."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import scipy.linalg as sla
from roundoff import roundoff

from gear_rotor_sim.analysis.bifurcation import Case, build_config
from gear_rotor_sim.config import ConfigError, load_config
from gear_rotor_sim.examples import PAPER_CONFIGS, paper_gearbox
from gear_rotor_sim.system import GearRotorSystem, gear_disc

PUB = "paper_sun2021_as_published"


@pytest.fixture(scope="module")
def systems():
    default = GearRotorSystem.from_config(paper_gearbox(), 25.0)
    published = GearRotorSystem.from_config(paper_gearbox(config=PUB), 25.0)
    return default, published


def test_as_published_file_differs_from_default_only_in_the_switch() -> None:
    d, p = load_config("paper_sun2021"), load_config(PUB)
    assert p.name == PUB
    assert all(m.gear_mass_in_mesh_matrix for m in p.meshes)
    assert not any(m.gear_mass_in_mesh_matrix for m in d.meshes)
    switched = p.replace(
        name=d.name,
        meshes=tuple(dataclasses.replace(m, gear_mass_in_mesh_matrix=False) for m in p.meshes),
    )
    assert switched == d


def test_default_assembly_has_no_pair_mass_and_the_switch_adds_eq32(systems) -> None:
    default, published = systems
    cfg = paper_gearbox()
    # everything but M is bitwise the default
    for name in ("K", "C", "G", "static_load", "thermal_load"):
        assert np.array_equal(getattr(default, name), getattr(published, name)), name
    np.testing.assert_array_equal(default.meshes[0].line_of_action, published.meshes[0].line_of_action)
    # M: the default plus M^g of Eq 32 = diag(m, m, m, J_d, J_d, J_p) of each gear at its node
    expected = default.M.copy()
    for g in cfg.gears:
        idx = np.arange(6 * g.node0, 6 * g.node0 + 6)
        expected[np.ix_(idx, idx)] += gear_disc(cfg, g).mass_matrix()
    err = np.abs(published.M - expected).max()
    assert err <= roundoff(np.abs(expected).max(), 2)
    changed = np.abs(published.M - default.M) > 0
    gear_dofs = {6 * g.node0 + j for g in cfg.gears for j in range(6)}
    assert {int(i) for i in np.nonzero(changed.any(axis=1))[0]} == gear_dofs


def test_mesh_element_is_the_default_one(systems) -> None:
    # only the assembly of M changes; the mesh (stiffness table, c_m from the gears' own inertias,
    # backlash, transmission error) is bitwise the default one
    default, published = systems
    a, b = default.meshes[0], published.meshes[0]
    assert a.damping == b.damping and a.mean_stiffness == b.mean_stiffness
    assert a.half_backlash == b.half_backlash
    np.testing.assert_array_equal(a.force_basis, b.force_basis)


def _eigenfrequencies(system) -> tuple[np.ndarray, np.ndarray]:
    m = system.meshes[0]
    v, f = m.line_of_action, system.free_dofs
    k = (system.K + m.mean_stiffness * np.outer(v, v))[np.ix_(f, f)]
    w2, x = sla.eigh(k, system.M[np.ix_(f, f)])
    share = m.mean_stiffness * (v[f] @ x) ** 2 / np.abs(w2)
    return w2, share


def test_spectrum_bounded_by_mass_ordering(systems) -> None:
    # M_def <= M_pub <= 2 M_def (Loewner order), so by Courant-Fischer every eigenvalue obeys
    # lambda_def / 2 <= lambda_pub <= lambda_def, index by index
    default, published = systems
    w_def, _ = _eigenfrequencies(default)
    w_pub, _ = _eigenfrequencies(published)
    # (modes without gear motion keep their eigenvalue: equality up to the relative round-off)
    rel = roundoff(1.0, w_def.size)
    assert np.all(w_pub <= w_def * (1 + rel))
    assert np.all(w_pub >= w_def / 2 * (1 - rel))
    assert np.any(w_pub < w_def * (1 - 1e-3))  # and the gear modes do move


def test_published_mesh_mode_where_the_paper_bands_point(systems) -> None:
    # Fig 6a's band (13500-14700 rpm, z1 = 29) and Sec 4.3's chaotic ranges put the mesh mode near
    # 4.0-4.1 kHz; the default model has it at 5.29 kHz
    freqs = {}
    for name, system in zip(("default", "published"), systems, strict=True):
        w2, share = _eigenfrequencies(system)
        fr = np.sqrt(np.abs(w2)) / (2 * np.pi)
        i = int(np.argmax(np.where(fr < 20e3, share, 0.0)))
        freqs[name] = fr[i]
    assert 5.2e3 < freqs["default"] < 5.4e3
    assert 3.9e3 < freqs["published"] < 4.1e3


def test_named_configuration_errors() -> None:
    with pytest.raises(ValueError, match=r"config: 'paper_sun2021_typo' is not one of"):
        paper_gearbox(config="paper_sun2021_typo")
    assert set(PAPER_CONFIGS) == {"paper_sun2021", PUB}
    d = {**_raw(PUB)}
    d["meshes"] = [{**d["meshes"][0], "gear_mass_in_mesh_matrix": "yes"}]
    with pytest.raises(
        ConfigError, match=r"meshes\[0\]\.gear_mass_in_mesh_matrix: 'yes' must be true or false"
    ):
        load_config(d)


def _raw(name: str) -> dict:
    import yaml

    from gear_rotor_sim.config import config_dirs

    return yaml.safe_load((config_dirs()[0] / f"{name}.yaml").read_text(encoding="utf-8"))


def test_case_carries_the_configuration() -> None:
    c = Case(25.0, config=PUB)
    assert Case.from_json(c.to_json()) == c
    assert "as_published" in c.label()
    # a case saved before the field existed loads as the default configuration
    old = '{"temperature_c": 25.0, "bearing_type": "A#", "thermal_backlash": true, "overrides": []}'
    assert Case.from_json(old) == Case(25.0)
    assert all(m.gear_mass_in_mesh_matrix for m in build_config(c).meshes)


def test_merge_windows_joins_gaps_below_the_threshold() -> None:
    from gear_rotor_sim.analysis.reproduce import merge_windows

    ws = [(14225.0, 14675.0), (12775.0, 13900.0), (14000.0, 14150.0), (15050.0, 15075.0)]
    assert merge_windows(ws, 250.0) == [(12775.0, 14675.0), (15050.0, 15075.0)]
    assert merge_windows(ws, 50.0) == sorted(ws)


def test_reproduce_with_the_published_config(tmp_path) -> None:
    import contextlib
    import io
    import json

    from gear_rotor_sim import cli

    def run(*extra: str) -> dict:
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf):
            args = ["reproduce", "--level", "tiny", "--json", "--workers", "1", "--out", str(tmp_path)]
            assert cli.main([*args, *extra]) == 0
        return json.loads(buf.getvalue())

    default = run()
    published = run("--config", PUB)
    assert "fig6_25c_main_chaotic_band_rpm" not in default
    assert set(published) == set(default) | {"fig6_25c_main_chaotic_band_rpm"}
    assert len(published["fig6_25c_main_chaotic_band_rpm"]) == 2
    assert (tmp_path / "figures" / "data" / f"reproduce_tiny_{PUB}.json").is_file()
    png = tmp_path / "figures" / PUB / "fig6_bifurcation.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    report = (tmp_path / "REPRODUCTION.md").read_text(encoding="utf-8")
    assert "## As-published configuration (`paper_sun2021_as_published`)" in report
    assert "--config paper_sun2021_as_published" in report
