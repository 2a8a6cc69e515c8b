"""Parse every command that docs/*.md shows, without running it (used by test_docs_commands.py).

Run as ``python test/docs_commands.py`` with one command per line on stdin; prints one JSON line
per command: ``{"command", "ok", "detail"}``. Each command's script or module is executed as
``__main__`` with ``argparse.ArgumentParser.parse_args`` replaced by a version that parses (exiting
with argparse's own message where an option or value is wrong) and then stops the command before
it does any work. So the check is the command line itself: the script or module exists, imports,
and accepts every option and value exactly as written.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import io
import json
import runpy
import shlex
import sys
from pathlib import Path
from typing import NoReturn

ROOT = Path(__file__).resolve().parent.parent
MODULES = {"gear-rotor-sim": "gear_rotor_sim.cli"}


class Parsed(BaseException):
    """Raised after a successful parse: the command line is valid, nothing is run."""


_parse_args = argparse.ArgumentParser.parse_args


def _parse_and_stop(
    self: argparse.ArgumentParser, args: list[str] | None = None, namespace: object = None
) -> NoReturn:
    _parse_args(self, args, namespace)
    raise Parsed


def target(command: str) -> tuple[str, str, list[str]]:
    """(kind, script path or module name, arguments) of a documented command."""
    words = shlex.split(command)
    for i, w in enumerate(words):  # a shell redirection or pipe ends the command's own arguments
        if w in (">", ">>", "|", "2>", "&>"):
            words = words[:i]
            break
    if words[0] in MODULES:
        return "module", MODULES[words[0]], words[1:]
    if words[:2] == ["python", "-m"]:
        return "module", words[2], words[3:]
    if words[0] == "python":
        return "script", words[1], words[2:]
    raise ValueError(f"not a documented command form: {command!r}")


def check(command: str) -> tuple[bool, str]:
    kind, name, args = target(command)
    if kind == "script":
        path = ROOT / name
    else:
        spec = importlib.util.find_spec(name)
        if spec is None:
            return False, f"no such module {name}"
        path = Path(spec.origin)
        if spec.submodule_search_locations:  # a package runs its __main__
            path = path.with_name("__main__.py")
    if not path.is_file():
        return False, f"no such script {name}"
    if "argparse" not in path.read_text():
        # a script without options: the command must pass none, and it is not run
        return (not args), ("" if not args else f"{name} takes no arguments, got {args}")
    sys.argv = [name, *args]
    err = io.StringIO()
    try:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
            if kind == "script":
                runpy.run_path(str(ROOT / name), run_name="__main__")
            else:
                runpy.run_module(name, run_name="__main__", alter_sys=True)
    except Parsed:
        return True, ""
    except SystemExit as exc:
        if exc.code in (0, None):  # --help
            return True, ""
        return False, f"exit {exc.code}: {err.getvalue().strip()[-400:]}"
    except Exception as exc:  # an import or set-up error before the parse
        return False, f"{type(exc).__name__}: {exc}"
    return False, "ran to the end without parsing options (the check could not stop it)"


def main() -> int:
    argparse.ArgumentParser.parse_args = _parse_and_stop
    sys.path.insert(0, str(ROOT))
    for line in sys.stdin.read().splitlines():
        ok, detail = check(line)
        print(json.dumps({"command": line, "ok": ok, "detail": detail}), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
