#!/usr/bin/env bash
# Create .venv (if needed) and install shlight with the given extras, e.g. `scripts/setup.sh test`.
# The install is editable (code changes need no reinstall), so it is skipped when
# pyproject.toml and the extras are those of the last install: a second run takes a moment.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
extras=${1:-}

if [ ! -x .venv/bin/python ]; then
    # Debian and Ubuntu ship venv's pip bootstrap (ensurepip) as a separate package.
    if ! "$PY" -c 'import ensurepip, venv' 2>/dev/null; then
        ver=$("$PY" -c 'import sys; print("%d.%d" % sys.version_info[:2])')
        if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
            echo "installing python3-venv (Python's venv needs it on Debian/Ubuntu)"
            export DEBIAN_FRONTEND=noninteractive
            apt-get update -qq
            apt-get install -y -qq --no-install-recommends "python$ver-venv" >/dev/null 2>&1 ||
                apt-get install -y -qq --no-install-recommends python3-venv >/dev/null
        else
            echo "error: $PY cannot create a virtual environment (no ensurepip)." >&2
            echo "       On Debian/Ubuntu: sudo apt-get install python3-venv  (or python$ver-venv)" >&2
            exit 1
        fi
    fi
    "$PY" -m venv .venv
    .venv/bin/python -m pip install -q --upgrade pip >/dev/null
fi

stamp=.venv/.shlight-install
# The stamp covers what the install builds: pyproject.toml, setup.py and the C kernels.
want="$(.venv/bin/python -c 'import glob, hashlib
h = hashlib.sha256()
kernels = glob.glob("provider/**/*.[ch]", recursive=True)   # the sources and their header
for name in ["pyproject.toml", "setup.py"] + sorted(kernels):
    h.update(open(name, "rb").read())
print(h.hexdigest())') ${extras}"
have=$(cat "$stamp" 2>/dev/null || true)
# An install with extras also serves a plain request (serve-demo.sh after test.sh).
# The C kernels are optional in pip's build (no compiler: it still installs without them), so
# the stamp also says whether a compiler and Python's headers were there: installing them
# since is a reason to install again.
toolchain="cc:$(command -v cc >/dev/null && echo yes || echo no)"
toolchain="$toolchain,headers:$(.venv/bin/python -c 'import os, sysconfig
print("yes" if os.path.exists(os.path.join(sysconfig.get_paths()["include"], "Python.h")) else "no")')"
# SHLIGHT_BUILD_KERNELS (yes: required, no: skipped; setup.py) changes what is built.
toolchain="$toolchain,kernels:${SHLIGHT_BUILD_KERNELS:-optional}"
want="${want%% *} $toolchain ${extras}"
if [ -x .venv/bin/shlight ] && { [ "$have" = "$want" ] || [ "${have% *} " = "$want" ]; } &&
        .venv/bin/python -c 'import provider' 2>/dev/null; then
    exit 0
fi
spec="."
[ -n "$extras" ] && spec=".[${extras}]"
echo "installing shlight${extras:+[$extras]} into .venv"
# setuptools prints an informational block on every editable install; it is not a problem.
PYTHONWARNINGS="ignore:Editable installation" .venv/bin/python -m pip install -q -e "$spec"
echo "$want" > "$stamp"
