#!/usr/bin/env bash
# One entry point for the README's commands (plays the role of a Makefile, which
# a fresh Debian machine does not have):
#   bash tasks.sh demo   set up, then run the main job on a shipped example
#   bash tasks.sh test   set up, then run the test suite
#   bash tasks.sh setup  only set up (.venv with armcal and its dependencies)
#   bash tasks.sh lock   write requirements.lock anew from pyproject.toml's ranges (docs/development.md)
set -euo pipefail
cd "$(dirname "$0")"
VENV=.venv
PY=${PYTHON:-python3}

as_root() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo "$@"; fi; }

apt_install() {
    as_root apt-get update -qq
    DEBIAN_FRONTEND=noninteractive as_root apt-get install -y -qq --no-install-recommends "$@" >/dev/null
}

system_deps() {
    # WeasyPrint needs Pango (with HarfBuzz, its subsetter and fontconfig) and at least one font:
    # each library that is missing is installed from its own Debian package.
    local packages=() library
    for library in pango-1.0:libpango-1.0-0 pangoft2-1.0:libpangoft2-1.0-0 harfbuzz:libharfbuzz0b \
                   harfbuzz-subset:libharfbuzz-subset0 fontconfig:libfontconfig1; do
        "$PY" -c "import ctypes.util,sys; sys.exit(ctypes.util.find_library('${library%%:*}') is None)" \
            || packages+=("${library#*:}")
    done
    [ "$(fc-list 2>/dev/null | wc -l)" -gt 0 ] || packages+=(fontconfig fonts-dejavu-core)
    if [ ${#packages[@]} -gt 0 ]; then
        echo "installing system libraries for WeasyPrint: ${packages[*]}"
        apt_install "${packages[@]}"
    fi
}

venv() {
    if [ ! -x "$VENV/bin/python" ]; then
        "$PY" -m venv "$VENV" 2>/dev/null || { apt_install python3-venv; rm -rf "$VENV"; "$PY" -m venv "$VENV"; }
    fi
    local stamp="$VENV/.armcal-installed"
    if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ] || [ requirements.lock -nt "$stamp" ]; then
        # the locked versions (pip and setuptools included), then armcal itself built with that setuptools
        "$VENV/bin/python" -m pip install -q -r requirements.lock
        "$VENV/bin/python" -m pip install -q --no-deps --no-build-isolation -e .
        touch "$stamp"
    fi
}

lock() {
    # every dependency's newest version within pyproject.toml's ranges, transitive ones included
    local scratch
    scratch=$(mktemp -d)
    "$PY" -m venv "$scratch/venv"
    "$scratch/venv/bin/python" -m pip install -q --upgrade pip setuptools
    "$scratch/venv/bin/python" -m pip install -q ".[test]"
    {
        echo "# Exact versions that tasks.sh installs (pip and setuptools included), written by 'bash tasks.sh lock'"
        echo "# on $(date -u +%Y-%m-%d) with $("$scratch/venv/bin/python" --version) on $(uname -m); see docs/development.md."
        "$scratch/venv/bin/python" tools/write_lock.py
    } > "$scratch/requirements.lock"
    mv "$scratch/requirements.lock" requirements.lock  # whole or not at all
    rm -rf "$scratch"
}

setup() { system_deps; venv; }

demo() {
    setup
    local spec=examples/goswami_ballbar/spec.yaml
    "$VENV/bin/armcal" validate "$spec"
    "$VENV/bin/armcal" run "$spec" --force
}

tests() {
    setup
    "$VENV/bin/python" -m pytest -q "$@"
}

case "${1:-}" in
    setup) setup ;;
    lock) lock ;;
    demo) demo ;;
    test) shift; tests "$@" ;;
    *) echo "usage: bash tasks.sh {demo|test|setup|lock}" >&2; exit 2 ;;
esac
