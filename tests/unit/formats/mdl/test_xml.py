"""Loading and writing MDL XML: security, errors with positions, faithful round trips."""

from __future__ import annotations

from mdl.formats.mdl import device_to_xml, load_device
from mdl.formats.mdl.load import validate_file
from support.common import DATA, EXAMPLE, fn_xml
from support.run import assert_clean_error, run_mdl

BOMB = """<?xml version="1.0"?>
<!DOCTYPE lolz [
 <!ENTITY lol "lol">
 <!ENTITY lol2 "&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;">
 <!ENTITY lol3 "&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;">
 <!ENTITY lol4 "&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;">
]>
<device xmlns="http://www.ornl.gov/ModbusXMLSchema"><name>&lol4;</name><description>x</description></device>
"""
EXTERNAL = """<?xml version="1.0"?>
<!DOCTYPE d [ <!ENTITY secret SYSTEM "file:///etc/passwd"> ]>
<device xmlns="http://www.ornl.gov/ModbusXMLSchema"><name>&secret;</name><description>x</description></device>
"""


def test_entity_bombs_and_external_entities_are_refused(tmp_path):
    for name, text in (("bomb.xml", BOMB), ("external.xml", EXTERNAL)):
        path = tmp_path / name
        path.write_text(text)
        proc = run_mdl("validate", path)
        assert_clean_error(proc, 1, f"{path}:")
        assert "root:" not in proc.stdout + proc.stderr
        assert_clean_error(run_mdl("gen", path, "-o", tmp_path / "out"), 1)
        assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def test_malformed_xml_names_line_and_column(tmp_path):
    path = tmp_path / "bad.xml"
    path.write_text(
        '<?xml version="1.0"?>\n<device xmlns="http://www.ornl.gov/ModbusXMLSchema">\n  <name>x</nam>\n</device>\n'
    )
    proc = run_mdl("validate", path)
    assert_clean_error(proc, 1, f"{path}:3:", "malformed XML")


def test_every_error_of_a_file_is_listed(tmp_path, write_device):
    path = write_device(fn_xml("a", "1", count="0") + fn_xml("b", "2", format="INT15"))
    proc = run_mdl("validate", path)
    assert_clean_error(proc, 1)
    lines = [line for line in proc.stderr.splitlines() if "error:" in line]
    assert len(lines) == 2 and "count" in lines[0] and "INT15" in lines[1]
    assert all(line.startswith(f"{path}:") for line in lines)


def test_semantic_errors_listed_together(tmp_path, write_device):
    path = write_device(
        fn_xml("a", "1")
        + fn_xml("a", "70000")
        + fn_xml("s", "5", format="STRING", count="126")
        + fn_xml("f", "9", read_function_code="arg = system(1);")
    )
    proc = run_mdl("validate", path)
    assert_clean_error(
        proc,
        1,
        "duplicate function name",
        "address 70000 is over 65535",
        "at most 125",
        "function 'f': read_function_code",
        "system",
    )


def test_missing_and_unreadable_files(tmp_path):
    assert_clean_error(run_mdl("validate", tmp_path / "none.xml"), 1, "none.xml: error: no such file")
    assert_clean_error(run_mdl("validate", tmp_path), 1, "is a directory")
    assert_clean_error(run_mdl("gen", tmp_path / "none.xml"), 1, "no such file")


def test_round_trip_keeps_every_field(tmp_path):
    for source in (DATA / "all_tables.xml", EXAMPLE / "temco_tstat.xml"):
        first = load_device(source)
        path = tmp_path / source.name
        path.write_text(device_to_xml(first))
        second = load_device(path)
        assert second == first
        assert device_to_xml(second) == device_to_xml(first)


def test_writer_is_ascii_with_character_references(tmp_path, write_device):
    path = write_device(fn_xml("t", "1", units="&#176;C"), name="Caf&#233; &lt;1&gt;")
    device = load_device(path)
    assert device.name == "Café <1>" and device.functions[0].units == "°C"
    text = device_to_xml(device)
    assert text.isascii() and "&#176;C" in text and "Caf&#233; &lt;1&gt;" in text
    assert "<multiplier>" not in text and "<length>" not in text  # defaults are not written back


def test_defaults_applied_in_model(write_device):
    fn = load_device(write_device(fn_xml("t", "1"), version=None)).functions[0]
    assert (fn.eff_length, fn.eff_count, fn.eff_format, fn.eff_multiplier, fn.table, fn.eff_access) == (
        "Full word",
        1,
        "INT8",
        1.0,
        "holding",
        "read_write",
    )
    assert fn.length is None and fn.count is None


def test_validate_many_files_reports_each(tmp_path, write_device):
    good = write_device(fn_xml("t", "1"), version=None, filename="good.xml")
    bad = tmp_path / "bad.xml"
    bad.write_text("not xml")
    proc = run_mdl("validate", good, bad)
    assert proc.returncode == 1
    assert f"{good}: valid MDL 0.9b" in proc.stdout and f"{bad}:1" in proc.stderr


def test_validate_file_api_positions(write_device):
    device, diags = validate_file(write_device(""))
    assert device is not None and diags == []
