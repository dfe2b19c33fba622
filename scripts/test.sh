#!/usr/bin/env bash
# One command on a fresh machine: install what the tests need and run them.
#   system packages (Debian): Mesa EGL for headless OpenGL, Chromium for the dashboard,
#   Mono for the C# client, glslang + spirv-cross for the HLSL, Xvfb for the viewer;
#   Python: shlight[test] into .venv; three.js (npm ci --prefix tests/node) for the export tests.
# As root, missing system packages are installed with apt-get; otherwise the script says
# which to install (the tests that need them are then skipped with that reason).
set -euo pipefail
cd "$(dirname "$0")/.."
PKGS="libegl1 libegl-mesa0 libgl1-mesa-dri chromium mono-mcs glslang-tools spirv-cross xvfb"
missing=()
for p in $PKGS; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
        echo "installing system packages: ${missing[*]}"
        export DEBIAN_FRONTEND=noninteractive
        apt-get update -qq && apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
    else
        echo "WARNING: missing system packages: ${missing[*]}"
        echo "         install them with: sudo apt-get install ${missing[*]}"
    fi
fi
bash scripts/setup.sh test
# three.js (pinned in tests/node/package-lock.json) for the export tests, which run three's own
# SphericalHarmonics3 and XREstimatedLight in node; without node/npm those tests are skipped.
if [ ! -d tests/node/node_modules/three ]; then
    if ! command -v npm >/dev/null && [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
        echo "installing node and npm for the three.js tests"
        export DEBIAN_FRONTEND=noninteractive
        apt-get update -qq && apt-get install -y -qq --no-install-recommends nodejs npm >/dev/null \
            || echo "WARNING: could not install nodejs npm"
    fi
    if command -v npm >/dev/null; then
        npm ci --prefix tests/node --no-audit --no-fund --loglevel=error >/dev/null \
            || echo "WARNING: npm ci --prefix tests/node failed: the three.js tests will be skipped"
    else
        echo "WARNING: node/npm missing (apt-get install nodejs npm): the three.js tests will be skipped"
    fi
fi
exec .venv/bin/python -m pytest "$@"
