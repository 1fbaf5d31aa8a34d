"""SunSpec (`--from sunspec`, SPEC 12), read only: `models.py` loads and checks a model definition (an id
pysunspec2 ships, or a JSON file), `build.py` turns a chain of them into the document model, `read.py` is
what `mdl import` calls. docs/sunspec.md describes the mapping."""
