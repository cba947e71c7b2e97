#!/usr/bin/env bash
# Installs the Python package (python/) into a virtual environment, VENV
# (default .venv), making it first: with python3-venv installed where Debian's
# python3 lacks it (root or sudo). Extra arguments are more packages for pip
# (CI adds pytest). Run from anywhere; needs Rust, as `scripts/setup.sh` checks.
set -euo pipefail
cd "$(dirname "$0")/.."
venv="${1:-.venv}"
shift || true

# Debian splits venv and ensurepip out of python3.
if ! command -v python3 >/dev/null || ! python3 -c "import ensurepip, venv" 2>/dev/null; then
    if [ "$(id -u)" -eq 0 ]; then
        sudo=()
    elif command -v sudo >/dev/null; then
        sudo=(sudo)
    else
        echo "setup-python: python3 with venv is missing, and neither root nor sudo to" >&2
        echo "              install it: apt-get install python3 python3-venv" >&2
        exit 1
    fi
    echo "setup-python: installing python3 and python3-venv"
    "${sudo[@]}" apt-get update -qq
    DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get install -y -qq --no-install-recommends \
        python3 python3-venv >/dev/null
fi

[ -x "$venv/bin/pip" ] || python3 -m venv "$venv"
# pip builds the wheel with maturin (from PyPI, per python/pyproject.toml) and cargo.
"$venv/bin/pip" install --quiet --upgrade pip
"$venv/bin/pip" install --quiet ./python "$@"
echo "setup-python: installed pathmix into $venv (activate: . $venv/bin/activate)"
