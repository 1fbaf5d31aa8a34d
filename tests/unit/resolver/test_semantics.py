"""`mdl validate` refuses minimum/maximum where they mean nothing (SPEC section 2: writes outside them are
refused, so a bound on text, or crossed bounds, are a mistake in the document)."""

from __future__ import annotations

import pytest

from support.common import fn_xml
from support.run import assert_clean_error, cli, run_mdl


@pytest.mark.parametrize(
    "function, message",
    [
        (fn_xml("label", "1 2", format="STRING", minimum="1"), "function 'label': minimum 1 cannot apply to a STRING"),
        (fn_xml("label", "1 2", format="STRING", maximum="9"), "function 'label': maximum 9 cannot apply to a STRING"),
        (
            fn_xml("level", "1", format="UINT16", minimum="10", maximum="5"),
            "function 'level': minimum 10 is above maximum 5",
        ),
    ],
)
def test_bounds_that_mean_nothing_are_refused(write_device, function, message):
    path = write_device(function + fn_xml("fine", "40", format="UINT16", minimum="0", maximum="10"))
    proc = run_mdl("validate", path)
    assert_clean_error(proc, 1, f"{path}:", message)
    assert "function 'fine'" not in proc.stderr


def test_bounds_on_a_bit_are_accepted(write_device):
    """A coil that only accepts 1 (a trigger) is a real device's way."""
    path = write_device(
        fn_xml("pump", "1", format="BIT", register_type="coil", minimum="1", maximum="1")
        + fn_xml("fan", "2", format="BIT", register_type="coil", minimum="-1", maximum="5")
    )
    proc = run_mdl("validate", path)
    assert proc.returncode == 0, proc.stderr


def test_multipliers_no_driver_can_use(write_device):
    """Zero makes every value the offset and nothing writable: refused. A tiny one (1e-320, whose
    reciprocal is no double) is a plain multiplication: generated, no traceback."""
    zero = write_device(fn_xml("z", "1", format="INT16", multiplier="0"), filename="zero.xml")
    assert_clean_error(cli("validate", zero), 1, "multiplier 0 reads every value as the offset")
    tiny = write_device(fn_xml("t", "1", format="INT16", multiplier="1e-320"), filename="tiny.xml")
    proc = cli("gen", tiny, "--lang", "python", "-o", tiny.parent / "out")
    assert proc.returncode == 0, proc.stderr


def test_a_write_fragment_on_text_is_refused(write_device):
    path = write_device(fn_xml("s", "1", format="STRING", count="2", write_function_code="r1 = arg;"))
    assert_clean_error(cli("validate", path), 1, "a write fragment takes a number; format STRING cannot use one")
