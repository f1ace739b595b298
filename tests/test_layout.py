"""The package's layout against its map (docs/ARCHITECTURE.md, "The package map"): every part has
a row, every row exists, every import inside the package follows the map's arrows, and no module
is longer than 800 lines."""
from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PKG = ROOT / "saltstudy"
MAX_LINES = 800


def _map() -> dict[str, set[str]]:
    """path (as written, e.g. ``saltstudy/solver/flow/``) -> the parts it may import."""
    text = (ROOT / "docs" / "ARCHITECTURE.md").read_text()
    section = text.split("## The package map", 1)[1].split("\n## ", 1)[0]
    rows = {}
    for line in section.splitlines():
        m = re.match(r"\| `(saltstudy/[^`]*)` \|.*\| ([^|]*) \|\s*$", line)
        if m:
            may = {t.strip().strip("`") for t in m.group(2).split(",")} - {"—", ""}
            rows[m.group(1)] = may
    return rows


def _part_of(path: Path, rows: dict[str, set[str]]) -> str:
    """The map row a file belongs to: its own module row, else its nearest package row."""
    rel = path.relative_to(ROOT).as_posix()
    if rel in rows:
        return rel
    parts = rel.split("/")
    for i in range(len(parts) - 1, 0, -1):
        key = "/".join(parts[:i]) + "/"
        if key in rows:
            return key
    raise AssertionError(f"{rel} has no row in the map")


def _target_file(module: str) -> Path | None:
    """The file of a dotted ``saltstudy...`` module name (package -> its __init__)."""
    p = ROOT / Path(*module.split("."))
    if p.with_suffix(".py").is_file():
        return p.with_suffix(".py")
    if (p / "__init__.py").is_file():
        return p / "__init__.py"
    return None


