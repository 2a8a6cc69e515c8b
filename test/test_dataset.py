"""Dataset generation: sweep validation, interruption and resume, parallel back ends, write failures."""

from __future__ import annotations

import errno
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from roundoff import roundoff

from gear_rotor_sim.cli import main
from gear_rotor_sim.recording import dataset
from gear_rotor_sim.recording.dataset import DatasetError, generate, load_sweep, parse_sweep, sha256_file
from gear_rotor_sim.recording.record_cli import InputError
from gear_rotor_sim.recording.writer import _FileSink

REPO = Path(__file__).resolve().parents[1]


class FakeSimulator:
    """Stand-in for the streaming simulator with its interface: deterministic signals, no physics.

    The generation logic (scheduling, files, manifest, resume) is what these tests exercise; the
    real simulator is used by ``test_killed_generation_resumes`` and ``test_record_command_data``.
    """

    def __init__(self, cfg, speed_rpm=3000.0, temperature_c=25.0, output_rate_hz=20000.0, channels=None):
        self.channels = tuple(channels)
        self.rate = float(output_rate_hz)
        self.speed, self.temp = float(speed_rpm), float(temperature_c)
        self.n = 0

    @property
    def time_s(self) -> float:
        return self.n / self.rate

    def set_targets(self, speed_rpm=None, temperature_c=None) -> None:
        self.speed = self.speed if speed_rpm is None else speed_rpm
        self.temp = self.temp if temperature_c is None else temperature_c

    def advance(self, duration: float):
        from gear_rotor_sim.blocks import SampleBlock

        n = int(np.ceil((self.time_s + duration) * self.rate - 1e-9)) - self.n
        t = (self.n + np.arange(n)) / self.rate
        data = np.sin(np.outer(t, 1.0 + np.arange(len(self.channels))) * self.speed / 60.0)
        units = tuple("m" for _ in self.channels)
        speed, temp = np.full(n, self.speed), np.full(n, self.temp)
        b = SampleBlock(self.time_s, self.rate, self.channels, units, data, self.n, speed, temp)
        self.n += n
        return b


@pytest.fixture
def fake_sim(monkeypatch: pytest.MonkeyPatch) -> None:
    import gear_rotor_sim.simulator

    monkeypatch.setattr(gear_rotor_sim.simulator, "Simulator", FakeSimulator)


SWEEP = {
    "name": "tiny",
    "base": {"duration_s": 0.2, "sample_rate_hz": 5000, "block_s": 0.05, "temperature_c": 25},
    "grid": {"speed_rpm": [2000, 3000], "bearing_type": ["A#", "B#"]},
    "runs": [{"speed_rpm": 2500, "temperature_c": 80, "schedule": [{"at_s": 0.1, "speed_rpm": 2600}]}],
}


def write_sweep(tmp_path: Path, sweep: dict, name: str = "sweep.yaml") -> Path:
    p = tmp_path / name
    p.write_text(yaml.safe_dump(sweep))
    return p


def manifest(out: Path) -> dict:
    return json.loads((out / "manifest.json").read_text())


def check_manifest(out: Path, n_total: int, partial_allowed: bool = False) -> dict:
    m = manifest(out)
    assert m["runs_total"] == n_total and m["runs_finished"] == len(m["runs"])
    for e in m["runs"]:
        f = out / e["file"]
        assert sha256_file(f) == e["sha256"] and f.stat().st_size == e["bytes"]
        p = e["parameters"]
        n = round(p["duration_s"] * p["sample_rate_hz"])
        assert e["sample_counts"] == {"/gear_rotor/dte": n, "/gear_rotor/bearing_forces": n}
        assert abs(e["duration_s"] - p["duration_s"]) <= roundoff(p["duration_s"], 2)
    if not partial_allowed:
        assert not list(out.glob("*.part"))
    return m


