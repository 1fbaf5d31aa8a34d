"""Our 0.9b XSD accepts and rejects exactly what ORNL's original XSD does; 1.0 accepts all of 0.9b."""

from __future__ import annotations

import pytest
from lxml import etree

from support.common import MDL_NS, ORNL, ROOT
from support.run import run_mdl

F = "<name>f</name><description>d</description>"


def doc(functions: str = "", head: str = "<name>D</name><description>x</description>", ns: bool = True, root="device"):
    xmlns = f' xmlns="{MDL_NS}"' if ns else ""
    return f'<?xml version="1.0"?><{root}{xmlns}>{head}{functions}</{root}>'


def fn(body: str) -> str:
    return f"<function>{body}</function>"


CORPUS = {
    "empty_device": doc(),
    "minimal_function": doc(fn(F + "<addresses>1</addresses>")),
    "all_fields": doc(
        fn(
            F + "<addresses>1 2</addresses><length>Lower byte</length><count>2</count>"
            "<format>UINT8</format><block_label>A</block_label><multiplier>0.5</multiplier>"
            "<units>C</units><read_function_code>arg = r1;</read_function_code>"
            "<write_function_code>r1 = arg;</write_function_code>"
        )
    ),
    "wrong_order": doc(fn(F + "<addresses>1</addresses><count>1</count><length>Full word</length>")),
    "missing_function_description": doc(fn("<name>f</name><addresses>1</addresses>")),
    "missing_device_description": doc(head="<name>D</name>"),
    "count_zero": doc(fn(F + "<addresses>1</addresses><count>0</count>")),
    "count_negative": doc(fn(F + "<addresses>1</addresses><count>-1</count>")),
    "count_decimal": doc(fn(F + "<addresses>1</addresses><count>2.0</count>")),
    "unknown_format": doc(fn(F + "<addresses>1</addresses><format>INT15</format>")),
    "lowercase_format": doc(fn(F + "<addresses>1</addresses><format>int16</format>")),
    "no_namespace": doc(fn(F + "<addresses>1</addresses>"), ns=False),
    "address_range_text": doc(fn(F + "<addresses>0 to 3</addresses>")),
    "address_list": doc(fn(F + "<addresses>1 2 3</addresses>")),
    "address_empty": doc(fn(F + "<addresses></addresses>")),
    "address_negative": doc(fn(F + "<addresses>-1</addresses>")),
    "address_padded": doc(fn(F + "<addresses>  5  </addresses>")),
    "two_block_labels": doc(fn(F + "<addresses>1</addresses><block_label>A</block_label><block_label>B</block_label>")),
    "multiplier_text": doc(fn(F + "<addresses>1</addresses><multiplier>0.1(?)</multiplier>")),
    "multiplier_exponent": doc(fn(F + "<addresses>1</addresses><multiplier>1e-3</multiplier>")),
    "multiplier_inf": doc(fn(F + "<addresses>1</addresses><multiplier>INF</multiplier>")),
    "length_low_byte": doc(fn(F + "<addresses>1</addresses><length>Low byte</length>")),
    "unknown_element": doc(fn(F + "<addresses>1</addresses><colour>red</colour>")),
    "two_names": doc(fn("<name>f</name>" + F + "<addresses>1</addresses>")),
    "extension_in_09b": doc(fn(F + "<addresses>1</addresses><register_type>input</register_type>")),
    "wrong_root": doc(root="devices"),
    "empty_units_and_name": doc(fn("<name></name><description>d</description><addresses>1</addresses><units></units>")),
    "function_before_description": doc(
        fn(F + "<addresses>1</addresses>"),
        head="<name>D</name>" + fn(F + "<addresses>1</addresses>") + "<description>x</description>",
    ),
    "version_attribute": doc().replace("<device ", '<device version="1.0" '),
}


# valid to both XSDs, refused by the checks an XSD cannot make
SEMANTICALLY_INVALID = {
    "address_empty": "no address",
    # xs:float admits INF; no driver can scale by it (issue 9: non-finite numbers refused)
    "multiplier_inf": "<multiplier> INF is not a finite number",
}


def _schema(path):
    return etree.XMLSchema(etree.parse(str(path)))


OUR_09B = _schema(ROOT / "schema" / "mdl-0.9b.xsd")
OUR_10 = _schema(ROOT / "schema" / "mdl-1.0.xsd")


@pytest.fixture(scope="module")
def ornl_xsd():
    return _schema(ORNL / "mdl.xsd")


@pytest.mark.conformance("ornl")
def test_corpus_is_large_and_mixed(ornl_xsd):
    verdicts = [ornl_xsd.validate(etree.fromstring(d.encode())) for d in CORPUS.values()]
    assert len(CORPUS) >= 20
    assert 5 <= sum(verdicts) <= len(verdicts) - 5


@pytest.mark.conformance("ornl")
@pytest.mark.parametrize("name", sorted(CORPUS))
def test_09b_schema_agrees_with_ornl(name, ornl_xsd):
    tree = etree.fromstring(CORPUS[name].encode())
    assert OUR_09B.validate(tree) == ornl_xsd.validate(tree), name


@pytest.mark.parametrize("name", sorted(CORPUS))
def test_every_09b_document_is_valid_10(name):
    tree = etree.fromstring(CORPUS[name].encode())
    if OUR_09B.validate(tree):
        assert OUR_10.validate(tree), (name, OUR_10.error_log)


@pytest.mark.conformance("ornl")
def test_cli_verdicts_match_ornl(tmp_path, ornl_xsd):
    files = {}
    for name, text in CORPUS.items():
        path = tmp_path / f"{name}.xml"
        path.write_text(text)
        files[name] = path
    for name, path in files.items():
        proc = run_mdl("validate", "--schema", "0.9b", path)
        ornl_ok = ornl_xsd.validate(etree.fromstring(CORPUS[name].encode()))
        assert "Traceback" not in proc.stderr
        if name in SEMANTICALLY_INVALID:
            assert ornl_ok and proc.returncode == 1 and SEMANTICALLY_INVALID[name] in proc.stderr
            continue
        assert (proc.returncode == 0) == ornl_ok, (name, proc.stdout, proc.stderr)
        if ornl_ok:
            assert proc.stdout.strip() == f"{path}: valid MDL 0.9b"
        else:
            assert f"{path}:" in proc.stderr and "error:" in proc.stderr


def test_cli_names_extensions_of_10(tmp_path):
    path = tmp_path / "ext.xml"
    path.write_text(CORPUS["extension_in_09b"])
    proc = run_mdl("validate", path)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == f"{path}: valid MDL 1.0 (extensions: register_type)"
    proc = run_mdl("validate", "--schema", "0.9b", path)
    assert proc.returncode == 1
    assert "register_type" in proc.stderr


def test_no_namespace_error_says_what_to_add(tmp_path):
    path = tmp_path / "nons.xml"
    path.write_text(CORPUS["no_namespace"])
    proc = run_mdl("validate", path)
    assert proc.returncode == 1
    assert MDL_NS in proc.stderr and f"{path}:1:" in proc.stderr
