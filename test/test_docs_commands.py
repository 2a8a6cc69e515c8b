"""Every command docs/*.md and docs/history/*.md show is a valid command line of this checkout.

test_readme.py runs the README's (and docs/live.md's) commands as written. The other docs show about
150 more: benchmarks that run for minutes to an hour, and the CLI on records that earlier commands
write. Those are not run here; each one is parsed by its own script or module with argparse
(``test/docs_commands.py``): the script exists, imports, and accepts every option and value exactly
as written, so a renamed option, a removed script or a typo in the docs fails. Commands are read
from ``bash`` code blocks (lines joined at a trailing backslash, comments dropped) and from inline
code spans. Usage forms (``...``, ``<...>`` placeholders or ``[--option]`` brackets) are patterns, and an
inline span of the program and a subcommand alone (`` `gear-rotor-sim record` ``) names it: neither is
a command.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = sorted((ROOT / "docs").glob("*.md")) + sorted((ROOT / "docs" / "history").glob("*.md"))
COMMAND = re.compile(
    r"^(python (benchmarks/\S+\.py|-m (gear_rotor_sim[\w.]*|lumped_gearbox)\b)"
    r"|gear-rotor-sim )"
)
NAME_ONLY = re.compile(r"^(gear-rotor-sim|python -m \S+)( [a-z]+)?$")
pytestmark = pytest.mark.slow  # one process parses about 150 command lines (imports the benchmarks)


def _block_lines(text: str) -> list[str]:
    out, cont = [], ""
    for line in text.splitlines():
        line = re.sub(r"\s+#.*$", "", line).rstrip()
        if line.endswith("\\"):
            cont += line[:-1].strip() + " "
            continue
        out.append((cont + line.strip()).strip())
        cont = ""
    return out


def documented_commands(paths: list[Path] = DOCS) -> dict[str, str]:
    """Command -> the first doc that shows it."""
    found: dict[str, str] = {}
    for path in paths:
        text = path.read_text()
        candidates = []
        for m in re.finditer(r"```(\w*)\n(.*?)```", text, re.S):
            if m.group(1) in ("bash", "sh", ""):
                candidates += _block_lines(m.group(2))
        prose = re.sub(r"```.*?```", "", text, flags=re.S)
        inline = [m.group(1).strip() for m in re.finditer(r"`([^`\n]+)`", prose)]
        candidates += [c for c in inline if not NAME_ONLY.match(c)]
        for c in candidates:
            if COMMAND.match(c) and not re.search(r"\.\.\.|<[^>]*>|\[-", c):
                found.setdefault(c, path.name)
    return found


def test_collector_reads_blocks_inline_spans_and_continuations(tmp_path: Path) -> None:
    doc = tmp_path / "x.md"
    doc.write_text(
        "Run `python benchmarks/a.py --x 1` or the form `gear-rotor-sim figures ... --from F`,\n"
        "`gear-rotor-sim recover SRC [--out DST]`; `gear-rotor-sim record` names a subcommand.\n"
        "```bash\npython benchmarks/b.py --y \\\n  --z 2   # comment\nls\n```\n"
    )
    assert documented_commands([doc]) == {
        "python benchmarks/a.py --x 1": "x.md",
        "python benchmarks/b.py --y --z 2": "x.md",
    }


def _parse(commands: list[str]) -> list[dict]:
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "MPLBACKEND": "Agg"}
    proc = subprocess.run(
        [sys.executable, str(ROOT / "test" / "docs_commands.py")],
        input="\n".join(commands),
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    return [json.loads(line) for line in proc.stdout.splitlines() if line.startswith("{")]


def test_the_check_rejects_a_wrong_option_and_a_missing_script() -> None:
    got = _parse(
        [
            "python benchmarks/calibration_independent.py --jobs 1 --no-such-option",
            "python benchmarks/no_such_script.py",
            "gear-rotor-sim calibrate RECORD.csv --json",
        ]
    )
    assert [r["ok"] for r in got] == [False, False, True], got
    assert "--no-such-option" in got[0]["detail"]


def test_every_documented_command_parses() -> None:
    commands = documented_commands()
    assert len(commands) > 100  # the docs hold about 150 distinct commands
    results = _parse(list(commands))
    assert len(results) == len(commands)
    bad = [f"{commands[r['command']]}: {r['command']}\n    {r['detail']}" for r in results if not r["ok"]]
    assert not bad, "\n".join(bad)
