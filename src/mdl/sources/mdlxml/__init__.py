"""MDL XML: secure parsing, XSD validation with positions, model <-> XML."""

from mdl.sources.mdlxml.load import load_device, validate_file
from mdl.sources.mdlxml.write import device_to_xml

__all__ = ["load_device", "validate_file", "device_to_xml"]