# ---------------------------------------------------------------------------------------------
# validation
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"colour": "red"}, r"unknown key\(s\) \['colour'\]"),
        (
            {"base": {"duration_s": 0.2, "temperature_c": 25, "speeed_rpm": 1}},
            r"base: unknown key\(s\) \['speeed_rpm'\]",
        ),
        (
            {"grid": {"speed_rpm": [1000, -5]}},
            r"grid\(speed_rpm=-5\): speed_rpm: -5 is out of range \(allowed 0 <=",
        ),
        (
            {"grid": {"speed_rpm": [1000], "temperature_c": [25, 900]}},
            r"grid\(speed_rpm=1000, temperature_c=900\): temperature_c: 900 .*allowed 25 <= value <= 325",
        ),
        ({"grid": {"speed_rpm": ["fast"]}}, r"grid\(speed_rpm=fast\): speed_rpm: 'fast' is not a number"),
        (
            {"grid": {"speed_rpm": [1000], "bearing_type": ["Z#"]}},
            r"grid\(speed_rpm=1000, bearing_type=Z#\): bearings\[\].type: 'Z#' is not one of \['A#'",
        ),
        (
            {"grid": {"speed_rpm": [1000]}, "base": {"temperature_c": 25, "duration_s": 0}},
            r"duration_s: 0 is out of range",
        ),
        ({"grid": {"speed_rpm": []}}, r"grid.speed_rpm: expected a non-empty list"),
        ({"grid": {"speed_rpm": [1000, 1000]}}, r"same parameters as"),
        (
            {"runs": [{"speed_rpm": 1, "schedule": [{"at_s": 0.1, "rpm": 2}]}]},
            r"runs\[0\].schedule\[0\]: unknown key",
        ),
        ({"runs": [{"speed_rpm": 1, "schedule": [{"at_s": 9, "speed_rpm": 2}]}]}, r"at_s: 9 is out of range"),
        ({"recording": {"qos": "fastest"}}, r"recording.qos: 'fastest'"),
        ({"runs": [{"speed_rpm": 1, "streams": ["dte", "sound"]}]}, r"streams: \['sound'\] not known"),
    ],
)
def test_bad_sweeps_name_the_key(change: dict, message: str) -> None:
    raw = {"base": {"duration_s": 0.2, "temperature_c": 25}, **change}
    if "grid" not in raw and "runs" not in raw:
        raw["runs"] = [{"speed_rpm": 1000}]
    with pytest.raises(InputError, match=message):
        parse_sweep(raw)


