#!/usr/bin/env bash
# One command on a fresh machine: install what the tests need and run them.
#   system packages (Debian): Mesa EGL for headless OpenGL, Chromium for the dashboard,
#   Mono for the C# client, glslang + spirv-cross for the HLSL, Xvfb for the viewer,
#   mosquitto for the MQTT tests, npm (when missing) for three.js, a C compiler (when
#   missing) for the provider's C kernels (built as required: SHLIGHT_BUILD_KERNELS=yes);
#   Python: shlight[test] into .venv; npm: three.js into tests/node (pinned by its
#   package-lock.json) for the export tests (three's own SphericalHarmonics3 and
#   XREstimatedLight in node) and the browser client tests (three.js in headless Chromium).
# As root, missing system packages are installed with apt-get; otherwise the script says
# which to install (the tests that need them are then skipped with that reason).
set -euo pipefail
cd "$(dirname "$0")/.."
PKGS="libegl1 libegl-mesa0 libgl1-mesa-dri chromium mono-mcs glslang-tools spirv-cross xvfb mosquitto"
missing=()
for p in $PKGS; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
command -v npm >/dev/null || missing+=(npm)
command -v cc >/dev/null || missing+=(gcc)
# The kernels compile against Python's headers: Debian's own python3 keeps them apart.
py_include=$(${PYTHON:-python3} -c 'import sysconfig; print(sysconfig.get_paths()["include"])')
[ -f "$py_include/Python.h" ] || missing+=(python3-dev)
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
# The C kernels required (as websockets' CI sets BUILD_EXTENSION=yes): one that does not
# compile fails the install here instead of leaving the tests on its Python twin.
SHLIGHT_BUILD_KERNELS=yes bash scripts/setup.sh test
if [ ! -d tests/node/node_modules/three ] || [ ! -d tests/node/node_modules/ktx-parse ]; then
    if command -v npm >/dev/null; then
        npm ci --prefix tests/node --no-audit --no-fund --loglevel=error >/dev/null \
            || echo "WARNING: npm ci --prefix tests/node failed: the three.js tests will be skipped"
    else
        echo "WARNING: npm missing (apt-get install npm): the three.js tests will be skipped"
    fi
fi
# pytest-xdist: one worker a core and one more, since many tests wait on servers, browsers and
# Mono processes of their own (2 quiet cores: 10 min 33 s with two workers, 9 min 41 s with
# three, 2026-11-29); -n N after the script's name for another count, -n 0 for one process.
# Each test goes to the worker that is free ("worksteal": the tests' lengths differ a
# thousandfold). The benches (pytest -m bench) are not in it.
workers=$(( $(nproc 2>/dev/null || echo 1) + 1 ))
exec .venv/bin/python -m pytest -n "$workers" --dist worksteal "$@"
