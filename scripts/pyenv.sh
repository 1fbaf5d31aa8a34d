# shellcheck shell=bash
# Sourced by scripts/demo and scripts/test: choose the Python to install mdl into.
# Inside a virtual environment, that one; otherwise a `.venv` in the checkout, created on first use,
# because distributions' Pythons refuse `pip install` outside one (PEP 668). Sets PY and puts its
# bin folder (where `mdl` lands) first on PATH.

in_venv() {
    python3 -c 'import sys; sys.exit(0 if sys.prefix != sys.base_prefix else 1)'
}

if in_venv; then
    PY=$(python3 -c 'import sys; print(sys.executable)')
else
    if [ ! -x .venv/bin/python ]; then
        echo "creating .venv (not inside a virtual environment)"
        if ! python3 -m venv .venv 2>/dev/null; then
            rm -rf .venv
            if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
                echo "installing python3-venv"
                apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-venv >/dev/null
                python3 -m venv .venv
            else
                echo "error: python3 cannot create a virtual environment; install your distribution's venv package" \
                     "(Debian/Ubuntu: apt-get install python3-venv) or activate a virtual environment first" >&2
                exit 1
            fi
        fi
    fi
    PY=$PWD/.venv/bin/python
fi
PATH="$(dirname "$PY"):$PATH"
export PATH