def test_bad_sweep_files_via_cli(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    (tmp_path / "bad.yaml").write_text("base: [1, 2\n")
    assert main(["dataset", str(tmp_path / "bad.yaml"), "--out", str(tmp_path / "o")]) == 2
    assert "not valid YAML" in capsys.readouterr().err
    (tmp_path / "evil.yaml").write_text("!!python/object/apply:os.system ['echo hi']\n")
    assert main(["dataset", str(tmp_path / "evil.yaml"), "--out", str(tmp_path / "o")]) == 2
    assert main(["dataset", str(tmp_path / "missing.yaml"), "--out", str(tmp_path / "o")]) == 2
    assert not (tmp_path / "o").exists()


def test_unwritable_output_folder(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("x")
    sweep = write_sweep(tmp_path, SWEEP)
    assert main(["dataset", str(sweep), "--out", str(blocker / "sub"), "--workers", "1"]) == 1
    assert "cannot create output folder" in capsys.readouterr().err
    assert blocker.read_text() == "x"


# ---------------------------------------------------------------------------------------------
# interruption and resume
# ---------------------------------------------------------------------------------------------
def test_interrupt_and_resume(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fake_sim: None) -> None:
    sweep = load_sweep(write_sweep(tmp_path, SWEEP))
    assert len(sweep.runs) == 5
    out = tmp_path / "ds"
    real = dataset.execute_run
    calls: list[str] = []

    def interrupted_after_two(*args):
        if len(calls) == 2:
            raise KeyboardInterrupt
        calls.append(args[4])
        return real(*args)

    monkeypatch.setattr(dataset, "execute_run", interrupted_after_two)
    with pytest.raises(KeyboardInterrupt):
        generate(sweep, out, workers=1)
    m = check_manifest(out, 5)
    assert [e["id"] for e in m["runs"]] == calls
    first_files = {e["file"]: (out / e["file"]).stat().st_mtime_ns for e in m["runs"]}

    calls.clear()
    monkeypatch.setattr(dataset, "execute_run", lambda *a: (calls.append(a[4]), real(*a))[1])
    report = generate(sweep, out, workers=1)
    assert len(report.skipped) == 2 and len(report.done) == 3 and len(calls) == 3
    m = check_manifest(out, 5)
    assert [e["id"] for e in m["runs"]] == [r.run_id for r in sweep.runs]
    for f, mtime in first_files.items():
        assert (out / f).stat().st_mtime_ns == mtime  # finished runs were not redone

    # a damaged file is detected by its checksum and only that run is redone
    damaged = out / m["runs"][3]["file"]
    raw = bytearray(damaged.read_bytes())
    raw[len(raw) // 2] ^= 0xFF
    damaged.write_bytes(bytes(raw))
    calls.clear()
    report = generate(sweep, out, workers=1)
    assert calls == [m["runs"][3]["id"]] and report.redone == calls
    check_manifest(out, 5)

    # a different sweep is refused in the same folder
    other = load_sweep(write_sweep(tmp_path, {**SWEEP, "name": "other"}, "other.yaml"))
    with pytest.raises(DatasetError, match="different sweep"):
        generate(other, out, workers=1)

    # the files hold the (fake) simulator's blocks
    run0 = sweep.runs[0]
    expected = FakeSimulator(None, run0.params.speed_rpm, 25.0, 5000.0, ["dte", "mesh_force"]).advance(0.2)
    with open(out / run0.file, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        got = [d for _s, ch, _m, d in reader.iter_decoded_messages() if ch.topic == "/gear_rotor/dte"]
    data = np.concatenate([np.asarray(d.data).reshape(-1, 2) for d in got])
    assert np.array_equal(data, expected.data)


def test_killed_generation_resumes(tmp_path: Path) -> None:
    sweep_file = write_sweep(
        tmp_path,
        {"base": {"duration_s": 0.5, "sample_rate_hz": 5000, "temperature_c": 25},
         "grid": {"speed_rpm": [3000, 3001, 3002]}},
    )  # fmt: skip
    out = tmp_path / "ds"
    env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    cmd = [
        sys.executable,
        "-m",
        "gear_rotor_sim.cli",
        "dataset",
        str(sweep_file),
        "--out",
        str(out),
        "--workers",
        "1",
    ]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
    deadline = time.monotonic() + 90
    try:
        while time.monotonic() < deadline and proc.poll() is None:
            if (out / "manifest.json").exists() and manifest(out)["runs_finished"] >= 1:
                break
            time.sleep(0.02)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    # killed while the next run may already be writing its <file>.part: the manifest holds only
    # finished runs; the resume below removes the stale part (check_manifest then asserts none)
    m = check_manifest(out, 3, partial_allowed=True)
    assert 1 <= len(m["runs"]) < 3
    kept = {e["file"]: (out / e["file"]).stat().st_mtime_ns for e in m["runs"]}
    report = generate(load_sweep(sweep_file), out, workers=1)
    assert len(report.skipped) == len(kept) and len(report.done) == 3 - len(kept)
    check_manifest(out, 3)
    assert all((out / f).stat().st_mtime_ns == t for f, t in kept.items())


# ---------------------------------------------------------------------------------------------
# parallel back ends
# ---------------------------------------------------------------------------------------------
def test_process_pool(tmp_path: Path, fake_sim: None) -> None:
    sweep = parse_sweep({"base": {"duration_s": 0.1, "sample_rate_hz": 5000, "temperature_c": 25},
                         "grid": {"speed_rpm": [2000, 3000]}})  # fmt: skip
    report = generate(sweep, tmp_path / "pool", workers=2)
    assert len(report.done) == 2
    check_manifest(tmp_path / "pool", 2)


def test_dask_cluster(tmp_path: Path, fake_sim: None) -> None:
    distributed = pytest.importorskip("dask.distributed")
    sweep = parse_sweep({"base": {"duration_s": 0.1, "sample_rate_hz": 5000, "temperature_c": 25},
                         "grid": {"speed_rpm": [2000, 3000]}})  # fmt: skip
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None
    ) as cl:
        report = generate(sweep, tmp_path / "dask", scheduler=cl.scheduler_address)
    assert len(report.done) == 2
    check_manifest(tmp_path / "dask", 2)
    with pytest.raises(DatasetError, match="cannot connect to the Dask scheduler"):
        generate(sweep, tmp_path / "dask2", scheduler="tcp://127.0.0.1:1", scheduler_timeout_s=1.0)


# ---------------------------------------------------------------------------------------------
# full disk
# ---------------------------------------------------------------------------------------------
def test_full_disk_keeps_finished_runs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fake_sim: None
) -> None:
    sweep = load_sweep(write_sweep(tmp_path, SWEEP))
    out = tmp_path / "ds"
    real_write = _FileSink._write
    budget = {"left": None}
    real = dataset.execute_run

    def run_then_fill_disk(*args):
        entry = real(*args)
        budget["left"] = 20_000  # the disk fills up during the next run
        return entry

    def limited(self, view):
        if budget["left"] is not None:
            if len(view) > budget["left"]:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
            budget["left"] -= len(view)
        return real_write(self, view)

    monkeypatch.setattr(dataset, "execute_run", run_then_fill_disk)
    monkeypatch.setattr(_FileSink, "_write", limited)
    with pytest.raises(DatasetError, match="No space left on device"):
        generate(sweep, out, workers=1)
    m = check_manifest(out, 5)
    assert len(m["runs"]) == 1
    before = {e["file"]: sha256_file(out / e["file"]) for e in m["runs"]}
    manifest_before = (out / "manifest.json").read_bytes()

    # the manifest cannot be rewritten either while the disk is full: the old one stays intact
    def full(*_a, **_k):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    with monkeypatch.context() as mp:
        mp.setattr(dataset.json, "dump", full)
        with pytest.raises(OSError, match="No space"):
            dataset.write_json_atomic(out / "manifest.json", {"broken": True})
    assert (out / "manifest.json").read_bytes() == manifest_before
    monkeypatch.setattr(dataset, "execute_run", real)
    monkeypatch.setattr(_FileSink, "_write", real_write)

    assert {f: sha256_file(out / f) for f in before} == before
    report = generate(sweep, out, workers=1)
    assert len(report.skipped) == 1 and len(report.done) == 4
    check_manifest(out, 5)
