"""Every documented example runs, in a fresh folder, in the order a reader meets it.

The convention (docs/testing.md, "Documented examples"), for README.md and docs/*.md:

- A fenced block marked ```sh is runnable. Its commands run top to bottom, a document's blocks in order,
  in one scratch folder holding a copy of examples/, tests/data/ and tests/cpp/ (never the checkout).
  A line ending in `\\` goes on; `#` starts a comment. Each command must exit 0, or N when its comment
  says `exit N`.
- A block marked ```output after a ```sh block (prose between) holds lines the block's last command
  prints, each found in its output (stdout and stderr, runs of spaces as one).
- Every other block is not run: ```console (`$ ` commands for a real device or the checkout's own set
  up, and their output), ```text (synopses with placeholders such as FILE.xml, output, file contents),
  and code. A block without a language that shows a command (`mdl ...`, `$ ...`) must say which it is.
- `mdl sim ... &` serves on a free port: a later number equal to its `--port N` is that sim's port.
  `socat -d -d pty,raw,echo=0 pty,raw,echo=0 &` makes a pseudo terminal pair (tests/conftest.py's
  SerialLine); the `/dev/pts/N` names are its two ends, in the order they first appear.

tests/meta/test_help_examples.py runs the `mdl ...` lines of `--help` with the same Runner.
"""

from __future__ import annotations

import os
import shlex
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from support.common import ROOT
from support.doc_examples import (
    DOCS,
    Command,
    Runner,
    command,
    doc_commands,
    scratch,
    unmarked_examples,
)


def _doc_name(path: Path) -> str:
    return path.relative_to(ROOT).as_posix()


def _tier(commands: list[Command]) -> list[pytest.MarkDecorator]:
    programs = {cmd.words[0] for cmd in commands} - {"mdl", "cd", "socat"}
    if programs:  # make, a compiler, clang-tidy, a built program
        return [pytest.mark.compile]
    if any(cmd.words[:2] == ["mdl", "sim"] or "/dev/pts/" in cmd.code for cmd in commands):
        return [pytest.mark.commands]  # serves a device: the commands tier
    return []


def _documents() -> list[tuple[str, list[Command]]]:
    return [(_doc_name(path), doc_commands(path.read_text(encoding="utf-8"), _doc_name(path))) for path in DOCS]


RUNNABLE = [pytest.param(name, commands, marks=_tier(commands), id=name) for name, commands in _documents() if commands]


@pytest.mark.parametrize(("name", "commands"), RUNNABLE)
def test_documented_examples_run(name, commands, tmp_path):
    with Runner(scratch(tmp_path)) as runner:
        for cmd in commands:
            runner.run(cmd)
    assert runner.ran == len(commands)


def test_every_example_is_marked():
    """A block showing a command says whether it runs (sh) or is shown only (console, text)."""
    unmarked = [
        where for path in DOCS for where in unmarked_examples(path.read_text(encoding="utf-8"), _doc_name(path))
    ]
    assert not unmarked, f"mark these blocks ```sh (runnable) or ```console/```text (not run): {unmarked}"


def test_runnable_examples_start_sims_in_the_background():
    """A reader pasting a ```sh block gets the next lines run: a sim in it must not hold the shell."""
    waiting = [
        cmd.where
        for _, commands in _documents()
        for cmd in commands
        if cmd.words[:2] == ["mdl", "sim"] and not cmd.background
    ]
    assert not waiting, f"end these `mdl sim` lines with &: {waiting}"


def test_a_failing_example_fails(tmp_path):
    """The control: a wrong exit status and a missing output line are each caught."""
    text = (
        "```sh\nmdl validate examples/temco_tstat/temco_tstat.xml   # exit 1\n```\n"
        "```sh\nmdl validate examples/temco_tstat/temco_tstat.xml\n```\nprints:\n```output\nnot valid\n```\n"
    )
    commands = doc_commands(text, "control.md")
    assert [cmd.status for cmd in commands] == [1, 0] and commands[1].output == ("not valid",)
    with Runner(scratch(tmp_path)) as runner:
        for cmd in commands:
            with pytest.raises(AssertionError):
                runner.run(cmd)


# --- the extractor, by property ---

_WORD = st.text(st.characters(blacklist_categories=("Cs", "Cc", "Zl", "Zp")), min_size=1, max_size=12)
_COMMENT = st.text(st.characters(blacklist_categories=("Cs", "Cc", "Zl", "Zp")), max_size=20)


@settings(max_examples=int(os.environ.get("MDL_FUZZ_DOC_EXAMPLES", "150")), deadline=None)
@given(
    args=st.lists(_WORD, min_size=1, max_size=6),
    comment=_COMMENT.filter(lambda c: "exit" not in c),
    background=st.booleans(),
    status=st.none() | st.integers(0, 255),
)
def test_a_line_parses_back(args, comment, background, status):
    """A shell line built from words, `&` and a comment gives back those words, `&` and the status."""
    comment = comment if status is None else f"{comment} exit {status}"
    line = shlex.join(args) + (" &" if background else "") + (f"  # {comment}" if comment.strip() else "")
    cmd = command(line, "x.md:1")
    assert cmd is not None
    assert (cmd.words, cmd.background, cmd.status) == (args, background, status or 0)


_LANG = st.sampled_from(["sh", "console", "text", "output", "", "python"])
_LINES = st.lists(st.lists(_WORD, min_size=1, max_size=4).map(shlex.join), max_size=4)


@settings(max_examples=int(os.environ.get("MDL_FUZZ_DOC_EXAMPLES", "150")), deadline=None)
@given(st.lists(st.tuples(_LANG, _LINES, st.booleans()), max_size=6))
def test_only_sh_blocks_run(doc):
    """Built Markdown: the commands found are the lines of its ```sh blocks, in order, at their lines."""
    text, expected, number = "", [], 1
    for lang, lines, prose in doc:
        if prose:
            text, number = text + "Some prose: ```not a fence``` here.\n", number + 1
        text += f"```{lang}\n"
        for i, line in enumerate(lines):
            if lang == "sh" and not line.startswith("#"):
                expected.append((f"d.md:{number + 1 + i}", shlex.split(line)))
            text += line + "\n"
        text, number = text + "```\n", number + len(lines) + 2
    found = [(cmd.where, cmd.words) for cmd in doc_commands(text, "d.md")]
    assert found == expected
