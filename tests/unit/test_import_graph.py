"""The import graph of the shipped package and the development tools has no cycle.

Every ``import`` statement counts, at module level or inside a function (a function-local import
that closes a cycle only hides it until someone moves it). A statement ``from a.b import c`` is an
edge to the module ``a.b.c`` when that is a module, else to ``a.b`` (a name its ``__init__``
defines); an edge to a package's submodule does not count as an edge to the package."""
import ast
from pathlib import Path

ADDON = Path(__file__).resolve().parents[2] / "addon"
PACKAGES = ("lamella", "lamella_dev")


def _modules() -> dict[str, Path]:
    out = {}
    for package in PACKAGES:
        for path in (ADDON / package).rglob("*.py"):
            parts = list(path.relative_to(ADDON).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out[".".join(parts)] = path
    return out


def _edges(name: str, path: Path, modules: dict) -> set[str]:
    is_package = path.name == "__init__.py"
    here = name.split(".") if is_package else name.split(".")[:-1]
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = here[: len(here) - node.level + 1] if node.level else []
            source = ".".join(base + ([node.module] if node.module else []))
            targets = [f"{source}.{a.name}" if f"{source}.{a.name}" in modules else source for a in node.names]
        else:
            continue
        out |= {t for t in targets if t in modules and t != name}
    return out


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in graph:
        if v not in index:
            visit(v)
    return out


def test_no_import_cycle():
    modules = _modules()
    graph = {name: _edges(name, path, modules) for name, path in modules.items()}
    cycles = _cycles(graph)
    detail = []
    for component in cycles:
        members = set(component)
        detail.append("; ".join(f"{m} -> {', '.join(sorted(graph[m] & members))}" for m in component))
    assert not cycles, "import cycles:\n" + "\n".join(detail)


def test_the_walk_sees_function_local_imports_and_finds_a_cycle(tmp_path):
    """The test above can fail: two modules importing each other, one inside a function."""
    (tmp_path / "a.py").write_text("import b\n")
    (tmp_path / "b.py").write_text("def f():\n    from a import x\n")
    modules = {"a": tmp_path / "a.py", "b": tmp_path / "b.py"}
    graph = {name: _edges(name, path, modules) for name, path in modules.items()}
    assert _cycles(graph) == [["a", "b"]]
