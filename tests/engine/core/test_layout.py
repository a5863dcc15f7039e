"""The shape of the shipped code, read from the built extension (CONTRIBUTING.md "Layout"): no import cycles
(imports inside functions count), the engine never imports Blender, the shared rooms of ``operators``
(``adapters``, ``bases``) never import a subsystem and adapters never import operator bases, panels never import operators, no file past 600 lines, no function past 80 lines, no private
names imported across modules, no object cloning through ``__new__``/``__dict__``, no comment that points
outside the extension."""
from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

BLENDER_MODULES = {"bpy", "mathutils", "bmesh", "bpy_extras", "gpu", "addon_utils"}
SUBSYSTEM_PACKAGES = ("operators.face", "operators.speech", "operators.general", "operators.hand",
                      "operators.morph", "operators.behavior", "operators.farm")
SHARED_ROOMS = ("operators.adapters", "operators.bases")
MAX_FILE_LINES, MAX_FUNCTION_LINES = 600, 80


def _modules(root: Path) -> dict[str, Path]:
    out = {}
    for path in sorted(root.rglob("*.py")):
        relative = path.relative_to(root).with_suffix("")
        parts = list(relative.parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def _is_package(path: Path) -> bool:
    return path.name == "__init__.py"


def _imports(name: str, path: Path, modules: dict[str, Path]):
    """(target module, imported names, line) of every import in the module, at any depth."""
    package = name if _is_package(path) else name.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, (), node.lineno
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".") if package else []
                base = base[:len(base) - (node.level - 1)] if node.level > 1 else base
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module
            names = tuple(alias.name for alias in node.names)
            submodules = [f"{target}.{n}" if target else n for n in names]
            found = [m for m in submodules if m in modules]
            for module in found:
                yield module, (), node.lineno
            rest = tuple(n for n, m in zip(names, submodules) if m not in modules)
            if rest or not found:
                yield target, rest, node.lineno


@pytest.fixture(scope="module")
def code(built_extension):
    modules = _modules(built_extension)
    assert "faces_hands_addon.core.rig" in modules and "operators.bases.registry" in modules
    graph = {name: sorted({t for t, _, _ in _imports(name, path, modules) if t in modules and t != name})
             for name, path in modules.items()}
    return built_extension, modules, graph


def _cycles(graph: dict[str, list[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on_stack, out, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_there_are_no_import_cycles(code):
    _, _, graph = code
    assert sum(len(v) for v in graph.values()) > 150, "the import graph is suspiciously small"
    assert _cycles(graph) == []


def test_an_import_cycle_would_be_found():
    assert _cycles({"a": ["b"], "b": ["c"], "c": ["a"], "d": ["a"]}) == [["a", "b", "c"]]


def test_layers_import_only_downwards(code):
    _, modules, _ = code
    offences = []
    for name, path in modules.items():
        for target, _, line in _imports(name, path, modules):
            top = (target or "").split(".")[0]
            if name.startswith("faces_hands_addon") and (top in BLENDER_MODULES or target.startswith("operators")
                                                         or target.startswith("panels")):
                offences.append(f"{name}:{line} (engine) imports {target}")
            if name.startswith(SHARED_ROOMS) and target.startswith(SUBSYSTEM_PACKAGES):
                offences.append(f"{name}:{line} (shared) imports the subsystem {target}")
            if name.startswith("operators.adapters") and target.startswith(("operators.bases", "operators.cli")):
                offences.append(f"{name}:{line} (adapter) imports the operator layer {target}")
            if name.startswith("panels") and target.startswith("operators"):
                offences.append(f"{name}:{line} (panel) imports {target}")
    assert offences == []


def test_no_private_names_cross_modules(code):
    _, modules, _ = code
    offences = [f"{name}:{line} imports {target}.{n}"
                for name, path in modules.items() for target, names, line in _imports(name, path, modules)
                for n in names if n.startswith("_") and n != "__version__" and target in modules]
    assert offences == []


def test_files_and_functions_stay_small(code):
    _, modules, _ = code
    long_files = [f"{p.name}: {n}" for p in modules.values()
                  if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_FILE_LINES]
    long_functions = []
    for name, path in modules.items():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                length = node.end_lineno - node.lineno + 1
                if length > MAX_FUNCTION_LINES:
                    long_functions.append(f"{name}.{node.name}: {length} lines")
    assert long_files == [] and long_functions == []


def test_no_cloning_through_dunder_new_or_dict(code):
    _, modules, _ = code
    pattern = re.compile(r"__new__\(|__dict__\.update\(")
    offences = [f"{name}:{n}" for name, path in modules.items()
                for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1) if pattern.search(line)]
    assert offences == []


def test_nothing_points_outside_the_extension(code):
    root, modules, _ = code
    pattern = re.compile(r"\.\./shared|shared/notes|\bissue \d+|\bissue #\d+", re.IGNORECASE)
    files = list(modules.values()) + sorted((root / "presets").rglob("*.json")) + sorted((root / "presets").rglob("*.md"))
    offences = [f"{path.relative_to(root)}:{n}" for path in files
                for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1) if pattern.search(line)]
    assert offences == []


def _package_graph(graph: dict[str, list[str]]) -> dict[str, list[str]]:
    """The engine's import graph collapsed to its packages (``faces_hands_addon.<package>``)."""
    def package(name: str) -> str:
        return ".".join(name.split(".")[:2])
    out: dict[str, set[str]] = {}
    for name, targets in graph.items():
        if not name.startswith("faces_hands_addon."):
            continue
        out.setdefault(package(name), set()).update(
            package(t) for t in targets if t.startswith("faces_hands_addon.") and package(t) != package(name))
    return {name: sorted(targets) for name, targets in out.items()}


def test_engine_packages_form_no_loop(code):
    """Packages, not only modules: speech -> behaviour/emotion -> face -> speech was a loop of packages made of
    modules that never imported each other in a circle. The composition of speech, behaviour and emotion
    lives above all three (``performance``)."""
    _, _, graph = code
    packages = _package_graph(graph)
    assert {"faces_hands_addon.speech", "faces_hands_addon.performance", "faces_hands_addon.emotion"} <= set(packages)
    assert _cycles(packages) == []
    assert "faces_hands_addon.performance" not in {t for name, targets in packages.items() for t in targets}, \
        "nothing in the engine may import the performance package: it composes the others"


def test_a_package_loop_would_be_found():
    graph = {"faces_hands_addon.speech.a": ["faces_hands_addon.emotion.b"],
             "faces_hands_addon.emotion.b": ["faces_hands_addon.face.c"],
             "faces_hands_addon.face.c": ["faces_hands_addon.speech.d"], "faces_hands_addon.speech.d": []}
    assert _cycles(_package_graph(graph)) == [["faces_hands_addon.emotion", "faces_hands_addon.face",
                                               "faces_hands_addon.speech"]]
