"""csv2xml pays for what the INI uses and reads each repeated cell once (issue 40), saying the same:
an INI whose functions are named after no profile's role reads no profile and imports no PyYAML (one
that names a role still has it played, tests/unit/profiles); the plain-text look that decides finds
every shipped role; a cell read from the cache is the cell read afresh, and one refused is refused
each time, with its row."""

from __future__ import annotations

import subprocess
import sys

import pytest

from mdl.formats.table.cells import CellError, read_type
from mdl.formats.table.numbers import parse_number
from mdl.formats.table.scoring import Text, normalize, words
from mdl.profiles.load import shipped_roles
from mdl.profiles.shipped import keyed

TABLE = "Address,Description,Format,Scale\n0,Total active power,int32,0.001\n2,Room temperature,int16,0.1\n"

_RUN = """
import atexit, sys
out = sys.argv.pop(1)
atexit.register(lambda: open(out, "w").write("\\n".join(sorted(sys.modules))))
sys.argv[0] = "mdl"
from mdl.cli import run
run()
"""


def modules_of_csv2xml(tmp_path, synonyms: str) -> tuple[set[str], str]:
    """The modules `mdl csv2xml` loads for an INI of these synonyms, and what it said."""
    (tmp_path / "m.csv").write_text(TABLE)
    ini = tmp_path / "m.ini"
    ini.write_text("[Column/Field Indices]\nmultiplier = Scale\n\n[Function Name Search Synonyms]\n" + synonyms)
    listing = tmp_path / "modules.txt"
    cmd = [sys.executable, "-c", _RUN, str(listing), "csv2xml", str(tmp_path / "m.csv"), "--ini", str(ini)]
    cmd += ["-o", str(tmp_path / "m.xml")]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    return set(listing.read_text().split()), proc.stderr


def test_an_ini_naming_no_role_reads_no_profile(tmp_path):
    modules, said = modules_of_csv2xml(tmp_path, "total_power = Total active power\nroom = Room temperature\n")
    assert "mdl.formats.table.convert" in modules  # control: the conversion ran
    assert not {"yaml", "mdl.profiles.load", "mdl.exchange.yamlnodes"} & modules
    assert "play it" not in said


def test_an_ini_naming_a_role_still_reads_the_profiles(tmp_path):
    modules, said = modules_of_csv2xml(tmp_path, "power_w = Total active power\nroom = Room temperature\n")
    assert "mdl.profiles.load" in modules
    assert "functions named after a profile's role play it: power_w (battery/evcharger/inverter/meter)" in said


def test_every_shipped_role_is_found_by_its_text():
    roles = shipped_roles()
    assert roles and keyed(roles) == set(roles)
    assert keyed(["total_power", "power", "room"]) == set()  # words of descriptions are no keys
    assert keyed(["roles", "name"]) == {"roles", "name"}  # other keys are (then the YAML is read)
    assert keyed([]) == set()


@pytest.mark.parametrize("cell", ["int16", " UINT32 ", "float", "char[8]", ">xB", "bool (bit 3)", "INT (Signed16)"])
def test_a_cached_type_is_the_type_read_afresh(cell):
    assert read_type(cell) == read_type.__wrapped__(cell)  # type: ignore[attr-defined]


def test_a_refused_cell_is_refused_each_time():
    for _ in range(2):
        with pytest.raises(CellError, match="unknown format 'int99'"):
            read_type("int99")
        with pytest.raises(CellError, match="multiplier 'mod10k"):
            parse_number("mod10k(True)", "auto", "multiplier", scale=True)


@pytest.mark.parametrize(
    "text", ["Total  active power (L1-L3)", "state_of_charge", "Température extérieure", "K", "a\u2028b", ""]
)
def test_a_text_is_split_as_by_the_regular_expressions(text):
    import re

    lower = text.lower()
    assert normalize(text) == " ".join(re.sub(r"[^\w]+", " ", lower).split())
    assert words(text) == re.findall(r"[^\W_]+", lower)
    t = Text(text)
    assert (t.norm, t.words) == (normalize(text), words(text))
    assert [w for w, _, _ in t.tokens] == t.words
