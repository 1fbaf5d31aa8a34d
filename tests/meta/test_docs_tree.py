"""The documentation names only files that are in the tree.

Every file reference in README.md, CONTRIBUTING.md and docs/*.md must exist, relative to the repository
or to src/mdl/ (a Markdown link: relative to its document's folder). A stale one fails naming the
document and the line. What counts as a file reference (CONTRIBUTING.md's rules, "Documentation"):
- a path starting with `src/` or `tests/`, or with another folder of the repository (`docs/`, `examples/`,
  `scripts/`, ...), anywhere, code blocks included (their commands run from the repository);
- outside code blocks, a path whose last part has an extension (`ir/steps.py`, `targets/c/templates/steps.j2`);
- an inline code span that is a folder of src/mdl, ending in `/` (`dsl/cfrag/`);
- a Markdown link's target; a dotted name `mdl.module.name` (the module, and the name defined in it).
`<name>` or `*` in a path is a wildcard that must match something. Command examples' own files
(`-o drivers/`, `DIR/<stem>.h`) are not the tree's; another project's files are listed in ELSEWHERE.

A longer run of the extractor's property test by hand: MDL_FUZZ_DOCS=3000 python -m pytest tests/meta/test_docs_tree.py
"""

from __future__ import annotations

import ast
import os
import re
import subprocess
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from support.common import ROOT  # noqa: E402

SRC = ROOT / "src" / "mdl"

# Files of other projects the docs cite (they are not in this tree): path -> whose
ELSEWHERE = {
    "utils/maps.py": "VOLTTRON's Modbus-TK driver (volttron-lib-modbustk-driver)",
    "utils/helpers.py": "VOLTTRON's Modbus-TK driver (volttron-lib-modbustk-driver)",
    "utils/client.py": "VOLTTRON's Modbus-TK driver (volttron-lib-modbustk-driver)",
    "Modules/Modbus_Handler/Modbus.ini": "12019/WISEAgent on GitHub",
    "Sample/Modbus_Handler/Modbus_Handler.ini": "ADVANTECH-Corp/WISEAgent on GitHub",
    "Sample/ModbusSample/ModbusSample.ini": "ADVANTECH-Corp/WISEAgent on GitHub",
    "Sample/Modbus_Handler/Modbus_Handler.cpp": "ADVANTECH-Corp/WISEAgent on GitHub",
}

_PATH = re.compile(r"(?<![\w./~:@$%<>*-])(?:[\w.<>*-]+/)+[\w.<>*-]*")
_EXTENSION = re.compile(r"[^./]\.[A-Za-z][A-Za-z0-9]{0,4}$")  # not a hidden name (`.ssh`)
_PLACEHOLDER_FOLDER = re.compile(r"[A-Z][A-Z_]*")  # DIR/<stem>.h: the user's folder
_ALTERNATIVE = re.compile(r"\.\w+")  # `<stem>.h/.cc`: a suffix standing for "or .cc", not a folder
_PLACEHOLDER = re.compile(r"<[^<>/]*>")
_CODE_SPAN = re.compile(r"`([^`]+)`")
_LINK = re.compile(r"\]\(([^()\s]+)\)")
_DOTTED = re.compile(r"(?<![\w./-])mdl(?:\.[A-Za-z_]\w*)+")
_FENCE = re.compile(r"^\s*(```|~~~)")


@dataclass(frozen=True)
class Reference:
    line: int
    text: str
    kind: str  # "path", "link" or "name"


def documents() -> list[Path]:
    return [ROOT / "README.md", ROOT / "CONTRIBUTING.md", *sorted((ROOT / "docs").glob("*.md"))]


@cache
def _folders(base: Path) -> frozenset[str]:
    """The entries a path may start with to be anchored at `base` (hidden ones only for .ci), less what
    git ignores: `build/` that scripts/demo leaves is not the tree's (a doc's `build/tstat_reader` is a
    command's own file), whether or not the demo ran first."""
    names = [
        p.name for p in base.iterdir() if p.name != "__pycache__" and (not p.name.startswith(".") or p.name == ".ci")
    ]
    return frozenset(name for name in names if not _ignored(base / name))


