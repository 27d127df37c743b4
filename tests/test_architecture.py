"""The layout's rules, read from the source: rooms by concept, no import circles,
composition over mixins, the functional core free of rclpy, the lab beside the product."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("robot_controller", "robot_controller_lab")
MAX_MODULE_LINES = 400
MAX_CORE_TOP_FILES = 8
# Bases that declare an interface rather than mix in behaviour.
INTERFACE_BASES = ("Protocol", "ABC", "Generic")


def _modules() -> dict[str, Path]:
    """Every module of the two packages by dotted name (a package by its ``__init__``)."""
    found = {}
    for package in PACKAGES:
        for path in (REPO / package).rglob("*.py"):
            parts = list(path.relative_to(REPO).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            found[".".join(parts)] = path
    return found


MODULES = _modules()


def _imported(name: str, path: Path) -> set[str]:
    """The project modules ``name`` imports, anywhere in its body (``TYPE_CHECKING`` and function bodies included)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    targets: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            candidates = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                prefix = ".".join(base + ([node.module] if node.module else []))
            else:
                prefix = node.module or ""
            # ``from package import module`` imports that module; a name that is no module is the package's
            submodules = [f"{prefix}.{alias.name}" for alias in node.names if f"{prefix}.{alias.name}" in MODULES]
            candidates = submodules + ([prefix] if len(submodules) < len(node.names) else [])
        else:
            continue
        for candidate in candidates:
            while candidate and candidate not in MODULES:
                candidate = candidate.rpartition(".")[0]
            if candidate and candidate != name:
                targets.add(candidate)
    return targets


GRAPH = {name: _imported(name, path) for name, path in MODULES.items()}


def _cycles() -> list[list[str]]:
    """The graph's strongly connected components of more than one module (Tarjan, iteratively)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    for root in GRAPH:
        if root in index:
            continue
        work = [(root, iter(sorted(GRAPH[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(GRAPH[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def test_no_import_circle_between_modules():
    assert _cycles() == []


def test_the_product_never_imports_the_lab():
    product = {name: targets for name, targets in GRAPH.items() if name.startswith("robot_controller.")}
    leaks = {
        name: sorted(t for t in targets if t.startswith("robot_controller_lab")) for name, targets in product.items()
    }
    assert {name: t for name, t in leaks.items() if t} == {}


def test_no_class_mixes_in_more_than_one_base():
    mixed = []
    for name, path in MODULES.items():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ClassDef):
                bases = [ast.unparse(b) for b in node.bases]
                behaviour = [b for b in bases if not any(word in b for word in INTERFACE_BASES)]
                if len(behaviour) > 1:
                    mixed.append(f"{name}.{node.name}({', '.join(bases)})")
    assert mixed == []


@pytest.mark.parametrize("name", sorted(MODULES))
def test_module_is_at_most_400_lines(name):
    assert MODULES[name].read_text().count("\n") <= MAX_MODULE_LINES


def test_core_top_level_is_a_few_files_and_rooms():
    top = sorted(p.name for p in (REPO / "robot_controller" / "core").glob("*.py"))
    assert len(top) <= MAX_CORE_TOP_FILES, top


def test_core_never_imports_rclpy():
    for path in (REPO / "robot_controller" / "core").rglob("*.py"):
        text = path.read_text()
        assert "import rclpy" not in text and "from rclpy" not in text, path
    code = (
        "import sys, robot_controller.blocks.wiring, robot_controller.experiments.inprocess; "
        "print('rclpy' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=60)
    assert out.stdout.strip() == "False"


def test_blocks_never_import_ros():
    """A block runs in a node and in process alike: nothing of ROS, nor of the ROS layer, in it (transitively)."""
    blocks = [name for name in GRAPH if name.startswith("robot_controller.blocks")]
    for name in blocks:
        reached, todo = set(), [name]
        while todo:
            for child in GRAPH.get(todo.pop(), ()):
                if child not in reached:
                    reached.add(child)
                    todo.append(child)
        ros = sorted(m for m in reached if m.startswith(("robot_controller.ros", "robot_controller.nodes")))
        assert not ros, (name, ros)
        text = MODULES[name].read_text()
        assert "import rclpy" not in text and "from rclpy" not in text, name


def test_package_inits_hold_no_logic():
    """An ``__init__`` is a docstring, imports, ``__all__`` and entry-point stubs; no classes."""
    for name, path in MODULES.items():
        if path.name == "__init__.py":
            classes = [n.name for n in ast.parse(path.read_text()).body if isinstance(n, ast.ClassDef)]
            assert classes == [], name
