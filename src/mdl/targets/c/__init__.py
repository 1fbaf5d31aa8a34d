"""The C99 target: <stem>.h / <stem>.c on libmodbus (SPEC section 5, docs/c-api.md)."""
