"""The layout shows the pipeline (docs/architecture.md): stage packages import only the stages
below them (no exemption), a registry's members never import it back, every package is drawn in
the document, and every registered target is a folder with its emitter and templates."""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

from mdl import targets
from support.common import ROOT

SRC = ROOT / "src" / "mdl"
DOC = ROOT / "docs" / "architecture.md"


def _unit(module: str) -> str:
    """The top-level package or module of mdl a module belongs to (`mdl.ir.steps` -> `values`)."""
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


# The pipeline's stages, lowest first: each imports only stages before it (no exemption). The helpers
# serve every stage and import none.
STAGES = [
    "model",
    "plan",
    "dsl",
    "ir",
    "resolver",
    "exchange",
    "profiles",
    "formats",
    "targets",
    "device",
    "exports",
    "api",
    "mdl",  # the package itself: `import mdl` is the library, mdl.api's calls (SPEC 16)
    "cli",
    "__main__",
]
HELPERS = {"diagnostics", "fileio", "forks", "records", "registry", "resources"}


def test_the_graph_sees_known_edges():
    """A control: the checks below would see a wrong edge if there were one, because they see these."""
    graph = import_graph()
    assert {"model", "dsl", "ir"} <= graph["resolver"]
    assert "resolver" in graph["targets"] and "model" in graph["dsl"]
    assert {"exchange", "resolver", "profiles"} <= graph["formats"] and "formats" in graph["cli"]
    assert {"device", "formats", "exchange"} <= graph["exports"] and "exchange" in graph["device"]


def test_the_stages_keep_their_order():
    """Lower stages never import higher ones: model < plan < lang < values < resolve < exchange (the
    values the writers and the device share) < profiles < formats < targets < device < exports < cli."""
    graph = import_graph()
    for unit, deps in graph.items():
        if unit in HELPERS:
            assert deps <= HELPERS, (unit, deps - HELPERS)
            continue
        for dep in deps - HELPERS:
            assert STAGES.index(dep) < STAGES.index(unit), f"{unit} imports {dep}, a later stage"


def test_every_unit_has_its_place():
    """A new package or module of src/mdl is placed in STAGES (or HELPERS) before the order can check it."""
    units = {
        p.stem if p.is_file() else p.name
        for p in SRC.iterdir()
        if (p.suffix == ".py" and p.stem != "__init__") or (p / "__init__.py").is_file()
    }
    placed = (set(STAGES) - {"mdl"}) | HELPERS
    assert units == placed, units ^ placed


def test_registries_and_their_members_do_not_import_each_other():
    """A registry (`formats/__init__.py`, `exports/__init__.py`) names its members; a member imports the
    shared types below both (mdl.exchange), never its registry back. The registry's own modules beside
    it (formats/loading.py, which reads any description; formats/sniff.py, which says what a file is)
    are its users, not its members."""
    own = {SRC / "formats" / "loading.py", SRC / "formats" / "sniff.py", SRC / "exports" / "fleet.py"}
    for registry in ("formats", "exports"):
        for path in (SRC / registry).rglob("*.py"):
            if path == SRC / registry / "__init__.py" or path in own:
                continue
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if isinstance(node, ast.ImportFrom) and node.module is not None:
                    back = node.module == f"mdl.{registry}" or (
                        node.module == "mdl" and registry in {a.name for a in node.names}
                    )
                    assert not back, f"{path.relative_to(SRC)} imports its registry mdl.{registry}"


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
