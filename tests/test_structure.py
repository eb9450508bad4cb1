"""The add-on's import structure: no cycles, and no import upwards.

Every import in ``addon/`` (at the top of a module or inside a function) is
read from the source.  The engine's modules sit in the layers below, from
the bottom; a module may import from its own layer and the layers below,
never from above.  The engine never imports the Blender layer or ``bpy``.
A new engine module must be placed in a layer here.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "addon"

#: The engine's layers, bottom first.  A package (``language``) stands for
#: all of its modules.
LAYERS = [
    ["errors", "datafile", "framerate", "smoothing", "fcurve_eval"],
    ["language", "resampling", "wavstream", "decoders", "audio", "pauses"],
    ["visemes", "conventions", "presets", "prosody", "weights", "arousal", "alignment", "importers"],
    ["coarticulation", "emotion_track", "expression", "settings", "render", "mapping", "key_reduction", "pose_blend",
     "gestures"],
    ["output", "pipeline", "learning", "keys", "edits"],
    ["batch", "cli", "arousal_cli", "__main__"],
]


def _module_name(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for p in PACKAGE.rglob("*.py")}


def _imports(name: str, path: Path, known: set[str]) -> set[str]:
    """The add-on's modules that ``name`` imports, anywhere in its source."""
    is_package = path.name == "__init__.py"
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name in known or a.name.split(".")[0] == "bpy":
                    out.add(a.name)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".")
                if not is_package:
                    base = base[:-1]
                base = base[:len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] == "bpy":
                out.add(target)
                continue
            for a in node.names:
                sub = f"{target}.{a.name}"
                if sub in known:
                    out.add(sub)
                elif target in known:
                    out.add(target)
    out.discard(name)
    return out


def _graph() -> dict[str, set[str]]:
    mods = _modules()
    return {n: _imports(n, p, set(mods)) for n, p in mods.items()}


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in graph:
                continue
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def _layer(module: str) -> int | None:
    parts = module.split(".")
    if parts[:2] != ["addon", "engine"]:
        return None
    if len(parts) == 2:
        return len(LAYERS)          # the engine package's own face: above everything
    for k, layer in enumerate(LAYERS):
        if parts[2] in layer:
            return k
    raise AssertionError(f"engine module {module} is in no layer of tests/test_structure.py: place it there")


def test_the_graph_sees_imports_inside_functions():
    graph = _graph()
    assert "addon.engine.alignment" in graph["addon.engine.pipeline"]
    # pipeline imports nothing from above it, but cli imports pipeline inside a function
    assert "addon.engine.pipeline" in graph["addon.engine.cli"] | graph["addon.engine.batch"]


def test_no_import_cycles():
    assert _cycles(_graph()) == []


def test_cycle_finder_finds_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_engine_never_imports_blender():
    bad = [(m, t) for m, targets in _graph().items() if m.startswith("addon.engine")
           for t in targets if t.startswith(("addon.blender", "bpy"))]
    assert bad == []


def test_engine_layers_import_only_downwards():
    upward = []
    for m, targets in _graph().items():
        lm = _layer(m)
        if lm is None:
            continue
        for t in targets:
            lt = _layer(t)
            if lt is not None and lt > lm:
                upward.append(f"{m} (layer {lm}) imports {t} (layer {lt})")
    assert upward == []
