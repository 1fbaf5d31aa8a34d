"""What the tests share that is not a fixture: paths and small builders (common), running `mdl` (run),
serving and wiring devices (devices), the tiers (tiers), and the harnesses and servers the test
folders use (c_harness, cpp_harness, engines, hostile_server, ...). The fixtures are in tests/conftest.py."""
