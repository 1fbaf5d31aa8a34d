"""SPEC 2.2's identity elements and the function elements marker, precision and write_multiple:
schema, reader, writer, `mdl validate`'s extension report and the checks on them."""

from __future__ import annotations

from mdl.formats.mdl.load import read_device
from mdl.formats.mdl.write import device_to_xml
from support.common import MDL_NS, fn_xml
from support.run import assert_clean_error, cli


def _doc(identity: str, functions: str) -> str:
    return (
        f'<?xml version="1.0" encoding="US-ASCII"?>\n<device xmlns="{MDL_NS}" version="1.0">\n'
        f"<name>Meter</name><description>d</description>{identity}{functions}</device>\n"
    )


IDENTITY = (
    "<manufacturer>ACME &#8211; Meters</manufacturer><product>M-23854</product>"
    "<product_version>1.2</product_version><program_id>9F:FF:FF:05:00:04:00:01</program_id>"
)
MODEL = fn_xml("model", "0", format="UINT16", marker="23854 23855", precision="-1")
SETPOINT = fn_xml("sp", "1", format="INT16", multiplier="0.1", precision="1", write_multiple="true")


def test_identity_and_new_function_elements_round_trip(tmp_path):
    path = tmp_path / "meter.xml"
    path.write_text(_doc(IDENTITY, MODEL + SETPOINT))
    device = read_device(path)
    assert (device.manufacturer, device.product, device.product_version, device.program_id) == (
        "ACME \u2013 Meters",
        "M-23854",
        "1.2",
        "9F:FF:FF:05:00:04:00:01",
    )
    model, sp = device.functions
    assert (model.marker, model.precision, model.write_multiple) == ([23854, 23855], -1, None)
    assert (sp.marker, sp.precision, sp.write_multiple) == (None, 1, True)
    again = tmp_path / "again.xml"
    again.write_text(device_to_xml(device))
    assert "&#8211;" in again.read_text()
    assert read_device(again) == device
    assert read_device(again).manufacturer == device.manufacturer


def test_validate_names_the_new_extensions(tmp_path):
    path = tmp_path / "meter.xml"
    path.write_text(_doc(IDENTITY, MODEL + SETPOINT))
    proc = cli("validate", str(path))
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == (
        f"{path}: valid MDL 1.0 (extensions: manufacturer, product, product_version, "
        "program_id, marker, precision, write_multiple)"
    )
    proc = cli("validate", "--schema", "0.9b", str(path))
    assert proc.returncode == 1


def test_identity_elements_keep_their_order(tmp_path):
    path = tmp_path / "meter.xml"
    path.write_text(_doc("<product>M</product><manufacturer>ACME</manufacturer>", MODEL))
    assert_clean_error(cli("validate", str(path)), 1, "manufacturer")


def test_a_marker_the_format_cannot_hold_is_refused(tmp_path):
    path = tmp_path / "meter.xml"
    path.write_text(
        _doc(
            "",
            fn_xml("kind", "0", format="INT16", marker="12 70000")
            + fn_xml("phases", "1", format="UINT8", length="Lower byte", marker="-1"),
        )
    )
    proc = cli("validate", str(path))
    assert_clean_error(proc, 1, "function 'kind': marker 70000 can never be read: the raw value is -32768..32767")
    assert "function 'phases': marker -1 can never be read: the raw value is 0..255" in proc.stderr


def test_a_marker_on_text_or_an_expression_is_refused(tmp_path):
    path = tmp_path / "meter.xml"
    path.write_text(_doc("", fn_xml("label", "0", format="STRING", count="4", marker="65")))
    assert_clean_error(cli("validate", str(path)), 1, "function 'label': a marker is a number")
    path.write_text(_doc("", fn_xml("e", "", expression="int16(hr:0) * 2", marker="4")))
    assert_clean_error(cli("validate", str(path)), 1, "function 'e': marker cannot be combined with an expression")


def test_markers_and_identity_are_not_integers_or_text_gone_wrong(tmp_path):
    path = tmp_path / "meter.xml"
    path.write_text(_doc("", fn_xml("kind", "0", format="UINT16", marker="0x10")))
    assert_clean_error(cli("validate", str(path)), 1, "marker")
    path.write_text(_doc("", fn_xml("kind", "0", format="UINT16", precision="1.5")))
    assert_clean_error(cli("validate", str(path)), 1, "precision")


def test_write_multiple_on_a_read_only_function_is_a_warning(tmp_path):
    path = tmp_path / "meter.xml"
    path.write_text(_doc("", fn_xml("t", "0", format="INT16", register_type="input", write_multiple="true")))
    proc = cli("validate", str(path))
    assert proc.returncode == 0
    assert "warning: function 't': write_multiple on a function that cannot be written does nothing" in proc.stderr
    assert cli("validate", "--fail-on-warning", str(path)).returncode == 1
