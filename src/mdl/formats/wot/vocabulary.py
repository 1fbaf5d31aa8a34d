"""The words of a Thing Description with Modbus forms, as the W3C (TD 1.1, the Modbus binding's `modv:`
vocabulary) and node-wot 0.8's Modbus binding and octet-stream codec use them, and the `mdl:` terms that
say what the binding cannot (docs/wot.md). The writer (mdl.exports.wot) and the reader (read.py) share
them, so that what one writes the other reads back."""

from __future__ import annotations

# TD 1.0's context first, then TD 1.1's: both JSON schemas (W3C's TD 1.1 and node-wot's 2021 copy) take it
TD_V1 = "https://www.w3.org/2019/wot/td/v1"
TD_V11 = "https://www.w3.org/2022/wot/td/v1.1"
MODV = "https://www.w3.org/2019/wot/modbus#"
XSD = "http://www.w3.org/2001/XMLSchema#"
MDL = "http://www.ornl.gov/ModbusXMLSchema#"  # the MDL namespace: the terms of docs/wot.md
CONTEXT = [TD_V1, TD_V11, {"modv": MODV, "xsd": XSD, "mdl": MDL}]

SCHEME = "modbus+tcp"
THING_MODEL = "tm:ThingModel"
OCTETS = "application/octet-stream"
TM_LINK_TYPE = "application/tm+json"

# MDL's register types <-> the binding's entities
ENTITIES = {"coil": "Coil", "discrete": "DiscreteInput", "holding": "HoldingRegister", "input": "InputRegister"}
TABLES = {entity: table for table, entity in ENTITIES.items()}
# modv:function (names and codes) -> the table it reads or writes, for TDs that say the function
FUNCTION_TABLES = {
    "readCoil": "coil",
    "writeSingleCoil": "coil",
    "writeMultipleCoils": "coil",
    "readDiscreteInput": "discrete",
    "readHoldingRegisters": "holding",
    "writeSingleHoldingRegister": "holding",
    "writeMultipleHoldingRegisters": "holding",
    "readInputRegister": "input",
    "readInputRegisters": "input",
    1: "coil",
    5: "coil",
    15: "coil",
    2: "discrete",
    3: "holding",
    6: "holding",
    16: "holding",
    4: "input",
}

# node-wot's byteSeq (the content type's parameter) <-> MDL's (byte order, word order): the codec swaps the
# bytes of each register for *_BYTE_SWAP, then reads the whole buffer little-endian for LITTLE_ENDIAN*
BYTE_SEQ = {
    ("big", "big"): "BIG_ENDIAN",
    ("little", "little"): "LITTLE_ENDIAN",
    ("little", "big"): "BIG_ENDIAN_BYTE_SWAP",
    ("big", "little"): "LITTLE_ENDIAN_BYTE_SWAP",
}
ORDERS = {seq: orders for orders, seq in BYTE_SEQ.items()}

# the binding's payload types (modv:type) of MDL's values
XSD_INTEGERS = {
    (8, True): "xsd:byte",
    (8, False): "xsd:unsignedByte",
    (16, True): "xsd:short",
    (16, False): "xsd:unsignedShort",
    (32, True): "xsd:int",
    (32, False): "xsd:unsignedInt",
    (64, True): "xsd:long",
    (64, False): "xsd:unsignedLong",
}
XSD_FLOATS = {32: "xsd:float", 64: "xsd:double"}

# node-wot's octet-stream codec: the bits of the payload a value is (the first bit the most significant of
# the first byte), where it is not the whole payload
BIT_OFFSET = "ex:bitOffset"
BIT_LENGTH = "ex:bitLength"
SAFE_BITS = 48  # node-wot reads integers of up to 6 bytes (Buffer.readIntBE); wider ones fail
SAFE_WRITE_BITS = 32  # and writes integers of up to 4 (wider: byte by byte with Buffer.writeInt8, which fails)

# the mdl: terms (a property's): what makes the description's value of the raw one the binding reads
MULTIPLIER = "mdl:multiplier"
OFFSET = "mdl:offset"
BITS = "mdl:bits"
SCALE_EXPONENT = "mdl:scaleExponent"
SCALE_BY = "mdl:scaleBy"
NOT_IMPLEMENTED = "mdl:notImplemented"
MDL_TERMS = (BITS, MULTIPLIER, OFFSET, SCALE_EXPONENT, SCALE_BY, NOT_IMPLEMENTED)

# the Thing Model's placeholders (W3C TD 1.1, section 10: `{{NAME}}`), filled when a TD is made of it
PLACEHOLDERS = ("HOST", "PORT", "UNIT_ID", "POLLING_TIME", "TIMEOUT")


def placeholder(name: str) -> str:
    return "{{" + name + "}}"
