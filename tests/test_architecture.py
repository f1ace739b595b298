"""The package's module import graph has no cycle.

Every module of ``saltstudy`` is parsed with :mod:`ast` (nothing is imported), and each
``import`` / ``from ... import`` statement, at the top of a module or inside a function, becomes an
edge to the ``saltstudy`` module it names (relative imports resolved; ``from pkg import name``
points at ``pkg.name`` when that is a module, else at ``pkg``). An import inside a function
breaks a cycle at run time but not in the design: the two modules still cannot be understood,
tested or changed one without the other, so those edges count too. Importing a submodule also
runs its package's ``__init__``; those implicit edges are left out, since every submodule would
otherwise form a loop with a package whose ``__init__`` re-exports it.
"""
from __future__ import annotations

import ast
from pathlib import Path

import saltstudy

ROOT = Path(saltstudy.__file__).resolve().parent
PACKAGE = "saltstudy"


def module_names() -> dict[str, Path]:
    """Dotted module name -> file, for every ``.py`` file of the package."""
    out = {}
    for f in sorted(ROOT.rglob("*.py")):
        parts = list(f.relative_to(ROOT).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join([PACKAGE, *parts])] = f
    return out


def _resolve(module: str, is_package: bool, level: int, target: str | None) -> str:
    """The absolute name of ``from <level dots><target> import ...`` written in ``module``."""
    if level == 0:
        return target or ""
    base = module.split(".")
    if not is_package:
        base = base[:-1]            # a module's relative imports start from its package
    if level > 1:
        base = base[:-(level - 1)]
    return ".".join(base + ([target] if target else []))


def import_graph() -> dict[str, set[str]]:
    """Module -> the package's modules it imports (anywhere in its body)."""
    modules = module_names()
    graph: dict[str, set[str]] = {m: set() for m in modules}
    for name, path in modules.items():
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        is_package = path.name == "__init__.py"
        for node in ast.walk(tree):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = _resolve(name, is_package, node.level, node.module)
                for a in node.names:
                    sub = f"{base}.{a.name}"
                    targets.append(sub if sub in modules else base)
            for t in targets:
                # ``import a.b.c`` names a.b.c; keep the longest prefix that is a module
                while t and t not in modules:
                    t = t.rpartition(".")[0]
                if t and t != name:
                    graph[name].add(t)
    return graph


def strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's strongly connected components with more than one module (the cycles)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def one_cycle(graph: dict[str, set[str]], component: list[str]) -> list[str]:
    """A shortest closed path through the component's first module, for the message."""
    start = component[0]
    inside = set(component)
    prev: dict[str, str] = {}
    queue = [start]
    while queue:
        v = queue.pop(0)
        for w in sorted(graph[v] & inside):
            if w == start:
                path = [v]
                while path[-1] != start:
                    path.append(prev[path[-1]])
                return [start] + path[::-1][1:] + [start]
            if w not in prev:
                prev[w] = v
                queue.append(w)
    return component


def describe(graph: dict[str, set[str]], components: list[list[str]]) -> str:
    return "; ".join(" -> ".join(m.removeprefix(PACKAGE + ".") for m in one_cycle(graph, c))
                     for c in components)


def test_graph_sees_the_imports():
    """The parser finds known edges of every kind: top level, relative, function level."""
    g = import_graph()
    assert "saltstudy.analysis.flux" in g["saltstudy.analysis.analyse"]
    assert "saltstudy.ncio" in g["saltstudy.analysis.analyse"]
    assert "saltstudy.analysis.analyse" in g["saltstudy.workflow.tasks"]      # inside a function
    assert "saltstudy.physics.laws" in g["saltstudy.analysis.profiles"]


def test_cycles_are_found_and_named():
    """The detector on a small graph: a loop of three is found and named, a tail is not."""
    g = {"saltstudy.a": {"saltstudy.b"}, "saltstudy.b": {"saltstudy.c"},
         "saltstudy.c": {"saltstudy.a"}, "saltstudy.d": {"saltstudy.a"}}
    cycles = strongly_connected(g)
    assert cycles == [["saltstudy.a", "saltstudy.b", "saltstudy.c"]]
    assert describe(g, cycles) == "a -> b -> c -> a"


def test_no_import_cycle():
    """No two modules import each other, directly or through others."""
    g = import_graph()
    cycles = strongly_connected(g)
    assert not cycles, f"import cycles: {describe(g, cycles)}"
