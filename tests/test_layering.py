"""The layout's layering, read from the source: every import (module level or inside a function)
points at the same layer or one listed before it, and the module-level imports have no cycle.

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


def imports(path: Path, module_level_only: bool) -> set[str]:
    """Absolute names of the project modules (and mujoco) that ``path`` imports."""
    tree = ast.parse(path.read_text(), filename=str(path))
    nodes = tree.body if module_level_only else list(ast.walk(tree))
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


def test_module_level_imports_have_no_cycle():
    graph = {m: imports(p, module_level_only=True) & MODULES.keys() for m, p in MODULES.items()}
    for m, targets in graph.items():  # importing a.b.c runs a/__init__ and a/b/__init__ first
        graph[m] = targets | {".".join(t.split(".")[:i]) for t in targets for i in (1, 2)} - {m}
    graph = {m: {t for t in targets if t in MODULES} for m, targets in graph.items()}
    state: dict[str, int] = {}  # 1 on the stack, 2 done

    def visit(node: str, stack: list[str]) -> None:
        state[node] = 1
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                cycle = [*stack[stack.index(nxt) :], nxt]
                # a package's __init__ importing its own submodules is not a cycle of the layout
                if not all(n == cycle[0] or n.startswith(cycle[0] + ".") for n in cycle):
                    pytest.fail("import cycle: " + " -> ".join(cycle))
            elif nxt not in state:
                visit(nxt, [*stack, nxt])
        state[node] = 2

    for module in sorted(graph):
        if module not in state:
            visit(module, [module])
