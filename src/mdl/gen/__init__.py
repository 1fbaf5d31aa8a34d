"""`mdl gen`: drivers from an MDL document, written only when their content changes."""

from __future__ import annotations

from pathlib import Path

from mdl.gen import python as pygen
from mdl.gen.render import environment, require_dir, write_outputs
from mdl.model import Device
from mdl.names import stem as file_stem

LANGS = ("python", "cpp", "all")


def render(device: Device, source_name: str, lang: str) -> dict[str, str]:
    """File name -> content for the chosen language(s)."""
    stem = file_stem(device.name)
    env = environment()
    out: dict[str, str] = {}
    if lang in ("python", "all"):
        out[f"{stem}.py"] = env.get_template("python/device.py.j2").render(**pygen.context(device, source_name))
    if lang in ("cpp", "all"):
        from mdl.gen import cpp as cppgen

        ctx = cppgen.context(device, source_name)
        out[f"{stem}.h"] = env.get_template("cpp/device.h.j2").render(**ctx)
        out[f"{stem}.cc"] = env.get_template("cpp/device.cc.j2").render(**ctx)
    return out


def generate(device: Device, source: Path, lang: str, outdir: Path, check: bool) -> list[Path]:
    require_dir(outdir)
    files = render(device, source.name, lang)
    return write_outputs({outdir / name: text for name, text in files.items()}, check)
