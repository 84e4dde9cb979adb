"""Whether two builds of a kernel's shared object hold the same machine code, function by
function: a check that a change of the C sources' layout (e.g. one file split into one per
concern) changed no instruction, so it cannot change speed.

    python benchmarks/kernel_code_equal.py ~/.cache/ramensim/native/mapkernels_OLD.so \\
        ~/.cache/ramensim/native/mapkernels_NEW.so

Each function of the text section (entry points and their OpenMP bodies, ``*._omp_fn.N``) is
disassembled with ``objdump -d`` and normalised: addresses, RIP-relative offsets and the
symbol comments they carry are dropped, and alignment padding (nop instructions, which the
assembler places between blocks and after a function's end) is ignored. Prints one line per function that differs and the count of equal ones.
"""
from __future__ import annotations

import argparse
import re
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from benchmarks._machine import machine_info  # noqa: E402

_PAD = re.compile(r"^(data16 )*(cs )?nop|^xchg\s+%ax,%ax$")


def functions(so: Path) -> dict[str, list[str]]:
    """Function name -> its normalised instructions."""
    text = subprocess.run(["objdump", "-d", "--no-show-raw-insn", str(so)], capture_output=True, text=True,
                          check=True).stdout
    out: dict[str, list[str]] = {}
    name = None
    for line in text.splitlines():
        head = re.match(r"^[0-9a-f]+ <(.+)>:$", line)
        if head:
            name = head.group(1)
            out[name] = []
            continue
        if name is None or not line.strip():
            name = None if not line.strip() else name
            continue
        insn = line.split(":", 1)[-1].split("#", 1)[0].strip()
        insn = re.sub(r"-?0x[0-9a-f]+\(%rip\)", "RIP", insn)
        insn = re.sub(r"\b[0-9a-f]+ <[^>]*>", "ADDR", insn)
        out[name].append(insn)
    return {n: [i for i in body if not _PAD.match(i)] for n, body in out.items()}


def _runtime(name: str) -> bool:
    """The linker's and C runtime's stubs (PLT entries, init/fini), not the kernels' code."""
    return "@plt" in name or name.startswith(("_", "deregister", "register", "frame_dummy"))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("a", type=Path)
    ap.add_argument("b", type=Path)
    args = ap.parse_args()
    fa, fb = functions(args.a), functions(args.b)
    names = sorted(n for n in set(fa) & set(fb) if not _runtime(n))
    differ = [n for n in names if fa[n] != fb[n]]
    for n in differ:
        print(f"differs: {n} ({len(fa[n])} vs {len(fb[n])} instructions)")
    only = sorted(n for n in set(fa) ^ set(fb) if not _runtime(n))
    if only:
        print(f"in one build only: {', '.join(only)}")
    print(f"{len(names) - len(differ)} of {len(names)} functions hold the same instructions")
    print(machine_info())
    return 0 if not differ and not only else 1


if __name__ == "__main__":
    sys.exit(main())
