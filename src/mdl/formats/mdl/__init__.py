"""MDL XML: secure parsing, XSD validation with positions, model <-> XML."""

from mdl.formats.mdl.load import load_device, validate_file
from mdl.formats.mdl.write import device_to_xml

__all__ = ["load_device", "validate_file", "device_to_xml"]
