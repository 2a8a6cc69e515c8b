"""Where the gear kernel's time goes by machine instruction, in the project's own build (perf and gdb).

Issue 13 (docs/history/solver_sessions.md, "Session 23"). ``profile_event_steps.py profile`` maps
samples to source lines but needs the kernel rebuilt with line tables, which did not finish compiling
in 19 minutes on the loaded machine of session 23. This script needs no rebuild: a child process runs
``run_chunk_gear`` on a chunk captured by ``profile_event_steps.py capture`` over and over (events
located as captured, or not with ``--no-locate``: regular steps only), ``perf record`` samples it
for ``--seconds`` and ``gdb``, attached to the child, disassembles the ``--top`` most sampled
addresses (numba registers its code through LLVM's GDB JIT interface). Printed: the shares of the
shared libraries, of the top addresses by mnemonic, of those whose operand is in the stack frame
(``(%rsp)``: values spilled or reloaded, and the skid of a stall before them) and of four-wide
vector (``ymm``) instructions, then each top address with its function offset and instruction.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/profile_event_steps.py capture /tmp/c20k.pkl``
then ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/profile_instructions.py /tmp/c20k.pkl --no-locate``
(needs ``perf`` and ``gdb``).
"""

from __future__ import annotations

import argparse
import collections
import copy
import os
import pickle
import re
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from profile_event_steps import perf_samples


def child(path: str, locate: bool) -> None:
    """Run the captured call forever (the parent ends it), after printing ``ready PID``."""
    from gear_rotor_sim.solver import gear_kernel

    with open(path, "rb") as fh:
        args = list(pickle.load(fh))
    if not locate:
        args[8] = False
    call = tuple(args)
    gear_kernel.run_chunk_gear(*copy.deepcopy(call))
    print(f"ready {os.getpid()}", flush=True)
    t_end = time.time() + 3600.0
    while time.time() < t_end:
        gear_kernel.run_chunk_gear(*copy.deepcopy(call))


def disassemble(pid: int, addrs: list[int]) -> dict[int, tuple[str, str]]:
    """(function + offset, instruction) of each address, by ``gdb -p PID -batch``."""
    script = "".join(f"echo @@{a:#x}\\n\ninfo symbol {a:#x}\nx/i {a:#x}\n" for a in addrs)
    fd, cmds = tempfile.mkstemp(suffix=".gdb")
    os.write(fd, script.encode())
    os.close(fd)
    gdb = ["gdb", "-p", str(pid), "-batch", "-nx", "-x", cmds]
    out = subprocess.run(gdb, capture_output=True, text=True, timeout=900).stdout
    os.unlink(cmds)
    res: dict[int, tuple[str, str]] = {a: ("?", "?") for a in addrs}
    cur = None
    for line in out.splitlines():
        if line.startswith("@@"):
            cur = int(line[2:], 16)
            res[cur] = ("?", "?")
            continue
        if cur is None:
            continue
        where, ins = res[cur]
        m = re.search(r"(\S+) \+ (\d+) in section", line)
        if m and where == "?":
            name = re.search(r"(?:solver\d+gear_[a-z_]+?|kernels)(\d+)(?=_)", m.group(1))
            fn = m.group(1)[name.end() : name.end() + int(name.group(1))] if name else m.group(1)[:40]
            where = f"{fn}+{m.group(2)}"
        if re.match(r"\s*(=>\s*)?0x[0-9a-f]+", line) and ":" in line:
            ins = line.split(":", 1)[1].strip()
            ins = re.sub(r"<[^>]{60,}>", "<...>", ins)
        res[cur] = (where, ins)
    return res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("path", help="a chunk from profile_event_steps.py capture")
    ap.add_argument("--seconds", type=float, default=15.0)
    ap.add_argument("--top", type=int, default=60)
    ap.add_argument("--no-locate", action="store_true", help="events not located: regular steps only")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(args.path, not args.no_locate)
        return
    cmd = [sys.executable, __file__, args.path, "--child"] + (["--no-locate"] if args.no_locate else [])
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    pid = int(proc.stdout.readline().split()[1])
    try:
        total, ips, lib = perf_samples(pid, args.seconds)
        top = [a for a, _ in ips.most_common(args.top)]
        where = disassemble(pid, top)
    finally:
        proc.terminate()
        proc.wait(timeout=60)

    def pct(c: float) -> str:
        return f"{100.0 * c / max(total, 1):.1f} %"

    kind = "located" if not args.no_locate else "not located"
    print(f"{total} samples ({kind}; load {os.getloadavg()[0]:.1f}); JIT code {pct(sum(ips.values()))}")
    print("  libraries: " + ", ".join(f"{k} {pct(v)}" for k, v in lib.most_common(6)))
    mnem: collections.Counter[str] = collections.Counter()
    for a in top:
        mnem[where[a][1].split()[0]] += ips[a]
    held = sum(ips[a] for a in top)
    stack = sum(ips[a] for a in top if "(%rsp)" in where[a][1])
    vec = sum(ips[a] for a in top if "ymm" in where[a][1])
    print(f"  top {len(top)} addresses {pct(held)}: stack-frame operand {pct(stack)}, ymm {pct(vec)}")
    print("  by mnemonic: " + ", ".join(f"{k} {pct(v)}" for k, v in mnem.most_common(12)))
    for a in sorted(top):
        print(f"  {pct(ips[a]):>7}  {where[a][0]:28s} {where[a][1]}")


if __name__ == "__main__":
    main()
