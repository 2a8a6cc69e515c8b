"""Every command README.md (and docs/live.md) shows runs as written (issue 14).

Commands are read from the Markdown itself: each line of a ``bash`` code block (comments after
``#`` removed), each ``python`` code block, and the ``gear-rotor-sim ...`` forms in the README's
command table. Each command must be handled by exactly one rule below, so a command added to the
README without a way to run it here fails :func:`test_every_readme_command_is_covered`.

Shortened where the command runs for long or forever, by options the commands document:
``bash scripts/demo.sh --real-time-factor 10`` (the demo's own option), ``gear-rotor-sim serve ...
--duration-s 0.5 --port 0``, and the README's Python example with 0.01 s instead of 0.5 s chunks.
``bash scripts/test.sh`` is not run inside the test suite it starts: the test checks that it is
exactly what CI runs (``.ci/run``). The block for a machine with ROS 2 from apt needs
``/opt/ros/jazzy``: where it exists the block runs as written; elsewhere each of its commands is
checked against what this checkout provides (``pip install -r requirements.txt`` runs; ``colcon
build --base-paths . msg_defs`` is what scripts/setup_env.sh builds; ``install/setup.bash`` exists;
``ros2 run gear_rotor_sim simulator`` resolves to the installed executable that the demo runs
with the same parameter file).
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
DOCS_WITH_COMMANDS = (README, ROOT / "docs" / "live.md")
APT_ROS = Path("/opt/ros/jazzy/setup.bash")
ENV = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}


def code_blocks(path: Path) -> list[tuple[str, str]]:
    """(language, text) of every fenced code block."""
    return [(m.group(1), m.group(2)) for m in re.finditer(r"```(\w*)\n(.*?)```", path.read_text(), re.S)]


def bash_commands(text: str) -> list[str]:
    out = []
    for line in text.splitlines():
        line = re.sub(r"\s+#.*$", "", line).strip()
        if line and not line.startswith("#"):
            out.append(line)
    return out


def table_forms(path: Path) -> list[str]:
    """``gear-rotor-sim ...`` forms in the first cell of the command table."""
    return re.findall(r"^\| `(gear-rotor-sim [^`]*)`", path.read_text(), re.M)


def _run(cmd: list[str] | str, timeout: float, **kw) -> subprocess.CompletedProcess:
    return subprocess.run(
        cmd, cwd=ROOT, env=ENV, capture_output=True, text=True, timeout=timeout, check=False, **kw
    )


# ---------------------------------------------------------------------------------------- rules
def run_test_sh(cmd: str) -> None:
    """Not run inside the suite it starts: it must be exactly CI's command."""
    ci = [ln.strip() for ln in (ROOT / ".ci" / "run").read_text().splitlines()]
    assert ci[-1] == cmd, f".ci/run ends with {ci[-1]!r}, the README says {cmd!r}"
    assert (ROOT / "scripts" / "test.sh").is_file()


def run_demo(cmd: str, tmp_path: Path) -> None:
    args = [*shlex.split(cmd), "--real-time-factor", "10", "--out", str(tmp_path / "demo")]
    r = _run(args, timeout=400)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    assert "sequence jumps 0, sample gaps/overlaps 0" in r.stdout, r.stdout[-3000:]


