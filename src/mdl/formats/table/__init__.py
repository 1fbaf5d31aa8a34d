"""`mdl csv2xml`: vendor register tables (CSV) + device INI -> MDL."""
