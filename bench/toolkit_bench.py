#!/usr/bin/env python3
"""Benchmarks of the Modbus Schema Toolkit path. Prints its figures; asserts nothing.

    python3 bench/toolkit_bench.py

1. import + generate (Python and C++) a 700-field SunSpec-sized schema, through the CLI and
   in-process (best of 3);
2. `mdl test` on the 59 reference scenarios (best of 3).
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
REFERENCE = ROOT.parent / "shared" / "conformance" / "modbus-schema-reference"
sys.path.insert(0, str(ROOT / "src"))


def sunspec_like(fields: int = 700) -> str:
    """A schema shaped like SunSpec models: blocks of measurements with scale factors."""
    lines = ["description: 'SunSpec-sized synthetic device'", "maxRegistersPerModbusRequest: 100", "blocks:"]
    address = 40000
    per_block = 70
    kinds = [
        "uint16(hr:{a})",
        "int16(hr:{a})",
        "uint32(hr:{a}#2)",
        "int32(hr:{a}#2)",
        "ieee754_32(hr:{a}#2)",
        "utf8(hr:{a}#8)",
        "enum(hr:{a} ; 0xFFFF ; 1 -> 'Off'; 2 -> 'Sleeping'; 3 -> 'Starting'; 4 -> 'MPPT')",
        "bitset(hr:{a}#2 ; 0xFFFF 0xFFFF ; 0 -> 'Ground fault'; 1 -> 'DC over voltage'; 2 -> 'AC disconnect')",
    ]
    sizes = [1, 1, 2, 2, 2, 8, 1, 2]
    n = 0
    for b in range(fields // per_block):
        lines += [
            f"  - id: 'Model{b}'",
            f"    description: 'Block {b}'",
            "    fields:",
            "      - id: 'SF'",
            f"        expression: 'int16(hr:{address}; 0x8000)'",
            "        system: true",
        ]
        address += 1
        n += 1
        for i in range(per_block - 1):
            k = i % len(kinds)
            expr = kinds[k].format(a=address)
            if k in (0, 1):
                expr = f"{expr} * 10^SF"
            lines += [
                f"      - id: 'F{i}'",
                f"        description: 'Field {i} of block {b}'",
                f'        expression: "{expr}"',
                "        unit: 'W'",
            ]
            address += sizes[k]
            n += 1
    lines += [
        "tests:",
        "  - id: 'zeros'",
        "    input:",
        "      - firstAddress: 'hr:40000'",
        "        rawValues: " + " ".join(["0000"] * 40),
        "    blocks:",
        "      - id: 'Model0'",
        "        expected:",
        "          F0: [ 0 ]",
    ]
    assert n == fields
    return "\n".join(lines) + "\n"


def best_of(runs: int, func) -> float:
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        func()
        times.append(time.perf_counter() - start)
    return min(times)


def cli(*args) -> None:
    subprocess.run([sys.executable, "-m", "mdl", *map(str, args)], check=True, capture_output=True)


def main() -> int:
    from mdl.formats.toolkit.read import import_schema
    from mdl.targets import render

    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        schema = d / "sunspec_like.yaml"
        schema.write_text(sunspec_like())
        xml = d / "sunspec_like.xml"
        t_import = best_of(3, lambda: cli("import", schema, "-o", xml))
        t_gen = best_of(3, lambda: cli("gen", xml, "--lang", "all", "-o", d / "out"))
        device = import_schema(schema)
        t_inproc = best_of(3, lambda: [render(import_schema(schema), "x.xml", lang) for lang in ("python", "cpp")])
        files = sorted(REFERENCE.glob("*.yaml"))
        t_test = best_of(3, lambda: cli("test", *files))
        print(f"schema: {len(device.functions)} fields in {len(device.tests)} scenario(s)")
        print(f"mdl import (700 fields, CLI):            {t_import * 1000:8.1f} ms")
        print(f"mdl gen --lang all (700 fields, CLI):    {t_gen * 1000:8.1f} ms")
        print(f"import + render both, in-process:         {t_inproc * 1000:8.1f} ms")
        print(f"mdl test on {len(files)} reference files (59 scenarios): {t_test * 1000:8.1f} ms")
    return 0


if __name__ == "__main__":
    sys.exit(main())
