"""Issue 37: an ESPHome node on a MAX485 module drives the transceiver's DE/RE from a pin: `--flow-control-pin`
writes `modbus: {flow_control_pin: PIN}` (without it `modbus: {}`). Every pin option is checked before it
reaches the YAML, and the node's pins are three (ESPHome refuses a pin used twice). `esphome config` accepts
the node in tests/engines/test_export_esphome.py."""

from __future__ import annotations

import pytest
import yaml

from support.common import EXAMPLE
from support.run import assert_clean_error, cli

TEMCO = EXAMPLE / "temco_tstat.xml"


def node(*extra):
    proc = cli("export", TEMCO, "--to", "esphome", "--baud", "9600", *extra)
    assert proc.returncode == 0, proc.stderr
    return yaml.safe_load(proc.stdout)


@pytest.mark.parametrize("pin", ["GPIO4", "4", "D4"])
def test_the_flow_control_pin_is_the_modbus_components(pin):
    written = node("--flow-control-pin", pin)
    assert written["modbus"] == {"flow_control_pin": pin}
    assert (written["uart"]["tx_pin"], written["uart"]["rx_pin"]) == ("GPIO17", "GPIO16")


def test_without_it_the_modbus_component_is_bare():
    assert node()["modbus"] == {}


@pytest.mark.parametrize("option", ["--flow-control-pin", "--tx-pin", "--rx-pin"])
@pytest.mark.parametrize(
    "pin", ["GPIO4\nwifi: {}", "GPIO4 # x", "{number: 4}", "", "gpio 4", "$PIN", "GPIO" + "4" * 40]
)
def test_a_pin_is_checked_before_it_reaches_the_yaml(option, pin):
    proc = cli("export", TEMCO, "--to", "esphome", option, pin)
    assert_clean_error(proc, 2, "is no pin: give GPIOn (GPIO4), a number (4) or one of the board's pin names")
    assert proc.stdout == ""


@pytest.mark.parametrize(
    ("args", "said"),
    [
        (("--flow-control-pin", "GPIO17"), "--tx-pin GPIO17 and --flow-control-pin GPIO17 name one pin"),
        (("--flow-control-pin", "16"), "--rx-pin GPIO16 and --flow-control-pin 16 name one pin"),
        (("--tx-pin", "GPIO5", "--rx-pin", "5"), "--tx-pin GPIO5 and --rx-pin 5 name one pin"),
    ],
)
def test_each_pin_is_its_own(args, said):
    assert_clean_error(cli("export", TEMCO, "--to", "esphome", *args), 2, said)


def test_the_flow_control_pin_needs_esphome():
    proc = cli("export", TEMCO, "--to", "homeassistant", "--flow-control-pin", "GPIO4")
    assert_clean_error(proc, 2, "--flow-control-pin sets the ESPHome node: it needs --to esphome")
