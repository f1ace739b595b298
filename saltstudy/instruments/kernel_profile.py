"""Where inside the compiled grain kernels the time goes: ``saltstudy bench profile``.

The grain bench runs under ``perf record -e cpu-clock`` in a child with an empty numba cache; the
child writes each compiled function's address and code, the parent assigns the samples
(``perf script -F ip``) to functions and disassembles the hottest (``objdump``). Written to
``--out``: ``summary.json`` and ``<kernel>.asm.txt`` per hot function. Needs ``perf`` and
``objdump``; one thread unless ``--threads``.
"""
from __future__ import annotations

import bisect
import collections
import ctypes
import importlib
import json
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

from .revision import run_isolated

#: the grain modules whose dispatchers' machine code is kept
_MODULES = ("advance", "coupling", "splash_kernels", "population", "particles")
#: code bytes kept per function (the hot kernels are 10-45 kB)
_CODE_BYTES = 1 << 16
#: window of code (bytes) over which the summary sums samples
_WINDOW = 512


def record_child(n: int, steps: int, fidelity: str, out: str) -> dict:
    """The child's side (under perf): the grain bench, then every compiled grain function's
    address (``out/functions.json``) and code (``out/code/<address>.bin``)."""
    from . import bench_particles as bp
    s, st = bp._component(bp._PACKAGE, n, 0.005, 2, fidelity)
    for _ in range(steps):
        s.dynamics(st, 0.005)
    code = Path(out) / "code"
    code.mkdir(parents=True, exist_ok=True)
    funcs = {}
    for m in _MODULES:
        mod = importlib.import_module(f"{bp._PACKAGE}.solver.grains.{m}")
        for name, d in vars(mod).items():
            for cres in list(getattr(d, "overloads", {}).values()):
                lib = cres.library
                module = getattr(lib, "_final_module", None)
                if module is None:
                    continue
                for fn in module.functions:
                    if fn.is_declaration:
                        continue
                    ptr = lib.get_pointer_to_function(fn.name)
                    if ptr and str(ptr) not in funcs:
                        funcs[str(ptr)] = [name, fn.name]
                        (code / f"{ptr:x}.bin").write_bytes(ctypes.string_at(ptr, _CODE_BYTES))
    (Path(out) / "functions.json").write_text(json.dumps(funcs))
    return {"functions": len(funcs), "parcels_end": int(s.n)}


def attribute(ips, funcs: dict[int, tuple[str, str]]) -> tuple[dict, int]:
    """{function start: Counter(offset -> samples)} of the addresses ``ips`` within _CODE_BYTES of
    the nearest start below, and the number of all samples."""
    starts = sorted(funcs)
    per = collections.defaultdict(collections.Counter)
    ips = list(ips)
    for ip in ips:
        i = bisect.bisect_right(starts, ip) - 1
        if i >= 0 and ip - starts[i] < _CODE_BYTES:
            per[starts[i]][ip - starts[i]] += 1
    return per, len(ips)


def _disassemble(path: Path) -> dict[int, str]:
    """offset -> instruction text of a raw x86-64 code dump (objdump)."""
    res = subprocess.run(["objdump", "-D", "-b", "binary", "-mi386:x86-64", str(path)],
                         capture_output=True, text=True, check=True)
    out = {}
    for line in res.stdout.splitlines():
        m = re.match(r"\s+([0-9a-f]+):\t(?:[0-9a-f]{2} )+\s*\t?(.*)", line)
        if m:
            out[int(m.group(1), 16)] = m.group(2).strip()
    return out