def _ignored(path: Path) -> bool:
    """Whether git ignores `path` (False outside a git checkout, or without git)."""
    try:
        proc = subprocess.run(["git", "check-ignore", "-q", str(path)], cwd=ROOT, capture_output=True, timeout=30)
    except (OSError, subprocess.SubprocessError):
        return False
    return proc.returncode == 0


def _is_reference(token: str, fenced: bool, whole_span: bool) -> bool:
    parts = token.rstrip("/").split("/")
    if (
        parts[0] == ".."
        or _PLACEHOLDER_FOLDER.fullmatch(parts[0])
        or any(_ALTERNATIVE.fullmatch(part) for part in parts[1:])
    ):
        return False
    if parts[0] in _folders(ROOT):
        return True
    if fenced:  # a command's own files (its -o folder, a library of the user's): not the tree's
        return False
    folder_span = whole_span and token.endswith("/") and parts[0] in _folders(SRC)  # `formats/xif/`
    return bool(_EXTENSION.search(parts[-1])) or folder_span


def references(text: str) -> list[Reference]:
    """Every file reference and dotted mdl name in a Markdown text, with its line."""
    found: list[Reference] = []
    fenced = False
    for number, line in enumerate(text.splitlines(), 1):
        if _FENCE.match(line):
            fenced = not fenced
            continue
        spans = set() if fenced else set(_CODE_SPAN.findall(line))
        links = [] if fenced else [t for t in _LINK.findall(line) if ":" not in t and not t.startswith("#")]
        for match in _PATH.finditer(line):
            token = match.group().rstrip(".")
            if token not in links and _is_reference(token, fenced, token in spans):
                found.append(Reference(number, token, "path"))
        found += [Reference(number, target, "link") for target in links]
        found += [Reference(number, name, "name") for name in _DOTTED.findall(line)]
    return found


def _path_exists(token: str) -> bool:
    pattern = _PLACEHOLDER.sub("*", token.rstrip("/"))
    for base in (ROOT, SRC):
        if "*" in pattern:
            if any(base.glob(pattern)):
                return True
        elif (base / pattern).exists():
            return True
    return False


@cache
def _top_level_names(module: Path) -> frozenset[str]:
    """The names a module defines or imports at its top level (inside `if`/`try` blocks too)."""
    names: set[str] = set()
    body = list(ast.parse(module.read_text(encoding="utf-8")).body)
    while body:
        node = body.pop()
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            names.update(n.id for t in targets for n in ast.walk(t) if isinstance(n, ast.Name))
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names.update((alias.asname or alias.name).split(".")[0] for alias in node.names)
        elif isinstance(node, (ast.If, ast.Try, ast.With)):
            body += [
                *node.body,
                *getattr(node, "orelse", []),
                *getattr(node, "finalbody", []),
                *(stmt for handler in getattr(node, "handlers", []) for stmt in handler.body),
            ]
    return frozenset(names)


def _name_exists(dotted: str) -> bool:
    """`mdl.a.b.name`: the longest module path that is a file or package, then a name defined in it."""
    parts = dotted.split(".")[1:]
    folder = SRC
    while parts and (folder / parts[0]).is_dir():
        folder = folder / parts.pop(0)
    if parts and (folder / f"{parts[0]}.py").is_file():
        module = folder / f"{parts.pop(0)}.py"
    else:
        module = folder / "__init__.py"
    return module.is_file() and (not parts or parts[0] in _top_level_names(module))


def missing(doc: Path, text: str) -> list[str]:
    """`doc:line: reference` for each reference in `text` that is not in the tree."""
    out = []
    for ref in references(text):
        if ref.kind == "path":
            ok = ref.text in ELSEWHERE or _path_exists(ref.text)
        elif ref.kind == "link":
            ok = (doc.parent / ref.text.split("#", 1)[0]).exists()
        else:
            ok = _name_exists(ref.text)
        if not ok:
            where = "its folder" if ref.kind == "link" else "the repository or src/mdl/"
            out.append(
                f"{doc.relative_to(ROOT)}:{ref.line}: {ref.kind} `{ref.text}` is not in the tree (relative to {where})"
            )
    return out


@pytest.mark.parametrize("doc", documents(), ids=lambda p: str(p.relative_to(ROOT)))
def test_every_file_a_document_names_exists(doc):
    assert doc.is_file(), f"{doc.relative_to(ROOT)} is missing"
    stale = missing(doc, doc.read_text(encoding="utf-8"))
    assert not stale, "stale references (fix the document, or list another project's file in ELSEWHERE):\n" + "\n".join(
        stale
    )


