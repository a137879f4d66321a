"""The house rules of the Python package, read from its source with ``ast``: arrows point one
way (commands -> library -> engine gateway -> core), so there is no import circle, nothing in
the library imports a command module, and only ``sonolux.engine`` touches the compiled core or
its handles. Imports inside functions count; those under ``if TYPE_CHECKING:`` do not."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "python" / "sonolux"
GATEWAY = "sonolux.engine"
PRIVATE_HANDLES = {"_native", "_g"}


def module_name(path: Path) -> str:
    parts = ["sonolux", *path.relative_to(PACKAGE).with_suffix("").parts]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {module_name(p): p for p in PACKAGE.rglob("*.py")}


def _type_checking_only(node: ast.AST, parents: dict[ast.AST, ast.AST]) -> bool:
    while node in parents:
        node = parents[node]
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            return True
    return False


def imports_of(name: str) -> set[str]:
    """The sonolux modules that module ``name`` imports (a name imported from a package counts
    as its submodule when there is one)."""
    tree = ast.parse(MODULES[name].read_text(encoding="utf-8"))
    parents = {child: node for node in ast.walk(tree) for child in ast.iter_child_nodes(node)}
    package = name if MODULES[name].name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(tree):
        if _type_checking_only(node, parents):
            continue
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name.startswith("sonolux")}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(package.split(".")[: len(package.split(".")) - node.level + 1]
                                + ([base] if base else []))
            if not base.startswith("sonolux"):
                continue
            for a in node.names:
                found.add(f"{base}.{a.name}" if f"{base}.{a.name}" in MODULES or
                          f"{base}.{a.name}" == "sonolux._core" else base)
    return found - {name}


GRAPH = {name: imports_of(name) for name in MODULES}


def circles() -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in GRAPH.get(v, ()):
            if w not in MODULES:
                continue
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            part = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                part.append(w)
                if w == v:
                    break
            if len(part) > 1:
                out.append(sorted(part))

    for v in sorted(MODULES):
        if v not in index:
            visit(v)
    return out


def is_command(name: str) -> bool:
    return name == "sonolux.cli" or name.startswith("sonolux.cli.")


def test_the_walker_sees_the_package():
    assert {"sonolux.engine", "sonolux.fieldfile", "sonolux.cli.main"} <= set(MODULES)
    assert "sonolux.fieldfile" in GRAPH["sonolux.cli.scene"]  # imported inside a function


def test_no_import_circle():
    assert circles() == []


def test_no_library_module_imports_a_command():
    upward = sorted(f"{a} -> {b}" for a, targets in GRAPH.items() if not is_command(a)
                    for b in targets if is_command(b))
    assert upward == []


def test_only_the_gateway_touches_the_core():
    users = sorted(a for a, targets in GRAPH.items() if "sonolux._core" in targets and a != GATEWAY)
    assert users == []
    handles = []
    for name, path in MODULES.items():
        if name == GATEWAY:
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Attribute) and node.attr in PRIVATE_HANDLES:
                handles.append(f"{name}: .{node.attr}")
    assert handles == []
