"""Documented examples as commands (docs/testing.md, "Documented examples"): the fenced blocks of a document,
each runnable line a Command, and a Runner that runs them in a scratch folder as a reader would (sims in the
background, a socat pair, cd kept); `shows`, the check that an ```output block is what its command printed,
and `unchecked_outputs`, the blocks that look like mdl's output without being checked."""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, replace
from pathlib import Path

from support.common import ROOT, skip_or_fail
from support.devices import SerialLine, Sim
from support.run import run_mdl

DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


COPIED = ["examples", "tests/data", "tests/cpp"]  # what the examples name, copied into each scratch folder


_FENCE = re.compile(r"^\s*(```|~~~)\s*([^\s`]*)\s*(.*?)\s*$")


SHOWN_ONLY = "shown-only:"  # ```LANG shown-only: REASON: a block that shows mdl's output and cannot be checked


_ELISION = re.compile(r"\.\.\.|…")  # in an ```output line: any text; a line of its own: any lines, none too


_MDL_COMMAND = re.compile(r"mdl(?: |$)(?![a-z0-9-]+: )")  # `mdl sim x.xml`, not its `mdl sim: serving ...`


# a line mdl prints: wrote FILE, [FILE:LINE:COL: ]error|warning|note: ..., mdl CMD: ..., N passed, M failed,
# FILE: valid MDL ..., FILE: profile NAME: N of M roles
_OUTPUT_LIKE = re.compile(
    r"^(?:wrote \S|(?:\S+: ?)?(?:error|warning|note): |mdl [a-z0-9-]+: |\d+ passed, \d+ failed)"
    r"|: valid MDL \d|: profile \S+: \d+ of \d+ roles"
)


_EXIT = re.compile(r"\bexit (\d+)\b")


_PTS = re.compile(r"/dev/pts/\d+")


_OPERATOR = re.compile(r"^[()<>|;&]+$|^\d?>>?$")


_SOCAT_PAIR = "socat -d -d pty,raw,echo=0 pty,raw,echo=0"


@dataclass(frozen=True)
class Command:
    where: str  # "docs/x.md:12": where a reader meets it
    code: str  # the shell text, without its comment and a final `&`
    background: bool = False
    status: int = 0
    output: tuple[str, ...] = ()

    @property
    def words(self) -> list[str]:
        return shlex.split(self.code)


def split_comment(line: str) -> tuple[str, str]:
    """(code, comment) of one shell line: a `#` that starts a word outside quotes starts the comment."""
    quote, escaped = "", False
    for i, ch in enumerate(line):
        if escaped:
            escaped = False
        elif ch == "\\" and quote != "'":
            escaped = True
        elif quote:
            quote = "" if ch == quote else quote
        elif ch in "'\"":
            quote = ch
        elif ch == "#" and (i == 0 or line[i - 1].isspace()):
            return line[:i].rstrip(), line[i + 1 :].strip()
    return line.rstrip(), ""


def command(line: str, where: str) -> Command | None:
    """A runnable line as a Command; None for a blank line or a comment."""
    code, comment = split_comment(line.strip())
    if not code:
        return None
    background = code.endswith("&") and not code.endswith("&&")
    status = _EXIT.search(comment)
    return Command(where, code[:-1].rstrip() if background else code, background, int(status.group(1)) if status else 0)


@dataclass(frozen=True)
class Block:
    lang: str
    line: int  # of its first content line
    lines: tuple[str, ...]
    info: str = ""  # what the opening fence says after the language

    @property
    def shown_only(self) -> bool:
        """Marked ```LANG shown-only: REASON: shows mdl's output that no test can reach (a real device)."""
        return self.info.startswith(SHOWN_ONLY) and bool(self.info[len(SHOWN_ONLY) :].strip())


def blocks(text: str) -> list[Block]:
    found, current, start, lang, info = [], None, 0, "", ""
    for number, line in enumerate(text.splitlines(), 1):
        fence = _FENCE.match(line)
        if current is None and fence:
            current, start, lang, info = [], number + 1, fence.group(2), fence.group(3)
        elif current is not None and fence and not fence.group(2) and not fence.group(3):
            found.append(Block(lang, start, tuple(current), info))
            current = None
        elif current is not None:
            current.append(line)
    return found


def doc_commands(text: str, name: str) -> list[Command]:
    """The runnable commands of a Markdown text, in order, each with the output its doc shows."""
    commands: list[Command] = []
    previous = ""
    for block in blocks(text):
        if block.lang == "output" and previous == "sh" and commands:
            commands[-1] = replace(
                commands[-1], output=commands[-1].output + tuple(line for line in block.lines if line.strip())
            )
        elif block.lang == "sh":
            joined, first = "", 0
            for offset, line in enumerate(block.lines):
                first = first if joined else block.line + offset
                if line.rstrip().endswith("\\") and not split_comment(line)[1]:
                    joined += line.rstrip()[:-1] + " "
                    continue
                found = command(joined + line, f"{name}:{first}")
                joined = ""
                if found is not None:
                    commands.append(found)
        previous = block.lang
    return commands


