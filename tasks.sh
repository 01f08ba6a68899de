#!/usr/bin/env bash
# One entry point for the README's commands (plays the role of a Makefile, which
# a fresh Debian machine does not have):
#   bash tasks.sh demo   set up, then run the main job on a shipped example
#   bash tasks.sh test   set up, then run the test suite
#   bash tasks.sh setup  only set up (.venv with armcal and its dependencies)
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
    # WeasyPrint needs Pango (with HarfBuzz and fontconfig) and at least one font.
    local missing=()
    for lib in pango-1.0 pangoft2-1.0 harfbuzz; do
        "$PY" -c "import ctypes.util,sys; sys.exit(ctypes.util.find_library('$lib') is None)" \
            || missing+=("$lib")
    done
    if [ ${#missing[@]} -gt 0 ] || ! fc-list 2>/dev/null | grep -q .; then
        echo "installing system libraries for WeasyPrint (missing: ${missing[*]:-fonts})"
        apt_install libpango-1.0-0 libpangoft2-1.0-0 libharfbuzz0b libharfbuzz-subset0 \
            fontconfig fonts-dejavu-core
    fi
}

venv() {
    if [ ! -x "$VENV/bin/python" ]; then
        "$PY" -m venv "$VENV" 2>/dev/null || { apt_install python3-venv; rm -rf "$VENV"; "$PY" -m venv "$VENV"; }
    fi
    local stamp="$VENV/.armcal-installed"
    if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ]; then
        "$VENV/bin/python" -m pip install -q --upgrade pip
        "$VENV/bin/python" -m pip install -q -e ".[test]"
        touch "$stamp"
    fi
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
    demo) demo ;;
    test) shift; tests "$@" ;;
    *) echo "usage: bash tasks.sh {demo|test|setup}" >&2; exit 2 ;;
esac
