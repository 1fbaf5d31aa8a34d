"""Every documented example runs, in a fresh folder, in the order a reader meets it.

The convention (docs/testing.md, "Documented examples"), for README.md and docs/*.md:

- A fenced block marked ```sh is runnable. Its commands run top to bottom, a document's blocks in order,
  in one scratch folder holding a copy of examples/, tests/data/ and tests/cpp/ (never the checkout).
  A line ending in `\\` goes on; `#` starts a comment. Each command must exit 0, or N when its comment
  says `exit N`.
- A block marked ```output after a ```sh block (prose between) is what the block's last command prints
  (`shows`): every line of stdout and stderr, whole (runs of spaces as one, blank lines aside), each
  stream in its order, the two interleaved as a terminal shows them. `...` in a line stands for any
  text, a line `...` for any lines (none too): a fragment says it is one. For `mdl sim ... &`, its
  serving lines.
- Every other block is not run: ```console (`$ ` commands for a real device or the checkout's own set
  up), ```text (synopses with placeholders such as FILE.xml, file contents), and code. A block without
  a language that shows a command (`mdl ...`, `$ ...`) must say which it is. A block that shows what
  mdl prints (`wrote `, `error:`, `note:`, `mdl sim: serving`, ...) is an ```output block, checked, or
  marked ```LANG shown-only: REASON where no test can make it (a real device, a terminal's redraw).
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
    blocks,
    command,
    doc_commands,
    scratch,
    shows,
    unchecked_outputs,
    unmarked_examples,
)

WALK = ["README.md", "docs/user-guide.md", "docs/probe.md"]  # a new user's reading, in order


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


@pytest.mark.commands  # serves devices
def test_a_new_users_walk(tmp_path):
    """README, then the user guide, then probe.md, in ONE folder, in that order, as a new user runs them:
    what an earlier document left (files it wrote, sims on their ports, the socat pair) breaks no later one."""
    walk = [(name, doc_commands((ROOT / name).read_text(encoding="utf-8"), name)) for name in WALK]
    assert all(commands for _, commands in walk), [name for name, commands in walk if not commands]
    with Runner(scratch(tmp_path)) as runner:
        for _, commands in walk:
            for cmd in commands:
                runner.run(cmd)
    assert runner.ran == sum(len(commands) for _, commands in walk)


def test_every_output_shown_is_checked():
    """A block that shows what mdl prints (`wrote `, `note:`, `warning:`, `error:`, `mdl sim: serving`, ...)
    is an ```output block after the ```sh block that prints it, or says why it cannot be one:
    ```LANG shown-only: REASON."""
    unchecked = [
        where for path in DOCS for where in unchecked_outputs(path.read_text(encoding="utf-8"), _doc_name(path))
    ]
    assert not unchecked, (
        "make these ```output blocks after the ```sh block that prints them (docs/testing.md), or mark them "
        f"```LANG shown-only: REASON: {unchecked}"
    )


def test_an_unchecked_output_is_found():
    """The control: mdl's output in ```text, without a language, in a ```sh comment, in a ```console
    transcript, and an ```output block after no ```sh block are each found; a marked block, an ```output
    block after a ```sh block and mere synopses are not."""
    text = (
        "```text\nexamples/x.xml: valid MDL 1.0\n```\n"  # line 2
        "```\nx.csv:3: warning: row skipped\n```\n"  # 5
        "```sh\nmdl sim x.xml --port 5020 &   # mdl sim: serving X on 127.0.0.1:5020 unit 1\n```\n"  # 8
        "```console\n$ mdl read x.xml --host 192.0.2.10\nerror: cannot connect\n```\n"  # 11
        "```text\nmdl test x.xml    # 1 passed, 0 failed\n```\n"  # 15
        "```text\nmdl capture x.xml -o raw.json\n```\n```output\nwrote raw.json\n```\n"  # 18, 21
        "```text shown-only: a real device\nerror: cannot connect\n```\n"  # 24
        "```text shown-only:\nwrote x.xml\n```\n"  # 27: a marker without its reason
        "```sh\nmdl validate x.xml\n```\n```output\nx.xml: valid MDL 1.0\n```\n"
        "```text\nmdl gen FILE.xml -o DIR   # exit 1 if any warning\nmdl sim FILE... [--unit U]\n```\n"
    )
    found = [where.split(":", 2)[1] for where in unchecked_outputs(text, "c.md")]
    assert found == ["2", "5", "8", "11", "15", "21", "27"], unchecked_outputs(text, "c.md")
    assert [block.shown_only for block in blocks(text)][7:9] == [True, False]


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


