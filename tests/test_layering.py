"""The layout's layering, read from the source: every import (module level or inside a function)
points at the same layer or one listed before it, the module-level imports have no cycle, not
even with the imports made for the type checker alone (``if TYPE_CHECKING:``), and no module of
``learners`` reads or calls another object's private members (``x._name`` for an x that is not
``self``, ``cls`` or an instance its own class just built).

Layers, lowest first: ``models`` < ``learners`` < ``envs.sensing`` < ``envs`` (the environments)
< ``envs.harness`` < ``envs.studies`` < ``envs.cli``. ``learners`` and ``models`` never import
mujoco at module level, so the learners run without a simulator.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("models", "learners", "envs")
LAYERS = ("models", "learners", "envs.sensing", "envs", "envs.harness", "envs.studies", "envs.cli")


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def layer(module: str) -> int:
    """Index in LAYERS of the longest layer name that is ``module`` or a package above it."""
    matches = [
        i for i, name in enumerate(LAYERS) if module == name or module.startswith(name + ".")
    ]
    return max(matches, key=lambda i: len(LAYERS[i]))


def _type_checking_blocks(tree: ast.Module) -> list[ast.stmt]:
    """The statements of the module-level ``if TYPE_CHECKING:`` blocks."""
    return [
        statement
        for node in tree.body
        if isinstance(node, ast.If) and ast.unparse(node.test).endswith("TYPE_CHECKING")
        for statement in node.body
    ]


def imports(path: Path, module_level_only: bool, type_checking: bool = False) -> set[str]:
    """Absolute names of the project modules (and mujoco) that ``path`` imports; with
    ``type_checking`` the module-level ones include those of ``if TYPE_CHECKING:`` blocks."""
    tree = ast.parse(path.read_text(), filename=str(path))
    nodes = tree.body if module_level_only else list(ast.walk(tree))
    if module_level_only and type_checking:
        nodes = [*nodes, *_type_checking_blocks(tree)]
    found = set()
    for node in nodes:
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            for alias in node.names:  # `from envs.sensing import stereo` imports a module
                candidate = f"{node.module}.{alias.name}"
                found.add(candidate if candidate in MODULES else node.module)
    return {name for name in found if name.split(".")[0] in (*PACKAGES, "mujoco")}


FILES = sorted(p for package in PACKAGES for p in (ROOT / package).rglob("*.py"))
MODULES = {module_name(p): p for p in FILES}


def test_the_layers_cover_every_module():
    assert len(MODULES) > 90  # the walk found the packages
    for module in MODULES:
        assert LAYERS[layer(module)].split(".")[0] == module.split(".")[0]


@pytest.mark.parametrize("module", sorted(MODULES))
def test_no_module_imports_a_higher_layer(module):
    own = layer(module)
    for target in imports(MODULES[module], module_level_only=False):
        if target.split(".")[0] == "mujoco":
            continue
        assert layer(target) <= own, f"{module} ({LAYERS[own]}) imports {target} (higher layer)"


def test_learners_never_import_mujoco_and_models_only_inside_functions():
    for module, path in MODULES.items():
        if module.split(".")[0] == "learners":
            assert "mujoco" not in imports(path, module_level_only=False), module
        if module.split(".")[0] == "models":
            assert "mujoco" not in imports(path, module_level_only=True), module


def find_cycles(type_checking: bool) -> list[list[str]]:
    """The import cycles a depth-first walk meets among the module-level imports (with
    ``type_checking``, those of ``if TYPE_CHECKING:`` blocks too): none when there is none."""
    graph = {
        m: imports(p, module_level_only=True, type_checking=type_checking) & MODULES.keys()
        for m, p in MODULES.items()
    }
    for m, targets in graph.items():  # importing a.b.c runs a/__init__ and a/b/__init__ first
        graph[m] = targets | {".".join(t.split(".")[:i]) for t in targets for i in (1, 2)} - {m}
    graph = {m: {t for t in targets if t in MODULES} for m, targets in graph.items()}
    state: dict[str, int] = {}  # 1 on the stack, 2 done
    cycles: list[list[str]] = []

    def visit(node: str, stack: list[str]) -> None:
        state[node] = 1
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                cycle = [*stack[stack.index(nxt) :], nxt]
                # a package's __init__ importing its own submodules is not a cycle of the layout
                if not all(n == cycle[0] or n.startswith(cycle[0] + ".") for n in cycle):
                    cycles.append(cycle)
            elif nxt not in state:
                visit(nxt, [*stack, nxt])
        state[node] = 2

    for module in sorted(graph):
        if module not in state:
            visit(module, [module])
    return cycles


#: Cycles that only the type checker's imports close, each with the reason it is still there.
TYPE_CHECKING_CYCLES_ALLOWED: dict[tuple[str, ...], str] = {}


def test_module_level_imports_have_no_cycle():
    cycles = find_cycles(type_checking=False)
    assert not cycles, "import cycle: " + " -> ".join(cycles[0])


def test_the_type_checkers_imports_have_no_cycle_either():
    for cycle in find_cycles(type_checking=True):
        assert tuple(cycle) in TYPE_CHECKING_CYCLES_ALLOWED, (
            "import cycle (TYPE_CHECKING included): " + " -> ".join(cycle)
        )


def test_a_type_checking_import_that_closes_a_cycle_is_found(tmp_path, monkeypatch):
    package = tmp_path / "learners"
    package.mkdir()
    (package / "a.py").write_text("from learners import b\n")
    (package / "b.py").write_text(
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from learners.a import X\n"
    )
    fake = {"learners.a": package / "a.py", "learners.b": package / "b.py"}
    monkeypatch.setitem(globals(), "MODULES", fake)
    assert find_cycles(type_checking=False) == []
    assert find_cycles(type_checking=True) == [["learners.a", "learners.b", "learners.a"]]


# ------------------------------------------------------------------------------ private members
#: ``x._name`` accesses under learners/ that are not of self, cls or an instance the class just
#: built, with the reason each is one: none today.
PRIVATE_ALLOWED: dict[tuple[str, str], str] = {}


def _same_class(node: ast.expr, class_name: str, own: set[str]) -> bool:
    """Whether ``node`` is self, cls, type(self), the class itself or a name bound in the
    method to an instance the class built (``som = cls(...)``)."""
    if isinstance(node, ast.Name):
        return node.id in ("self", "cls", class_name) or node.id in own
    return (
        isinstance(node, ast.Call) and ast.unparse(node.func) == "type" and len(node.args) == 1
        and ast.unparse(node.args[0]) == "self"
    )  # fmt: skip


def private_accesses(path: Path) -> list[tuple[int, str]]:
    """(line, expression) of every ``x._name`` (not a dunder) in ``path`` whose x is not of the
    class the code is in."""
    tree = ast.parse(path.read_text(), filename=str(path))
    found: list[tuple[int, str]] = []

    def check(scope: ast.AST, class_name: str) -> None:
        own = set()
        for node in ast.walk(scope):
            if isinstance(node, ast.Assign) and isinstance(node.value, ast.Call):
                if _same_class(node.value.func, class_name, set()):
                    own.update(t.id for t in node.targets if isinstance(t, ast.Name))
        for node in ast.walk(scope):
            private = node.attr.startswith("_") and not node.attr.startswith("__") \
                if isinstance(node, ast.Attribute) else False  # fmt: skip
            if private and not (class_name and _same_class(node.value, class_name, own)):
                found.append((node.lineno, ast.unparse(node)))

    for node in tree.body:
        if isinstance(node, ast.ClassDef):
            for item in node.body:
                check(item, node.name)
        else:
            check(node, "")
    return found


def test_no_module_of_learners_reads_another_objects_private_members():
    root_learners = ROOT / "learners"
    for path in sorted(root_learners.rglob("*.py")):
        module = module_name(path)
        for line, expression in private_accesses(path):
            assert (module, expression) in PRIVATE_ALLOWED, (
                f"{path.relative_to(ROOT)}:{line}: {expression} reads a private member of an "
                "object of another class; use a public attribute or pass the object explicitly"
            )


def test_the_private_member_check_finds_what_it_should(tmp_path):
    source = tmp_path / "m.py"
    source.write_text(
        "class C:\n"
        "    def f(self, other):\n"
        "        som = type(self)()\n"
        "        self._a, som._b, type(self)._c, C._d = 1, 2, 3, 4\n"
        "        return other._e\n"
        "def g(x):\n"
        "    return x._f, x.__class__\n"
    )
    assert private_accesses(source) == [(5, "other._e"), (7, "x._f")]