def _output_like(block: Block) -> list[str]:
    """The lines of a block (not ```sh, not ```output) that read as mdl's output: a line that is not a command,
    or the comment of one (`mdl test x.xml   # 1 passed, 0 failed`)."""
    found = []
    for line in block.lines:
        text = line.strip()
        if block.lang == "sh" or text.startswith(("$ ", "> ")) or _MDL_COMMAND.match(text):
            text = split_comment(text)[1]
        if _OUTPUT_LIKE.search(text):
            found.append(line.strip())
    return found


def unchecked_outputs(text: str, name: str) -> list[str]:
    """Blocks that show mdl's output without a check: a block (other than ```output) holding a line that
    reads as mdl's output (or a ```sh comment that does) and not marked ```LANG shown-only: REASON, and an
    ```output block that follows no ```sh block."""
    found, previous = [], ""
    for block in blocks(text):
        if block.lang == "output":
            if previous != "sh":
                found.append(f"{name}:{block.line}: an ```output block after no ```sh block is never checked")
        elif not block.shown_only and (lines := _output_like(block)):
            found.append(f"{name}:{block.line}: ```{block.lang} shows {lines[0]!r}")
        previous = block.lang if block.lang != "output" else previous
    return found


def _squeezed(line: str) -> str:
    return " ".join(line.split())


def _line_matches(shown: str, printed: str) -> bool:
    parts = _ELISION.split(_squeezed(shown))
    return re.fullmatch(".*".join(map(re.escape, parts)), printed) is not None


def shows(block: Sequence[str], stdout: str, stderr: str) -> bool:
    """True when the ```output lines `block` are what a terminal shows of `stdout` and `stderr`: each
    printed line once, whole (runs of spaces as one, blank lines aside), in its stream's order, the two
    streams interleaved in any way. `...` (or `…`) in a line stands for any text; a line of its own
    `...` for any lines, none too."""
    streams = [[_squeezed(line) for line in text.splitlines() if line.strip()] for text in (stdout, stderr)]
    out, err = streams
    states = {(0, 0)}  # lines of stdout and of stderr shown so far, after each line of the block
    for shown in filter(str.strip, block):
        if _squeezed(shown) in ("...", "…"):  # any lines: every state at or past one reached
            least, after = len(err) + 1, set()
            for j in range(len(out) + 1):
                least = min([least, *(k0 for j0, k0 in states if j0 == j)])
                after |= {(j, k) for k in range(least, len(err) + 1)}
            states = after
            continue
        states = {(j + 1, k) for j, k in states if j < len(out) and _line_matches(shown, out[j])} | {
            (j, k + 1) for j, k in states if k < len(err) and _line_matches(shown, err[k])
        }
        if not states:
            return False
    return (len(out), len(err)) in states


def unmarked_examples(text: str, name: str) -> list[str]:
    """Blocks without a language that show a command (`mdl ...`, `$ ...`): each must say whether it runs."""
    return [
        f"{name}:{block.line}"
        for block in blocks(text)
        if not block.lang and any(line.startswith(("mdl ", "$ ")) for line in block.lines)
    ]


@contextmanager
def _chdir(path: Path) -> Iterator[None]:
    before = os.getcwd()
    os.chdir(path)
    try:
        yield
    finally:
        os.chdir(before)


def scratch(folder: Path) -> Path:
    """A fresh folder holding copies of what the examples name."""
    for part in COPIED:  # as a checkout has them: not what a reader's earlier run left (build/, caches)
        shutil.copytree(ROOT / part, folder / part, ignore=shutil.ignore_patterns("build", "__pycache__"))
    return folder


