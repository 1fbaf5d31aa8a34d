"""`mdl sim --scenario`: registers a scenario gives no value ("----", "xxxx", or absent) answer
exception 2, and drivers and `mdl read` then read expressions that need them as null."""

from __future__ import annotations

import json

from pymodbus.client import ModbusTcpClient

from support.run import cli, run_mdl

SCHEMA = """description: 'Scenario edges'
blocks:
  - id: 'Main'
    fields:
      - id: 'A'
        expression: 'int16(hr:0)'
      - id: 'B'
        expression: 'int16(hr:1)'
      - id: 'C'
        expression: 'uint16(hr:2)'
      - id: 'Sum'
        expression: 'A + B'
      - id: 'Text'
        expression: "concat('<', B, '|', C, '>')"
      - id: 'Mapped'
        expression: "enum(hr:0; 0x10 -> 'Sixteen'; 2 -> 'Two')"
tests:
  - id: 'edges'
    input:
      - firstAddress: 'hr:0'
        rawValues: 0010 ---- xxxx
    blocks:
      - id: 'Main'
        expected:
          A: [ 16 ]
          B: []
          C: []
          Sum: []
          Text: [ '<|>' ]
          Mapped: [ 'Sixteen' ]
"""


def test_missing_and_failing_registers(tmp_path, sim_factory):
    path = tmp_path / "edges.yaml"
    path.write_text(SCHEMA)
    proc = cli("test", path)
    assert proc.stdout.strip() == "1 passed, 0 failed", proc.stdout
    sim = sim_factory(path, "--scenario", "edges")
    client = ModbusTcpClient(sim.host, port=sim.port, timeout=5)
    assert client.connect()
    try:
        assert client.read_holding_registers(0, count=1, device_id=1).registers == [16]
        for address in (1, 2):
            rr = client.read_holding_registers(address, count=1, device_id=1)
            assert rr.isError() and rr.exception_code == 2
    finally:
        client.close()
    xml = tmp_path / "edges.xml"
    assert cli("import", path, "-o", xml).returncode == 0
    proc = run_mdl("read", xml, "--host", sim.host, "--port", sim.port, "--format", "json")
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout) == {"A": 16, "B": None, "C": None, "Sum": None, "Text": "<|>", "Mapped": "Sixteen"}


NEWER_KEYS = """description: 'Newer key names, coils with missing bits'
blocks:
  - id: 'Main'
    fields:
      - id: 'Power'
        expression: 'ieee754_32(ir:00000 # 2)'
      - id: 'Pump'
        expression: "boolean(c:1 ; 'off' ; 'on')"
      - id: 'Fan'
        expression: 'boolean(c:2)'
tests:
  - id: 'recorded'
    input:
      - firstRegisterAddress: 'ir:00000'
        registers: |-
          449A 5225
      - firstRegisterAddress: 'c:0'
        registers: 0 1 -
    blocks:
      - id: 'Main'
        expected:
          Power: [ 1234.567 ]
          Pump: [ 'on' ]
          Fan: []
"""


def test_newer_key_names_and_missing_bits(tmp_path):
    path = tmp_path / "newer.yaml"
    path.write_text(NEWER_KEYS)
    proc = cli("test", path)
    assert proc.stdout.strip() == "1 passed, 0 failed", proc.stdout + proc.stderr
    xml = tmp_path / "newer.xml"
    assert cli("import", path, "-o", xml).returncode == 0
    assert cli("validate", xml).returncode == 0
    assert cli("test", xml).stdout.strip() == "1 passed, 0 failed"
