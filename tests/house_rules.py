"""The house's figures, read from the source alone (``ast``; nothing is imported):

- the modules at ``flatland_ma``'s top level;
- import circles among the modules of ``flatland_ma`` and ``baselines``: through imports
  that run when a module is imported, then also through those made for the type checker
  alone (``if TYPE_CHECKING:``), then also through imports inside functions;
- imports up the layers (``LAYERS``, after DESIGN.md's "Layers");
- library files over ``MAX_FILE_LINES`` lines and functions over ``MAX_FUNCTION_LINES``;
- files that touch pymunk's internals (its private attributes, ``pymunk._chipmunk``, its
  ``ffi`` and ``lib``);
- reads of another module's private members (``x._name`` where ``x`` is not ``self`` or
  ``cls`` and no class or function of the same file defines ``_name``, and
  ``from module import _name``), leaving out the standard library's.

``python -m tests.house_rules`` prints every figure; ``tests/test_house.py`` holds the
house to them.
"""

from __future__ import annotations

import ast
import importlib.util
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from functools import cache
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("flatland_ma", "baselines")
"""The packages whose modules the figures count (the library and its learners)."""
MAX_FILE_LINES = 400
MAX_FUNCTION_LINES = 60

LAYERS = (
    "cli",
    "studio",
    "integrations",
    "bench",
    "lifelong",
    "evaluation",
    "play",
    "policies",
    "envs",
    "render",
    "build",
    "tasks",
    "agents",
    "sensors",
    "world",
    "scenario",
    "kinds",
)
"""``flatland_ma``'s subpackages from the top floor down: each imports only those below
it, with two exceptions. The file format (``scenario``) is apart: below ``build`` only
``kinds`` may be imported by it and nothing there imports it (the world, sensors, agents
and rules know nothing of files). The package's root (``flatland_ma/__init__.py``, the
door) may import any of them, and nothing in ``flatland_ma`` imports ``baselines``.
DESIGN.md lists ``render`` and ``policies`` after the file format as side floors; their
places here are what their imports and their users need: the envs draw through
``render``, and policies drive envs. ``cli`` (the command line), ``bench`` (the speed
bench) and ``kinds`` (the registry of the kinds files name) are not in DESIGN.md's
list."""
FILE_FORMAT = "scenario"
READS_FILES_FROM = "build"
"""The lowest layer that may import the file format."""

STANDARD_PRIVATE = frozenset(
    {"_actions", "_fields", "_replace", "_asdict", "_make", "_field_defaults", "_getframe"}
)
"""Private names of the standard library's objects read through an instance (argparse's
parser actions, a named tuple's documented ``_replace``, ``sys._getframe``)."""


@dataclass(frozen=True)
class Import:
    """One import of one module: where, what, and when it runs."""

    line: int
    target: str
    """The module imported (for ``from a.b import c``: ``a.b.c`` if that is a module)."""
    typing_only: bool
    """Under ``if TYPE_CHECKING:``."""
    lazy: bool
    """Inside a function: it runs when the function is called."""


@dataclass(frozen=True)
class Figures:
    top_level: list[str]
    circles: list[list[str]]
    circles_with_typing: list[list[str]]
    circles_with_lazy: list[list[str]]
    up_imports: list[str]
    unplaced: list[str]
    long_files: list[tuple[int, str]]
    long_functions: list[tuple[int, str, str]]
    pymunk_internals: list[str]
    private_reads: list[str]