def test_every_other_projects_file_is_still_cited():
    """ELSEWHERE does not outlive the text that needed it."""
    cited = {ref.text for doc in documents() if doc.is_file() for ref in references(doc.read_text(encoding="utf-8"))}
    assert not set(ELSEWHERE) - cited, f"no document names these any more: {sorted(set(ELSEWHERE) - cited)}"


def test_the_rules_on_known_lines():
    """A control: what is a reference, what is not, and each kind of stale one is reported with its line."""
    text = "\n".join(
        [
            "The IR is `ir/steps.py`; the C steps are in targets/c/templates/steps.j2 and `dsl/cfrag/`.",  # 1
            "Read `formats/toolkit.py` and src/mdl/nothing/",  # 2
            "```sh",  # 3
            "mdl gen x.xml -o drivers/ && cc out/temco_tstat.cc && python3 scripts/regen_golden.py",  # 4
            "python3 scripts/no_such_script.py",  # 5
            "```",  # 6
            "Writes <stem>.h/.cc; read/write and 0.9b/1.0; see [the guide](docs/user-guide.md), "
            "[gone](docs/gone.md), https://example.com/a/b.py, `formats/<name>/read.py`.",  # 7
            "mdl.targets.render, mdl.ir.steps.Scale, mdl.targets.no_such_name, mdl.nowhere.",  # 8
            "utils/client.py is VOLTTRON's; `model/`, `formats/missing/`; not `device/name`, DIR/<stem>.h, "
            "`.ssh/`",  # 9
        ]
    )
    assert missing(ROOT / "README.md", text) == [
        "README.md:2: path `formats/toolkit.py` is not in the tree (relative to the repository or src/mdl/)",
        "README.md:2: path `src/mdl/nothing/` is not in the tree (relative to the repository or src/mdl/)",
        "README.md:5: path `scripts/no_such_script.py` is not in the tree (relative to the repository or src/mdl/)",
        "README.md:7: link `docs/gone.md` is not in the tree (relative to its folder)",
        "README.md:8: name `mdl.targets.no_such_name` is not in the tree (relative to the repository or src/mdl/)",
        "README.md:8: name `mdl.nowhere` is not in the tree (relative to the repository or src/mdl/)",
        "README.md:9: path `formats/missing/` is not in the tree (relative to the repository or src/mdl/)",
    ]


_TREE_FILES = sorted(
    p.relative_to(ROOT).as_posix()
    for folder in ("src", "tests", "docs", "scripts")
    for p in (ROOT / folder).rglob("*")
    if p.is_file() and "__pycache__" not in p.parts and p.suffix in (".py", ".md", ".j2")
)
_PROSE = st.text(
    st.characters(codec="utf-8", exclude_characters="`/()[].\r\n\x0b\x0c\x1c\x1d\x1e\x85\u2028\u2029"), max_size=40
)
_NAME = st.text(st.sampled_from("abcdefghijklmnopqrstuvwxyz_"), min_size=1, max_size=12)


@settings(max_examples=int(os.environ.get("MDL_FUZZ_DOCS", "150")), deadline=None)
@given(
    st.lists(st.tuples(_PROSE, st.sampled_from(_TREE_FILES), st.booleans(), st.integers(0, 2)), min_size=1, max_size=8),
    st.integers(0, 7),
    _NAME,
)
def test_any_prose_keeps_references_and_finds_the_stale_one(lines, at, name):
    """Real files named in any text (in backticks or not, with sentence punctuation) are found and pass;
    one file that is not there, put on any line, is the one reported, at that line."""
    stale = f"src/mdl/{name}_not_in_the_tree.py"
    text = []
    for prose, path, quoted, punctuation in lines:
        shown = f"`{path}`" if quoted else path
        text.append(f"{prose} {shown}{['', '.', ','][punctuation]} {prose}")
    line = min(at, len(text) - 1)
    text[line] += f" and {stale}."
    found = references("\n".join(text))
    assert {ref.text for ref in found if ref.kind == "path"} >= {path for _, path, _, _ in lines}
    assert missing(ROOT / "README.md", "\n".join(text)) == [
        f"README.md:{line + 1}: path `{stale}` is not in the tree (relative to the repository or src/mdl/)"
    ]
