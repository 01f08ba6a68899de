"""The import graph among armcal's sub-packages and root modules, and its cycles.

Each node is a top-level name under armcal/: a sub-package (`spec`, `kinematics`, ...) or a
root module (`cli`, `units`, ...). An edge A -> B means some file of A imports something
of B. Every import statement counts, wherever it stands: at module level, inside a function
(a lazy import) or under `if TYPE_CHECKING`. Imports within one node are not edges; a module named
by a string to importlib is not seen (armcal names none).

    python tools/import_graph.py          prints the cycles (strongly connected components
                                          with more than one node), one a line; exit 1 if any
    python tools/import_graph.py --edges  prints every edge with the files that make it
"""

from __future__ import annotations

import ast
import sys
from collections import defaultdict
from pathlib import Path

PACKAGE = "armcal"
ROOT = Path(__file__).resolve().parent.parent / PACKAGE


def node_of(module: str) -> str | None:
    """The graph node of a dotted module name under armcal (None outside armcal or for armcal itself)."""
    parts = module.split(".")
    if parts[0] != PACKAGE or len(parts) < 2:
        return None
    return parts[1]


def module_name(path: Path, root: Path) -> str:
    """The dotted module name of a file under the package root."""
    relative = path.relative_to(root.parent).with_suffix("")
    parts = list(relative.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def imported_modules(path: Path, root: Path) -> set[str]:
    """Every module a file imports, absolute dotted names; relative imports resolved."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    own = module_name(path, root).split(".")
    package = own if path.name == "__init__.py" else own[:-1]
    found: set[str] = set()
    for statement in ast.walk(tree):
        if isinstance(statement, ast.Import):
            found.update(alias.name for alias in statement.names)
        elif isinstance(statement, ast.ImportFrom):
            if statement.level:
                base = package[: len(package) - statement.level + 1]
                stem = ".".join(base + ([statement.module] if statement.module else []))
            else:
                stem = statement.module or ""
            found.add(stem)
            # `from armcal import spec` imports the node `spec`, not only `armcal`
            found.update(f"{stem}.{alias.name}" for alias in statement.names if alias.name != "*")
    return found


def edges(root: Path = ROOT) -> dict[tuple[str, str], set[str]]:
    """Edge (importer node, imported node) -> the files (relative to the package) that make it."""
    nodes = {path.stem if path.is_file() else path.name for path in root.iterdir()
             if (path.suffix == ".py" and path.stem != "__init__") or (path / "__init__.py").is_file()}
    made: dict[tuple[str, str], set[str]] = defaultdict(set)
    for path in sorted(root.rglob("*.py")):
        source = node_of(module_name(path, root))
        if source is None:
            continue
        for module in imported_modules(path, root):
            target = node_of(module)
            if target in nodes and target != source:
                made[(source, target)].add(str(path.relative_to(root)))
    return dict(made)


def cycles(graph_edges) -> list[list[str]]:
    """The strongly connected components with more than one node (Tarjan), each sorted, sorted."""
    successors: dict[str, list[str]] = defaultdict(list)
    for source, target in graph_edges:
        successors[source].append(target)
        successors.setdefault(target, [])
    index: dict[str, int] = {}
    lowlink: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = lowlink[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for successor in successors[node]:
            if successor not in index:
                visit(successor)
                lowlink[node] = min(lowlink[node], lowlink[successor])
            elif successor in on_stack:
                lowlink[node] = min(lowlink[node], index[successor])
        if lowlink[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                components.append(sorted(component))

    for node in sorted(successors):
        if node not in index:
            visit(node)
    return sorted(components)


def main(argv: list[str]) -> int:
    made = edges()
    if "--edges" in argv:
        for (source, target), files in sorted(made.items()):
            print(f"{source} -> {target}: {', '.join(sorted(files))}")
        return 0
    found = cycles(made)
    for component in found:
        inner = sorted((s, t) for (s, t) in made if s in component and t in component)
        print("{" + ", ".join(component) + "}: " + ", ".join(f"{s}->{t}" for s, t in inner))
    if not found:
        print("no cycles")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
