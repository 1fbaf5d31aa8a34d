"""Where a description comes from: MDL XML (`mdlxml/`), a vendor's register table (`csvmap/`, mdl csv2xml),
and any description a command accepts, MDL or a format of mdl.formats (`loading.py`)."""
