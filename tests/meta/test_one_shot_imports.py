"""A one-shot command imports only what it uses (issue 40): `mdl read` of raw registers or of a description,
and `mdl --help`, each run as a user runs it (`python -X importtime -m mdl ...`), never import the
converters, the exporters, the code generators, the fleet poller or the libraries only those use. The import
graph is what is held here, not a time: the times are bench/ figures (docs/performance.md). The modules are
those in sys.modules when the command exits (`-X importtime` does not see a module importlib.import_module
loads, as the command group loads a command's module)."""

from __future__ import annotations

import subprocess
import sys

import pytest

from mdl.cli.app import COMMANDS, main
from support.common import EXAMPLE

NOWHERE = ["--host", "127.0.0.1", "--port", "1", "--timeout", "0.2", "--retries", "0"]  # refused at once
# what no one-shot read needs: another command's module, a converter, a writer, a poller, their libraries
NEVER = (
    "mdl.cli.convert",
    "mdl.cli.gen",
    "mdl.cli.survey",
    "mdl.cli.validate",
    "mdl.cli.scenarios",
    "mdl.exports",
    "mdl.targets",
    "mdl.formats.table",
    "mdl.device.fleet",
    "mdl.device.server",
    "mdl.profiles",
    "jinja2",
    "yaml",
    "openpyxl",
    "pdfplumber",
    "pypdfium2",
    "paho",
    "prometheus_client",
    "mdl.dsl.cfrag.cemit",  # the C emitter (a read runs a fragment's Python translation)
    "hashlib",  # only a write of a file (fileio's temporary name, secrets) or a long generated name uses it
    "secrets",
    "shutil",  # only fileio's fallback copy (shutil imports bz2 and lzma)
    "csv",  # only a csv record
    "decimal",  # only a value shown with a precision, or a fragment's float literal
    "fractions",
    "shlex",  # only the message for a file that is not what it was given as
    "mdl.formats.wise.sections",  # a file is told from WISE-Agent's and XIF's without their words
    "mdl.formats.xif.columns",
)
# nor, without a description, the expression and fragment compilers (a raw read's functions have neither)
COMPILERS = (
    "mdl.dsl.cfrag",
    "mdl.dsl.expr.fields",
    "mdl.dsl.expr.parser",
    "mdl.dsl.expr.lower",
    "mdl.dsl.expr.nodes",
    "mdl.dsl.expr.pyemit",
)
# the only dataclasses a one-shot command defines: the types the library's users build and change themselves
# (every other class of its path is a record, mdl.records, or a plain class: a dataclass's methods are
# compiled as its class is made, 3 M instructions each, docs/performance.md)
PUBLIC_DATACLASSES = {
    "mdl.diagnostics.Diagnostic",
    "mdl.diagnostics.TextSpan",
    "mdl.model.Device",
    "mdl.model.Function",
    "mdl.model.Scenario",
    "mdl.model.ScenarioInput",
}


_RUN = """
import atexit, sys
out = sys.argv.pop(1)
def made():  # the dataclasses of mdl's modules, as `dataclass:MODULE.CLASS`
    for name, module in list(sys.modules.items()):
        for value in list(vars(module).values()) if name.startswith("mdl") else ():
            if isinstance(value, type) and value.__module__ == name and "__dataclass_fields__" in value.__dict__:
                yield f"dataclass:{name}.{value.__qualname__}"
atexit.register(lambda: open(out, "w").write("\\n".join(sorted([*sys.modules, *made()]))))
sys.argv[0] = "mdl"
from mdl.cli import run
run()
"""


def imported(tmp_path, *args: str) -> set[str]:
    """The modules loaded by `mdl ARGS`, run as the console script runs it."""
    listing = tmp_path / "modules.txt"
    proc = subprocess.run([sys.executable, "-c", _RUN, str(listing), *args], capture_output=True, text=True, timeout=60)
    assert listing.is_file(), proc.stderr
    return set(listing.read_text().split())


def offending(modules: set[str], never: tuple[str, ...] = NEVER) -> list[str]:
    return sorted(m for m in modules if any(m == n or m.startswith(n + ".") for n in never))


@pytest.mark.parametrize(
    "args",
    [
        ["read", *NOWHERE, "--raw", "hr:0-3"],
        ["read", str(EXAMPLE / "temco_tstat.xml"), *NOWHERE, "fan_speed"],
        ["write", str(EXAMPLE / "temco_tstat.xml"), *NOWHERE, "fan_speed=1"],
    ],
    ids=["raw", "described", "write"],
)
def test_a_one_shot_read_or_write_imports_only_what_it_uses(args, tmp_path):
    modules = imported(tmp_path, *args)
    assert "mdl.device.runtime" in modules  # control: the run got as far as the device
    assert not offending(modules)
    made = {m.removeprefix("dataclass:") for m in modules if m.startswith("dataclass:")}
    assert "mdl.model.Function" in made  # control: the listing sees dataclasses
    assert made <= PUBLIC_DATACLASSES
    if "--raw" in args:
        assert not offending(modules, ("lxml", "mdl.formats"))  # no description: no XML
        assert not offending(modules, COMPILERS)


def test_help_imports_no_device_code(tmp_path):
    modules = imported(tmp_path, "--help")
    assert "mdl.cli.convert" in modules  # control: --help lists every command, so imports their modules
    heavy = ("pymodbus", "mdl.device.runtime", "lxml", "jinja2", "yaml", "mdl.targets.templating")
    assert not offending(modules, heavy)


def test_every_command_is_where_the_group_looks_for_it():
    """COMMANDS names each command's module: each module registers exactly the commands it is named for."""
    every = main.every_command()
    assert sorted(every) == sorted(COMMANDS)
    for name, cmd in every.items():
        assert cmd.callback is not None and cmd.callback.__module__ == COMMANDS[name], name
