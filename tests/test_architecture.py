"""The layout shows the pipeline (docs/architecture.md): stage packages import only the stages
below them, every package is drawn in the document, and every registered target is a folder
with its emitter and templates."""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

from mdl import targets

SRC = Path(__file__).resolve().parent.parent / "src" / "mdl"
DOC = Path(__file__).resolve().parent.parent / "docs" / "architecture.md"


def _unit(module: str) -> str:
    """The top-level package or module of mdl a module belongs to (`mdl.values.ir` -> `values`)."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "mdl"


def import_graph() -> dict[str, set[str]]:
    """Top-level unit -> the units it imports (every import, type-checking and function-level ones too)."""
    edges: dict[str, set[str]] = {}
    for path in SRC.rglob("*.py"):
        parts = path.relative_to(SRC.parent).with_suffix("").parts
        module = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not (isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] == "mdl"):
                continue
            names = [f"mdl.{a.name}" for a in node.names] if node.module == "mdl" else [node.module]
            for target in names:
                unit = _unit(target)
                is_unit = (SRC / unit).is_dir() or (SRC / f"{unit}.py").is_file()  # not `from mdl import __version__`
                if is_unit and unit != _unit(module):
                    edges.setdefault(_unit(module), set()).add(unit)
    return edges


def test_no_import_cycles_between_stages():
    graph = import_graph()
    state: dict[str, str] = {}

    def visit(node: str, path: list[str]) -> None:
        state[node] = "open"
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == "open":
                raise AssertionError("import cycle: " + " -> ".join([*path, node, nxt]))
            if nxt not in state:
                visit(nxt, [*path, node])
        state[node] = "done"

    for node in sorted(graph):
        if node not in state:
            visit(node, [])


def test_the_graph_sees_known_edges():
    """A control: the check would see a cycle if there were one, because it sees these edges."""
    graph = import_graph()
    assert {"model", "lang", "values"} <= graph["resolve"]
    assert "resolve" in graph["targets"] and "model" in graph["lang"]


def test_the_stages_keep_their_order():
    """Lower stages never import higher ones: model < lang < values < resolve < sources/targets/device/
    exports < cli (the XIF and WISE writers in sources/ return the exports' types)."""
    order = ["model", "lang", "values", "resolve", "sources", "targets", "device", "exports", "cli"]
    peers = {"sources", "targets", "device", "exports"}
    graph = import_graph()
    for low, unit in enumerate(order):
        for dep in graph.get(unit, ()):
            if dep in order:
                assert order.index(dep) <= low or {unit, dep} <= peers, (unit, dep)
    assert "sources" not in graph.get("targets", set()) | graph.get("device", set())


def test_every_package_is_drawn_in_architecture_md():
    text = DOC.read_text(encoding="utf-8")
    packages = sorted(p.relative_to(SRC).as_posix() for p in SRC.rglob("__init__.py"))
    for init in packages:
        folder = Path(init).parent
        if folder != Path("."):
            assert f"`{folder.name}/`" in text, f"docs/architecture.md does not show src/mdl/{folder}/"


@pytest.mark.parametrize("name", targets.names())
def test_each_target_is_a_folder_with_emitter_and_templates(name):
    folder = SRC / "targets" / name
    assert (folder / "emit.py").is_file() and any((folder / "templates").glob("*.j2"))
    target = importlib.import_module(f"mdl.targets.{name}.emit").TARGET
    assert target.name == name and target is targets.target(name)
