"""Time grows linearly with a cell (issue 34, finding 3): each pattern that was quadratic (a regex trying
a long run from each of its characters) goes through the real reading code, the CLI in process, at a
size N and at 2N. Linear code takes about twice as long at 2N (less, with the command's fixed cost);
quadratic code four times. The test asserts the ratio of the best of RUNS runs at each size stays
under GROWTH: no wall-clock limit, and N is chosen so the quadratic code took a second or so."""

from __future__ import annotations

import shutil
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from support.common import DATA, ROOT
from support.run import cli

GROWTH = 2.5  # linear: 2 at most (nearer 1: the command's fixed cost); quadratic: 3 to 4
RUNS = 5
ATTEMPTS = 2
# under this a run is the command's fixed cost and the machine's noise (a few ms either way), not the
# cell's: the quadratic code took a second at N and four at 2N, so the floor hides none of it
FLOOR = 0.1
HEADER = "Modbus Address,Parameter,Data Type,Units,Access\n30001,Phase 1 voltage,Float,V,R\n"
SEED = ROOT / "examples" / "wise_4012e" / "Modbus.ini"
METER_INI = (DATA / "meter.ini").read_text()


def _csv(tmp: Path, text: str) -> list[object]:
    (tmp / "t.csv").write_text(text)
    shutil.copy(DATA / "meter.ini", tmp / "t.ini")
    return ["csv2xml", tmp / "t.csv", "--ini", tmp / "t.ini", "-o", tmp / "out.xml"]


def header_cell(tmp: Path, n: int) -> list[object]:  # normalize_header's `\(.*?\)`
    return _csv(tmp, HEADER.replace("Access", "(" * n))


def address_cell(tmp: Path, n: int) -> list[object]:  # `\s*[,;/&\n]\s*` over a run of spaces
    return _csv(tmp, HEADER + "1" + " " * n + "x,Phase 2 voltage,Float,V,R\n")


def access_cell(tmp: Path, n: int) -> list[object]:  # parse_access's `\s*\(.*\)$`
    return _csv(tmp, HEADER + "30003,Phase 2 voltage,Float,V," + "(1" * (n // 2) + "\n")


def ini_key_line(tmp: Path, n: int) -> list[object]:  # configparser's `.*?\s*[=:]`
    args = _csv(tmp, HEADER)
    (tmp / "t.ini").write_text(METER_INI + "x" + " " * n + "y\n")
    return args


def ini_blank_lines(tmp: Path, n: int) -> list[object]:  # quoted keys' `^(\s*)"` from every blank line
    args = _csv(tmp, HEADER)
    (tmp / "t.ini").write_text(METER_INI + "\n" * n)
    return args


def wise_min(tmp: Path, n: int) -> list[object]:  # `[0-9]+\.?[0-9]*` splitting a run of digits every way
    path = tmp / "Modbus.ini"
    path.write_text(SEED.read_text().replace("AI1=1, Voltage1, 0, 5,", "AI1=1, Voltage1, " + "1" * n + "x, 5,"))
    return ["import", path, "-o", tmp / "out.xml"]


# (pattern, N): at N the quadratic code took about a second
PATTERNS: list[tuple[Callable[[Path, int], list[object]], int]] = [
    (header_cell, 10_000),
    (address_cell, 3_000),
    (access_cell, 24_000),
    (ini_key_line, 8_000),
    (ini_blank_lines, 8_000),
    (wise_min, 6_000),
]


def _run(args: list[object]) -> float:
    start = time.perf_counter()
    proc = cli(*args, timeout=120)
    took = time.perf_counter() - start
    assert "Traceback" not in proc.stderr, proc.stderr
    assert len(proc.stderr) < 20_000, "a message repeats the whole cell"
    return took


def _best_times(at_n: list[object], at_2n: list[object]) -> tuple[float, float]:
    """The best of RUNS runs at each size, taken in turns (a busy machine slows both alike)."""
    small = large = float("inf")
    for _ in range(RUNS):
        small = min(small, _run(at_n))
        large = min(large, _run(at_2n))
    return small, large


@pytest.mark.parametrize("pattern, n", PATTERNS, ids=[p.__name__ for p, _ in PATTERNS])
def test_time_grows_linearly_with_the_cell(tmp_path, pattern, n):
    small, large = tmp_path / "n", tmp_path / "2n"
    small.mkdir()
    large.mkdir()
    args = pattern(small, n), pattern(large, 2 * n)
    for _ in range(ATTEMPTS):  # a second look only where the first was disturbed: quadratic code fails both
        at_n, at_2n = _best_times(*args)
        if at_2n < max(GROWTH * at_n, FLOOR):
            return
    pytest.fail(f"{pattern.__name__}: {at_n:.3f} s at {n}, {at_2n:.3f} s at {2 * n}")