def profile_kernels(n: int = 1_000_000, steps: int = 100, fidelity: str = "reduced",
                    out: str | Path = "kernel-profile", threads: int = 1, top: int = 4) -> dict:
    """Record the grain bench under perf; write and return the summary (module doc)."""
    for tool in ("perf", "objdump"):
        if shutil.which(tool) is None:
            raise RuntimeError(f"{tool} is not on PATH: the kernel profile needs it")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    data = out / "perf.data"
    with tempfile.TemporaryDirectory(prefix="saltstudy-profile-numba-") as cache:
        run_isolated(f"{__name__}:record_child",
                     {"n": int(n), "steps": int(steps), "fidelity": fidelity, "out": str(out)},
                     prefix=["perf", "record", "-q", "-e", "cpu-clock", "-F", "4000", "-o",
                             str(data), "--"],
                     env={"NUMBA_CACHE_DIR": cache, "NUMBA_NUM_THREADS": str(threads)})
    script = subprocess.run(["perf", "script", "-F", "ip", "-i", str(data)], capture_output=True,
                            text=True, check=True)
    ips = [int(w, 16) for w in script.stdout.split() if re.fullmatch(r"[0-9a-fA-F]+", w)]
    funcs = {int(k): tuple(v) for k, v in json.loads((out / "functions.json").read_text()).items()}
    per, total = attribute(ips, funcs)
    in_kernels = sum(sum(c.values()) for c in per.values())
    rows = []
    for start, cnt in sorted(per.items(), key=lambda kv: -sum(kv[1].values())):
        kernel, symbol = funcs[start]
        nsamp = sum(cnt.values())
        win = collections.Counter()
        for off, c in cnt.items():      # samples per _WINDOW bytes of code
            win[off // _WINDOW * _WINDOW] += c
        rows.append({"kernel": kernel, "symbol": symbol[:120], "address": start,
                     "share": nsamp / max(total, 1), "share_of_kernels": nsamp / max(in_kernels, 1),
                     "windows": {f"{w:#x}": c / nsamp for w, c in sorted(win.items())
                                 if c / nsamp >= 0.01}})
    for r in rows[:top]:
        ins = _disassemble(out / "code" / f"{r['address']:x}.bin")
        cnt = per[r["address"]]
        last = max(cnt) + 64
        lines = [f"{cnt.get(o, 0):6d} {o:6x}  {t}" for o, t in sorted(ins.items()) if o <= last]
        name = re.sub(r"[^A-Za-z0-9_]+", "_", r["kernel"])
        path = out / f"{name}.asm.txt"
        if path.exists():  # a second function of the same kernel (the dispatcher's wrapper)
            path = out / f"{name}.{r['address']:x}.asm.txt"
        path.write_text("\n".join(lines) + "\n")
        r["listing"] = path.name
    summary = {"n_parcels": int(n), "steps": int(steps), "fidelity": fidelity,
               "threads": int(threads), "samples": total,
               "in_grain_kernels": in_kernels / max(total, 1),
               "functions": rows}
    (out / "summary.json").write_text(json.dumps(summary, indent=1))
    return summary


def register_bench_profile(bench_app) -> None:
    import typer

    from ..workflow.cli_commands import fail

    @bench_app.command("profile")
    def profile(n: float = typer.Option(1e6, "--n", help="parcels"),
                steps: int = typer.Option(100, "--steps", help="steps recorded"),
                fidelity: str = typer.Option("reduced", "--fidelity", help="whose grid the "
                                             "frozen flow fills"),
                out: Path = typer.Option(Path("kernel-profile"), "--out",
                                         help="folder for summary.json and the listings"),
                threads: int = typer.Option(1, "--threads", help="numba threads"),
                top: int = typer.Option(4, "--top", help="functions to disassemble")) -> None:
        """Sample the grain kernels' machine code under perf: where inside each kernel the time
        goes (an annotated listing per hot kernel)."""
        from ..config import load_fidelity
        for hint, value, what in (("--n", n, "parcel"), ("--threads", threads, "thread")):
            if value < 1:
                raise typer.BadParameter(f"at least one {what}", param_hint=hint)
        try:
            load_fidelity(fidelity)
        except (FileNotFoundError, ValueError) as e:
            raise typer.BadParameter(str(e), param_hint="--fidelity") from e
        try:
            s = profile_kernels(int(n), steps, fidelity, out, threads, top)
        except RuntimeError as e:
            fail(str(e), 1)
        typer.echo(f"{s['samples']} samples, {s['in_grain_kernels']:.0%} in the grain kernels' "
                   f"compiled code (the rest: compiling, Python, the set-up); of those:")
        for r in s["functions"][:top]:
            hot = ", ".join(f"{w} {f:.0%}" for w, f in sorted(r["windows"].items(),
                                                                key=lambda kv: -kv[1])[:4])
            typer.echo(f"  {r['share_of_kernels']:6.1%}  {r['kernel']:24s} hottest windows: {hot}"
                       f"  -> {out / r.get('listing', '')}")