def run_serve(cmd: str, tmp_path: Path) -> None:
    args = [*shlex.split(cmd), "--duration-s", "0.5", "--port", "0"]
    assert args[0] == "gear-rotor-sim"
    r = _run([sys.executable, "-m", "gear_rotor_sim.cli", *args[1:]], timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    assert r.stdout.startswith("serving ws://127.0.0.1:") and "served 0.500 s simulated" in r.stdout, r.stdout


def run_apt_block(cmds: list[str]) -> None:
    if APT_ROS.exists():  # a machine with ROS 2 Jazzy from apt: as written, the node for 5 s
        script = " && ".join(cmds[:-1]) + f" && timeout -s INT 5 {cmds[-1]}; test $? -eq 0 -o $? -eq 124"
        r = _run(["bash", "-c", script], timeout=900)
        assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
        return
    assert cmds[0] == f"source {APT_ROS}"
    pip = shlex.split(cmds[1])
    assert pip[:3] == ["pip", "install", "-r"]
    r = _run([sys.executable, "-m", *pip], timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    colcon = shlex.split(cmds[2])
    setup = (ROOT / "scripts" / "setup_env.sh").read_text()
    assert colcon[:2] == ["colcon", "build"] and " ".join(colcon[2:]) in setup
    assert cmds[3] == "source install/setup.bash" and (ROOT / "install" / "setup.bash").is_file()
    ros2 = shlex.split(cmds[4])
    assert ros2[:4] == ["ros2", "run", "gear_rotor_sim", "simulator"] and ros2[4:6] == [
        "--ros-args",
        "--params-file",
    ]
    assert (ROOT / ros2[6]).is_file()
    demo = (ROOT / "gear_rotor_sim" / "ros" / "demo.py").read_text()
    assert f'share_file("{ros2[6]}", env)' in demo  # the demo runs the node with this very file
    from gear_rotor_sim.ros.demo import executable, ros_environment

    assert executable("simulator", ros_environment()).is_file()


#: What each README Python block must leave true (blocks run in order, as one session would).
PYTHON_CHECKS = (
    "assert block2.first_index == block.n_samples",
    "assert list(block.channels) == ['mesh1_dte', 'mesh2_dte'], block.channels",
)


def run_python_blocks(texts: list[str]) -> None:
    assert len(texts) == len(PYTHON_CHECKS)
    script = ""
    for text, check in zip(texts, PYTHON_CHECKS, strict=True):
        short = text.replace("advance(0.5)", "advance(0.01)")
        assert short != text
        script += short + "\n" + check + "\n"
    r = _run([sys.executable, "-c", script], timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]


def check_table_form(form: str) -> None:
    """The documented form parses with the real command line (placeholders as values)."""
    from gear_rotor_sim.cli import SUBCOMMANDS, build_parser

    tokens = shlex.split(form.replace("[", " ").replace("]", " "))[1:]
    assert tokens[0] in SUBCOMMANDS, form
    if "..." in tokens:
        return  # 'gear-rotor-sim figures ...': the subcommand exists; its options are in its --help
    try:
        build_parser(tokens[0]).parse_args(tokens)
    except SystemExit as exc:
        raise AssertionError(f"README form {form!r} does not parse: exit {exc.code}") from None


# ---------------------------------------------------------------------------------------- tests
def _bash_cases() -> list[tuple[str, list[str]]]:
    cases = []
    for path in DOCS_WITH_COMMANDS:
        for lang, text in code_blocks(path):
            if lang == "bash":
                cases.append((path.name, bash_commands(text)))
    return cases


def _rule(cmds: list[str]) -> str:
    if cmds and cmds[0].startswith("source /opt/ros/"):
        return "apt"
    kinds = set()
    for c in cmds:
        if c == "bash scripts/test.sh":
            kinds.add("test_sh")
        elif c.startswith("bash scripts/demo.sh"):
            kinds.add("demo")
        elif c.startswith("gear-rotor-sim serve"):
            kinds.add("serve")
        else:
            return f"unhandled: {c}"
    return ",".join(sorted(kinds))


def test_every_readme_command_is_covered():
    blocks = _bash_cases()
    assert len(blocks) >= 3
    for name, cmds in blocks:
        assert not _rule(cmds).startswith("unhandled"), f"{name}: {_rule(cmds)}"
    assert [lang for lang, _ in code_blocks(README)].count("python") == len(PYTHON_CHECKS)
    forms = table_forms(README)
    assert len(forms) >= 8 and any(f.startswith("gear-rotor-sim recover") for f in forms)


@pytest.mark.parametrize("form", table_forms(README))
def test_readme_table_forms_parse(form):
    check_table_form(form)


def test_recover_documented_form_is_the_real_one():
    """The form of issue 14 (two positional files) is refused; the README's form parses."""
    from gear_rotor_sim.cli import build_parser

    with pytest.raises(SystemExit):
        build_parser("recover").parse_args(["recover", "BROKEN.mcap", "FIXED.mcap"])
    assert "`gear-rotor-sim recover SRC --out OUT`" in README.read_text()


def test_readme_bash_commands_run(tmp_path):
    done: set[str] = set()  # a command shown in two documents runs once
    for _name, cmds in _bash_cases():
        if _rule(cmds) == "apt":
            run_apt_block(cmds)
            continue
        for cmd in cmds:
            if cmd in done:
                continue
            done.add(cmd)
            if cmd == "bash scripts/test.sh":
                run_test_sh(cmd)
            elif cmd.startswith("bash scripts/demo.sh"):
                run_demo(cmd, tmp_path)
            else:
                run_serve(cmd, tmp_path)


def test_readme_python_example_runs():
    run_python_blocks([t for lang, t in code_blocks(README) if lang == "python"])


@pytest.mark.skipif(not (ROOT / "install" / "setup.bash").exists(), reason="run scripts/setup_env.sh first")
def test_env_sh_sources_under_strict_mode():
    """Scripts that run ``set -euo pipefail`` (benchmarks/detection.sh) can source scripts/env.sh.

    colcon's ``install/setup.bash`` reads unset variables (``COLCON_TRACE``); env.sh turns ``-u`` off
    around it and restores the caller's ``-u``.
    """
    script = (
        'set -euo pipefail; . scripts/env.sh; case $- in *u*) ;; *) exit 3 ;; esac; python -c "import rclpy"'
    )
    res = _run(["bash", "-c", script], timeout=120)
    assert res.returncode == 0, res.stderr[-2000:]