class Runner:
    """Runs Commands one after another as a reader would, in `folder`: sims in the background on free
    ports, a socat pseudo terminal pair for `/dev/pts/N`, `cd` kept for the lines that follow."""

    def __init__(self, folder: Path):
        self.top = self.cwd = folder.resolve()
        self.sims: list[Sim] = []
        self.line: SerialLine | None = None
        self.names: dict[str, str] = {}  # a port or pseudo terminal the docs name -> the real one
        self.ran = 0

    def __enter__(self) -> Runner:
        return self

    def __exit__(self, *exc: object) -> None:
        try:
            for sim in self.sims:
                assert sim.stop() == 0, f"mdl sim did not stop cleanly: {sim.stderr}"
        finally:
            if self.line is not None:
                self.line.close()

    def _real(self, text: str, printed: bool = False) -> str:
        """The text with the ports and pseudo terminals the docs name replaced by the real ones; in what a
        command prints (`printed`), a port only as HOST:PORT (`it listens on 5020` stays)."""
        if not self.names:
            return text
        named = [
            (rf"(?<=:){re.escape(name)}" if printed and name.isdigit() else rf"(?<![\w./-]){re.escape(name)}")
            + r"(?![\w./-])"
            for name in sorted(self.names, key=len, reverse=True)
        ]  # all at once: /dev/pts/3 -> /dev/pts/4 must not go on to /dev/pts/4 -> /dev/pts/5
        return re.sub("|".join(named), lambda m: self.names[m.group(0)], text)

    def _take_pseudo_terminals(self, code: str) -> None:
        for pts in _PTS.findall(code):
            if pts not in self.names:
                ends = self._serial_line().ends
                taken = sum(name.startswith("/dev/pts/") for name in self.names)
                assert taken < 2, f"{pts}: a pseudo terminal pair has two ends"
                self.names[pts] = ends[taken]

    def _serial_line(self) -> SerialLine:
        if self.line is None:
            self.line = SerialLine()
        return self.line

    def run(self, cmd: Command) -> None:
        self._take_pseudo_terminals(cmd.code)
        parts = re.split(r"\s+&&\s+", self._real(cmd.code))
        for part in parts[:-1]:
            self._one(replace(cmd, code=part, background=False, status=0, output=()))
        self._one(replace(cmd, code=parts[-1]))  # its output's names are made real once they are known
        self.ran += 1

    def _one(self, cmd: Command) -> None:
        words = cmd.words
        assert not (cmd.output and (words[0] == "cd" or cmd.code == _SOCAT_PAIR)), f"{cmd.where}: no output to check"
        if words[0] == "cd":
            self.cwd = (self.cwd / words[1]).resolve()
            assert self.cwd.is_relative_to(self.top) and self.cwd.is_dir(), (cmd.where, self.cwd)
            return
        if cmd.code == _SOCAT_PAIR:
            assert cmd.background, f"{cmd.where}: socat serves until stopped: end the line with &"
            self._serial_line()
            return
        if words[:2] == ["mdl", "sim"]:
            self._sim(cmd, words[2:])
            return
        assert not cmd.background, f"{cmd.where}: only `mdl sim` and socat run in the background"
        if words[0] == "mdl" and not any(_OPERATOR.match(token) for token in _tokens(cmd.code)):
            proc = run_mdl(*words[1:], input="\n" * 40, cwd=self.cwd)
        else:
            proc = self._shell(cmd, words[0])
        shown = f"{cmd.where}: {cmd.code}\n{proc.stdout}{proc.stderr}"
        assert proc.returncode == cmd.status, (proc.returncode, shown)
        assert "Traceback" not in proc.stderr, shown
        if cmd.output:
            cmd = replace(cmd, output=tuple(self._real(line, printed=True) for line in cmd.output))
            assert shows(cmd.output, proc.stdout, proc.stderr), _differs(cmd, proc.stdout, proc.stderr)

    def _shell(self, cmd: Command, program: str) -> subprocess.CompletedProcess[str]:
        if "/" not in program and program != "mdl" and shutil.which(program) is None:
            skip_or_fail(f"{cmd.where}: {program} is not installed")
        env = {
            **os.environ,
            "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}",
            "PYTHONWARNINGS": "ignore",
        }
        return subprocess.run(
            ["bash", "-c", cmd.code],
            cwd=self.cwd,
            env=env,
            stdin=subprocess.DEVNULL,
            capture_output=True,
            text=True,
            timeout=600,
        )

    def _sim(self, cmd: Command, args: list[str]) -> None:
        """`mdl sim FILE... OPTIONS` on a free port (or the pseudo terminal named), until the Runner ends."""
        files = []
        while args and not args[0].startswith("-"):
            files.append(args.pop(0))
        options, port, serial = [], None, None
        while args:
            arg = args.pop(0)
            if arg in ("--port", "--serial") and args:
                port, serial = (args.pop(0), serial) if arg == "--port" else (port, args.pop(0))
            else:
                options.append(arg)
        assert files and (port or serial), f"{cmd.where}: name the files first, then --port N or --serial DEVICE"
        if port and port != "0":
            assert port not in self.names, f"{cmd.where}: port {port} is served by an earlier example"
        with _chdir(self.cwd):
            sim = Sim(files, *options, serial=serial)
        self.sims.append(sim)
        if port and port != "0":
            self.names[port] = str(sim.port)
        if cmd.output:  # what it printed when ready: its serving lines (stderr is read when it stops)
            output = tuple(self._real(line, printed=True) for line in cmd.output)
            printed = "\n".join(sim.ready_lines)
            assert shows(output, printed, ""), _differs(replace(cmd, output=output), printed, "")


def _differs(cmd: Command, stdout: str, stderr: str) -> str:
    return (
        f"{cmd.where}: {cmd.code}\nthe ```output block (each line whole, in order; `...` for lines left out):\n"
        + "\n".join(cmd.output)
        + f"\n--- what it printed, stdout:\n{stdout}--- stderr:\n{stderr}"
    )


def _tokens(code: str) -> list[str]:
    lexer = shlex.shlex(code, posix=True, punctuation_chars=True)
    lexer.whitespace_split = True
    return list(lexer)