_TWO_VALID = "mdl validate examples/temco_tstat/temco_tstat.xml tests/data/all_tables.xml"
_FIRST = "examples/temco_tstat/temco_tstat.xml: valid MDL 1.0 (extensions: access, minimum, maximum)"
_SECOND = "tests/data/all_tables.xml: valid MDL 1.0 (...)"


def _with_output(*lines: str) -> str:
    return f"```sh\n{_TWO_VALID}\n```\nprints:\n```output\n" + "\n".join(lines) + "\n```\n"


@pytest.mark.commands  # serves a device
def test_a_failing_example_fails(tmp_path):
    """The control: a wrong exit status, a missing output line, a fragment of a line, a line left out
    without `...`, lines out of order and a sim's serving line that differs are each caught."""
    text = "```sh\nmdl validate examples/temco_tstat/temco_tstat.xml   # exit 1\n```\n" + "".join(
        _with_output(*lines)
        for lines in (
            ["not valid"],
            ["valid MDL 1.0"],  # a fragment of a line
            [_FIRST],  # the second line left out
            [_SECOND, _FIRST],  # out of order
        )
    )
    text += "```sh\nmdl sim tests/data/all_tables.xml --port 5020 &\n```\n```output\nmdl sim: serving X\n```\n"
    commands = doc_commands(text, "control.md")
    assert [cmd.status for cmd in commands] == [1, 0, 0, 0, 0, 0] and commands[1].output == ("not valid",)
    with Runner(scratch(tmp_path)) as runner:
        for cmd in commands:
            with pytest.raises(AssertionError):
                runner.run(cmd)


@pytest.mark.commands  # serves a device
def test_a_right_example_passes(tmp_path):
    """The other side: the whole output, or with `...` for the lines and the text left out, passes."""
    text = "".join(_with_output(*lines) for lines in ([_FIRST, _SECOND], [_FIRST, "..."], ["...", _SECOND]))
    text += "```sh\nmdl sim tests/data/all_tables.xml --port 5020 &\n```\n```output\n"
    text += "mdl sim: serving All Tables on 127.0.0.1:5020 unit 1\n```\n"
    with Runner(scratch(tmp_path)) as runner:
        for cmd in doc_commands(text, "control.md"):
            runner.run(cmd)
        assert runner.ran == 4


def test_output_is_matched_whole_in_order():
    """`shows`: every printed line, whole, each stream in order, interleaved; `...` elides."""
    out, err = "a 1\nb  2\n\n", "note: x\n"
    assert shows(["a 1", "note: x", "b 2"], out, err)  # interleaved as a terminal may show them
    assert shows(["note: x", "a  1", "b 2"], out, err)
    assert not shows(["b 2", "a 1", "note: x"], out, err)  # stdout out of its order
    assert not shows(["a 1", "b 2"], out, err)  # stderr left out, without `...`
    assert not shows(["a", "b 2", "note: x"], out, err)  # a fragment of a line
    assert shows(["a ...", "...", "b 2"], out, err)
    assert shows(["…"], out, err) and shows(["..."], "", "")
    assert not shows(["a 1", "a 1", "b 2", "note: x"], out, err)  # a line shown twice


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


_LINE = st.text(st.characters(blacklist_categories=("Cs", "Cc", "Zl", "Zp", "Zs")), min_size=1, max_size=8).filter(
    lambda line: "..." not in line and "…" not in line
)


@settings(max_examples=int(os.environ.get("MDL_FUZZ_DOC_EXAMPLES", "150")), deadline=None)
@given(st.lists(_LINE, max_size=6, unique=True), st.lists(_LINE, max_size=6, unique=True), st.data())
def test_any_interleaving_shows_and_nothing_less(out, err, data):
    """Built streams of distinct lines: every interleaving of the two is shown; one with a line left
    out, or two lines of a stream swapped, is not."""
    out = [line for line in out if line not in err]
    picks = data.draw(st.permutations([0] * len(out) + [1] * len(err)))
    streams, block = [iter(out), iter(err)], []
    for pick in picks:
        block.append(next(streams[pick]))
    printed = "\n".join(out), "\n".join(err)
    assert shows(block, *printed)
    if block:
        left_out = data.draw(st.integers(0, len(block) - 1))
        assert not shows(block[:left_out] + block[left_out + 1 :], *printed)
    if len(out) >= 2:
        swapped = [out[1] if line == out[0] else out[0] if line == out[1] else line for line in block]
        assert not shows(swapped, *printed)


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