def module_files() -> dict[str, Path]:
    """Every module of ``PACKAGES`` by its dotted name (a package by its own name)."""
    found = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            if "__pycache__" in path.parts:
                continue
            parts = path.relative_to(ROOT).with_suffix("").parts
            found[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return found


@cache
def _tree(path: Path) -> ast.Module:
    return ast.parse(path.read_text(), filename=str(path))


def _walk(node: ast.AST, typing_only=False, lazy=False) -> Iterator[tuple[ast.AST, bool, bool]]:
    """Every node under ``node``, with whether it lies under ``if TYPE_CHECKING:`` and
    whether inside a function."""
    for child in ast.iter_child_nodes(node):
        yield child, typing_only, lazy
        inner_typing = typing_only
        if isinstance(child, ast.If) and "TYPE_CHECKING" in ast.unparse(child.test):
            for statement in child.body:
                yield statement, True, lazy
                yield from _walk(statement, True, lazy)
            for statement in child.orelse:
                yield statement, typing_only, lazy
                yield from _walk(statement, typing_only, lazy)
            continue
        inner_lazy = lazy or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
        yield from _walk(child, inner_typing, inner_lazy)


def _package_of(module: str, path: Path) -> str:
    return module if path.name == "__init__.py" else module.rpartition(".")[0]


def imports_of(module: str, path: Path, known: dict[str, Path]) -> list[Import]:
    """The imports of ``module`` (file ``path``) of other modules in ``known``."""
    found = []
    for node, typing_only, lazy in _walk(_tree(path)):
        targets = []
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                package = _package_of(module, path).split(".")
                package = package[: len(package) - node.level + 1]
                base = ".".join([*package, base] if base else package)
            targets = [
                f"{base}.{alias.name}" if f"{base}.{alias.name}" in known else base
                for alias in node.names
            ]
        for target in dict.fromkeys(targets):
            while target and target not in known:  # ``import a.b.c`` of a name in ``a.b``
                target = target.rpartition(".")[0]
            if target and target != module:
                found.append(Import(node.lineno, target, typing_only, lazy))
    return found


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected groups of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    groups = []

    def visit(start: str) -> None:  # iterative: deep chains do not hit the recursion limit
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, edges = work[-1]
            for other in edges:
                if other not in index:
                    index[other] = low[other] = len(index)
                    stack.append(other)
                    on_stack.add(other)
                    work.append((other, iter(sorted(graph[other]))))
                    break
                if other in on_stack:
                    low[node] = min(low[node], index[other])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    group = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        group.append(member)
                        if member == node:
                            break
                    if len(group) > 1:
                        groups.append(sorted(group))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return sorted(groups)


def import_graphs() -> tuple[dict[str, set[str]], ...]:
    """Three graphs of module imports: those that run on import; those plus the type
    checker's; those plus imports inside functions."""
    known = module_files()
    running, typing, lazy = ({m: set() for m in known} for _ in range(3))
    for module, path in known.items():
        for found in imports_of(module, path, known):
            if found.lazy:
                lazy[module].add(found.target)
            elif found.typing_only:
                typing[module].add(found.target)
            else:
                running[module].add(found.target)
    with_typing = {m: running[m] | typing[m] for m in known}
    with_lazy = {m: with_typing[m] | lazy[m] for m in known}
    return running, with_typing, with_lazy


def layer_of(module: str) -> str | None:
    """The layer of a module of ``flatland_ma`` (None for the root and for baselines)."""
    parts = module.split(".")
    return parts[1] if parts[0] == "flatland_ma" and len(parts) > 1 else None


def may_import(layer: str, other: str) -> bool:
    if other == layer:
        return True
    if other == FILE_FORMAT:
        return layer in LAYERS[: LAYERS.index(READS_FILES_FROM) + 1] or layer == "kinds"
    return LAYERS.index(other) > LAYERS.index(layer)


def up_imports() -> list[str]:
    """Every import, wherever it is in a file, of a layer its importer may not import."""
    known = module_files()
    wrong = []
    for module, path in known.items():
        layer = layer_of(module)
        if not module.startswith("flatland_ma."):
            continue
        for found in imports_of(module, path, known):
            other = layer_of(found.target)
            where = f"{path.relative_to(ROOT)}:{found.line} imports {found.target}"
            if found.target.startswith("baselines"):
                wrong.append(where)
            elif layer in LAYERS and other in LAYERS and not may_import(layer, other):
                wrong.append(where)
    return wrong


def unplaced() -> list[str]:
    """The subpackages and top-level modules of ``flatland_ma`` in no layer."""
    names = {layer_of(module) for module in module_files()} - {None, *LAYERS}
    return sorted(str(name) for name in names)


def top_level_modules() -> list[str]:
    return sorted(path.name for path in (ROOT / "flatland_ma").glob("*.py"))


def long_files_and_functions() -> tuple[list[tuple[int, str]], list[tuple[int, str, str]]]:
    files, functions = [], []
    for path in module_files().values():
        where = str(path.relative_to(ROOT))
        lines = path.read_text().count("\n")
        if lines > MAX_FILE_LINES:
            files.append((lines, where))
        for node in ast.walk(_tree(path)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                length = (node.end_lineno or node.lineno) - node.lineno + 1
                if length > MAX_FUNCTION_LINES:
                    functions.append((length, where, node.name))
    return sorted(files, reverse=True), sorted(functions, reverse=True)


@cache
def pymunk_private_names() -> frozenset[str]:
    """The private attribute names pymunk's own source sets or defines (from its files,
    without importing it)."""
    spec = importlib.util.find_spec("pymunk")
    if spec is None or not spec.submodule_search_locations:
        return frozenset()
    names = set()
    for folder in spec.submodule_search_locations:
        for path in Path(folder).glob("*.py"):
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.Attribute) and _private(node.attr):
                    names.add(node.attr)
                elif isinstance(node, (ast.FunctionDef, ast.ClassDef)) and _private(node.name):
                    names.add(node.name)
    return frozenset(names)


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def _root_name(node: ast.AST) -> str | None:
    while isinstance(node, (ast.Attribute, ast.Call, ast.Subscript)):
        node = node.func if isinstance(node, ast.Call) else node.value
    return node.id if isinstance(node, ast.Name) else None


def _imported_names(tree: ast.Module) -> dict[str, str]:
    """Each name a file binds by an import, to the module it comes from."""
    names = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                names[alias.asname or alias.name.split(".")[0]] = alias.name
        elif isinstance(node, ast.ImportFrom) and node.module:
            for alias in node.names:
                names[alias.asname or alias.name] = f"{node.module}.{alias.name}"
    return names


def pymunk_internals() -> list[str]:
    """Files that touch pymunk beyond its documented API, with what they touch."""
    private = pymunk_private_names()
    found = []
    for path in module_files().values():
        tree = _tree(path)
        imported = _imported_names(tree)
        if not any(m.split(".")[0] == "pymunk" for m in imported.values()):
            continue
        touched = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("pymunk._"):
                touched.add(node.module or "")
            elif isinstance(node, ast.Import):
                touched |= {a.name for a in node.names if a.name.startswith("pymunk._")}
            elif isinstance(node, ast.Attribute) and _private(node.attr):
                root = _root_name(node.value)
                if root == "pymunk" or (root not in ("self", "cls") and node.attr in private):
                    touched.add(f".{node.attr}")
            elif isinstance(node, ast.Name) and imported.get(node.id, "").startswith("pymunk._"):
                touched.add(imported[node.id])
        if touched:
            found.append(f"{path.relative_to(ROOT)}: {', '.join(sorted(touched))}")
    return found


def _defined_here(tree: ast.Module) -> set[str]:
    """The private names a file defines: its functions, classes, assignments, attributes
    it sets on any object, and its parameters."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            names.add(node.id)
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
            names.add(node.attr)
        elif isinstance(node, ast.arg):
            names.add(node.arg)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names.add(node.target.id)
    return {name for name in names if _private(name)}


def private_reads() -> list[str]:
    """Reads of private members defined in another module (``pymunk``'s counted too)."""
    standard = set(sys.stdlib_module_names)
    found = []
    for path in module_files().values():
        tree = _tree(path)
        here = _defined_here(tree)
        imported = _imported_names(tree)
        where = path.relative_to(ROOT)
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module:
                if node.module.split(".")[0] in standard:
                    continue
                found += [
                    f"{where}:{node.lineno} from {node.module} import {alias.name}"
                    for alias in node.names
                    if _private(alias.name)
                ]
            elif isinstance(node, ast.Attribute) and _private(node.attr):
                root = _root_name(node.value)
                if root in ("self", "cls") and isinstance(node.value, ast.Name):
                    continue
                origin = imported.get(root or "", "").split(".")[0]
                if origin in standard or node.attr in here or node.attr in STANDARD_PRIVATE:
                    continue
                found.append(f"{where}:{node.lineno} {ast.unparse(node)[:70]}")
    return sorted(found, key=lambda row: (row.split(":")[0], int(row.split(":")[1].split()[0])))


def figures() -> Figures:
    running, with_typing, with_lazy = import_graphs()
    files, functions = long_files_and_functions()
    return Figures(
        top_level=top_level_modules(),
        circles=circles(running),
        circles_with_typing=circles(with_typing),
        circles_with_lazy=circles(with_lazy),
        up_imports=up_imports(),
        unplaced=unplaced(),
        long_files=files,
        long_functions=functions,
        pymunk_internals=pymunk_internals(),
        private_reads=private_reads(),
    )


def report(found: Figures) -> str:
    def block(title: str, rows: list) -> list[str]:
        return [f"{title}: {len(rows)}", *(f"    {row}" for row in rows)]

    def groups(rows: list[list[str]]) -> list[str]:
        return [" <-> ".join(group) for group in rows]

    lines = [
        *block("modules at flatland_ma's top level", found.top_level),
        *block("import circles (imports run on import)", groups(found.circles)),
        *block("... with the type checker's imports too", groups(found.circles_with_typing)),
        *block("... with imports inside functions too", groups(found.circles_with_lazy)),
        *block("imports up the layers", found.up_imports),
        *block("flatland_ma's modules and subpackages in no layer", found.unplaced),
        *block(f"library files over {MAX_FILE_LINES} lines", found.long_files),
        *block(f"functions over {MAX_FUNCTION_LINES} lines", found.long_functions),
        *block("files touching pymunk's internals", found.pymunk_internals),
        *block("private members read across modules", found.private_reads),
    ]
    return "\n".join(lines)


if __name__ == "__main__":
    print(report(figures()))
