"""The layers of the ergopose package (docs/architecture.md), read from the source with ``ast``.

A module may import modules of its own layer and of the layers below it, never above; no two
modules import each other, directly or round a longer circle; ergopose modules are imported at
the top of a module (the import graph is what the top of the files says), and the only imports
deferred into functions are the ones listed in DEFERRED_ON_PURPOSE. The checks run on the real
source and, to show they can fail, on small made-up graphs.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "ergopose"

#: Lowest first. A name is a module or a package (all modules under it).
#: sim/ and evaluation/ stand beside the product: they import it and nothing in it imports them;
#: the commands, on top, run them for ``ergopose simulate`` / ``evaluate`` / ``demo``.
LAYERS: tuple[tuple[str, tuple[str, ...]], ...] = (
    (
        "base",
        (
            "ergopose",
            "ergopose.errors",
            "ergopose.progress",
            "ergopose.atomic",
            "ergopose.arrays",
            "ergopose.keypoints",
            "ergopose.resources",
            "ergopose.video",
            "ergopose.remote",
            "ergopose.cli_progress",
        ),
    ),
    ("geometry", ("ergopose.geometry",)),
    ("records", ("ergopose.records",)),
    ("settings", ("ergopose.settings",)),
    ("calibration", ("ergopose.calibration",)),
    ("pose", ("ergopose.pose",)),
    ("recon", ("ergopose.recon",)),
    ("ergonomics", ("ergopose.ergonomics",)),
    ("session", ("ergopose.session",)),
    ("report", ("ergopose.report",)),
    ("pipeline", ("ergopose.pipeline",)),
    ("sim", ("ergopose.sim",)),
    ("evaluation", ("ergopose.evaluation",)),
    ("commands", ("ergopose.commands", "ergopose.cli", "ergopose.__main__")),
)

#: (module, imported module) deferred into a function on purpose, and why.
DEFERRED_ON_PURPOSE = {
    ("ergopose.pose.blazepose", "ai_edge_litert.interpreter"): "heavy runtime, needed only when a network runs",
    ("ergopose.pose.blazepose", "ai_edge_litert"): "LiteRT's model schema, needed only when a network loads",
    ("ergopose.pose.blazepose", "flatbuffers"): "model rewriting, needed only when a network loads",
    ("ergopose.pose.onnx_models", "onnxruntime"): "heavy runtime, needed only for a user-brought ONNX model",
    ("ergopose.pipeline.store", "fcntl"): "POSIX only; without it the store works unlocked",
    ("ergopose.commands.assess", "ergopose.pipeline.cluster"): "needs Dask (an optional extra): only for --cluster",
    ("ergopose.remote", "fsspec"): "an optional extra (cluster): only for videos given as URLs",
}


def module_names() -> dict[str, Path]:
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def _absolute(module: str, is_package: bool, node: ast.ImportFrom) -> str:
    if not node.level:
        return node.module or ""
    base = module.split(".") if is_package else module.split(".")[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def imports_of(module: str, path: Path, known: set[str]) -> list[tuple[str, str, bool]]:
    """(imported name, ergopose module it resolves to or "", at module top) for every import."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    top = {id(n) for n in tree.body}
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = _absolute(module, path.name == "__init__.py", node)
            names = [f"{base}.{a.name}" if f"{base}.{a.name}" in known else base for a in node.names]
        else:
            continue
        for name in names:
            target = name
            while target and target not in known:
                target = target.rpartition(".")[0]
            out.append((name, target if target.startswith("ergopose") else "", id(node) in top))
    return out


def layer_of(module: str) -> int | None:
    best, best_len = None, -1
    for k, (_, members) in enumerate(LAYERS):
        for m in members:
            if (module == m or module.startswith(m + ".")) and len(m) > best_len and (m != "ergopose" or module == m):
                best, best_len = k, len(m)
    return best


def layer_violations(edges: set[tuple[str, str]]) -> list[str]:
    """Imports from a lower layer up into a higher one."""
    bad = []
    for a, b in sorted(edges):
        la, lb = layer_of(a), layer_of(b)
        if la is not None and lb is not None and lb > la:
            bad.append(f"{a} ({LAYERS[la][0]}) imports {b} ({LAYERS[lb][0]})")
    return bad


def circles(edges: set[tuple[str, str]]) -> list[list[str]]:
    """Strongly connected sets of more than one module (Tarjan)."""
    adj: dict[str, list[str]] = {}
    for a, b in edges:
        adj.setdefault(a, []).append(b)
        adj.setdefault(b, [])
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in adj[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                on.discard(w)
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                found.append(sorted(group))

    for v in sorted(adj):
        if v not in index:
            visit(v)
    return found


@pytest.fixture(scope="module")
def graph():
    mods = module_names()
    known = set(mods)
    edges: set[tuple[str, str]] = set()
    deferred: list[tuple[str, str]] = []
    for m, path in mods.items():
        for name, target, at_top in imports_of(m, path, known):
            if target and target != m:
                edges.add((m, target))
            if not at_top:
                deferred.append((m, name))
    return mods, edges, deferred


def test_every_module_has_a_layer(graph):
    mods, _, _ = graph
    assert [m for m in mods if layer_of(m) is None] == []


def test_no_import_goes_up_a_layer(graph):
    _, edges, _ = graph
    assert layer_violations(edges) == []


def test_no_import_circles(graph):
    _, edges, _ = graph
    assert circles(edges) == []


def test_imports_at_module_top_unless_deferred_on_purpose(graph):
    _, _, deferred = graph
    assert sorted(set(deferred) - set(DEFERRED_ON_PURPOSE)) == []


def test_the_product_does_not_import_the_simulator_or_the_evaluation(graph):
    _, edges, _ = graph
    side = ("ergopose.sim", "ergopose.evaluation")
    product_layers = {name for name, _ in LAYERS} - {"sim", "evaluation", "commands"}
    bad = [(a, b) for a, b in edges if LAYERS[layer_of(a)][0] in product_layers and b.startswith(side)]
    assert bad == []


def test_the_checks_catch_what_they_forbid():
    # the import issue 17 found: the 2D stage reaching up into the reconstruction
    assert layer_violations({("ergopose.pose.fisheye", "ergopose.recon.records")}) == [
        "ergopose.pose.fisheye (pose) imports ergopose.recon.records (recon)"
    ]
    assert layer_violations({("ergopose.pipeline.stages", "ergopose.sim.ground_truth")}) != []
    assert layer_violations({("ergopose.recon.records", "ergopose.records")}) == []
    assert circles({("a", "b"), ("b", "c"), ("c", "a"), ("c", "d")}) == [["a", "b", "c"]]
    assert circles({("a", "b"), ("b", "c")}) == []
    assert layer_of("ergopose.report.pages") == [n for n, _ in LAYERS].index("report")
    assert layer_of("ergopose.records") == [n for n, _ in LAYERS].index("records")
    assert layer_of("ergopose.unknown_module") is None