def _imports(path: Path):
    """Dotted ``saltstudy`` modules a file imports (top level and inside functions)."""
    rel = path.relative_to(ROOT).with_suffix("")
    pkg = list(rel.parts[:-1])
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg[: len(pkg) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            if not mod.startswith("saltstudy"):
                continue
            # `from pkg import module` names a module, `from module import name` does not
            for a in node.names:
                sub = f"{mod}.{a.name}"
                yield sub if _target_file(sub) is not None else mod
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith("saltstudy"):
                    yield a.name


def _allowed(target_part: str, may: set[str]) -> bool:
    name = target_part.removeprefix("saltstudy/").removesuffix(".py").rstrip("/")
    for m in may:
        m = m.removesuffix(".py").rstrip("/")
        if name == m or name.startswith(m + "/"):
            return True
    return False


def test_every_part_has_a_row_and_every_row_exists():
    rows = _map()
    assert rows, "docs/ARCHITECTURE.md has no package map"
    for key in rows:
        assert (ROOT / key).exists(), f"the map lists {key}, which is not in the tree"
    for f in PKG.rglob("*.py"):
        _part_of(f, rows)   # raises naming the file
    for d in PKG.rglob("*"):
        if d.is_dir() and (d / "__init__.py").is_file():
            rel = d.relative_to(ROOT).as_posix() + "/"
            assert any(k == rel or k.startswith(rel) for k in rows), f"{rel} has no row in the map"


def test_imports_follow_the_map():
    rows = _map()
    bad = []
    for f in sorted(PKG.rglob("*.py")):
        src = _part_of(f, rows)
        for mod in _imports(f):
            tf = _target_file(mod)
            if tf is None:
                bad.append(f"{f.relative_to(ROOT)} imports {mod}, which does not exist")
                continue
            dst = _part_of(tf, rows)
            # the package's identity (version, source key) is everyone's
            if dst == src or src.endswith("/") and dst.startswith(src) or \
                    dst == "saltstudy/_identity.py":
                continue
            if not _allowed(dst, rows[src]):
                bad.append(f"{f.relative_to(ROOT)} imports {mod} ({dst}), not among {src}'s arrows")
    assert not bad, "\n".join(bad)


def test_no_module_over_800_lines():
    long = {p.relative_to(ROOT).as_posix(): n for p in sorted(PKG.rglob("*.py"))
            if (n := len(p.read_text().splitlines())) > MAX_LINES}
    assert not long, f"modules over {MAX_LINES} lines (split them along their processes): {long}"


def test_the_grain_step_calls_its_kernels_through_one_record():
    """particles.KERNELS holds every kernel a step calls, each a compiled function of the grain
    modules (a benchmark passes its own record, nothing rebinds a module's names); the parallel
    ones, run through particles.Threads, are among them."""
    from saltstudy.solver.grains import particles

    assert set(particles.PARALLEL) <= set(particles.StepKernels._fields)
    for name, kernel in particles.KERNELS._asdict().items():
        assert hasattr(kernel, "py_func"), name
        assert kernel.__module__.startswith("saltstudy.solver.grains."), name


#: names with a leading underscore that are public by their owner's documentation (namedtuple's)
PUBLIC_UNDERSCORED = {"_asdict", "_replace", "_fields", "_make", "_field_defaults"}


def _private_definitions(files: list[Path]) -> set[str]:
    """Private names (``_x``, not dunder) that ``files`` define: functions, classes, module and
    class attributes, and attributes assigned on ``self``/``cls``."""
    out: set[str] = set()
    for f in files:
        for node in ast.walk(ast.parse(f.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                out.add(node.name)
            elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
                out.add(node.id)
            elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
                out.add(node.attr)
            elif isinstance(node, ast.alias):
                out.add(node.asname or node.name.split(".")[-1])
    return {n for n in out if n.startswith("_") and not n.startswith("__")}


def test_no_private_name_crosses_a_part():
    """A part of the map (a package or module row) reaches another only through its public
    names: no ``from other import _name``, and no ``x._name`` (``x`` not ``self``/``cls``) whose
    ``_name`` the part itself does not define (a private method of another part's object, a
    private module global)."""
    rows = _map()
    files_of: dict[str, list[Path]] = {}
    for f in sorted(PKG.rglob("*.py")):
        files_of.setdefault(_part_of(f, rows), []).append(f)
    bad = []
    for part, files in files_of.items():
        own = _private_definitions(files)
        for f in files:
            rel = f.relative_to(ROOT).with_suffix("")
            pkg = list(rel.parts[:-1])
            for node in ast.walk(ast.parse(f.read_text())):
                if isinstance(node, ast.ImportFrom):
                    if node.level:
                        mod = ".".join(pkg[: len(pkg) - (node.level - 1)]
                                       + ([node.module] if node.module else []))
                    else:
                        mod = node.module or ""
                    if not mod.startswith("saltstudy"):
                        continue
                    tf = _target_file(mod)
                    if tf is None or _part_of(tf, rows) == part:
                        continue
                    for a in node.names:
                        if a.name.startswith("_") and not a.name.startswith("__"):
                            bad.append(f"{f.relative_to(ROOT)}: from {mod} import {a.name}")
                elif (isinstance(node, ast.Attribute) and node.attr.startswith("_")
                      and not node.attr.startswith("__") and node.attr not in own
                      and node.attr not in PUBLIC_UNDERSCORED
                      and not (isinstance(node.value, ast.Name)
                               and node.value.id in ("self", "cls"))):
                    bad.append(f"{f.relative_to(ROOT)}:{node.lineno}: .{node.attr}")
    assert not bad, "private names used across parts:\n" + "\n".join(bad)



def test_grain_modules_import_only_what_they_use():
    """Each name a grain module imports is used in it (read by a kernel, called, re-exported in
    ``__all__``)."""
    unused = {}
    for path in sorted((PKG / "solver" / "grains").glob("*.py")):
        tree = ast.parse(path.read_text())
        imported = {a.asname or a.name.split(".")[0] for node in tree.body
                    if isinstance(node, (ast.Import, ast.ImportFrom)) for a in node.names}
        imported.discard("annotations")
        used = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)}
        used |= {n.value.id for n in ast.walk(tree)
                 if isinstance(n, ast.Attribute) and isinstance(n.value, ast.Name)}
        exported = set()
        for node in tree.body:
            if isinstance(node, ast.Assign) and any(getattr(t, "id", "") == "__all__"
                                                    for t in node.targets):
                exported = {e.value for e in node.value.elts}
        if imported - used - exported:
            unused[path.name] = sorted(imported - used - exported)
    assert unused == {}
