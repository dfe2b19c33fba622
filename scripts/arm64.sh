#!/usr/bin/env bash
# The C kernels built and tested for aarch64 (a 64-bit Raspberry Pi OS, a Pi 3/4/5 or Zero 2 W)
# on an x86 machine: an arm64 Debian 12 chroot run under qemu-user-static, as websockets
# builds its ARM wheels. The kernels are compiled there by setup.py with Debian's GCC (NEON
# code, -O3 as on a Pi) and the kernel tests run there against Debian's numpy and OpenCV.
#
#   bash scripts/arm64.sh            # build the chroot once (~10-15 min, ~1.5 GB), then test
#   SHLIGHT_ARM64_ROOT=/path ...     # where the chroot lives (default /var/cache/shlight/arm64)
#   SHLIGHT_REQUIRE_ARM64=1 ...      # a machine that cannot run it fails instead of skipping
#   SHLIGHT_ARM64_INSTALL=0 ...      # without the edge install's check (pip install . there)
#
# Where the machine cannot (not root, no binfmt_misc, no network for the first build) it
# says why and exits 0: the check is skipped, never silently passed. A kernel test that
# fails under emulation exits 1. .ci/run runs it after the test suite.
set -uo pipefail
cd "$(dirname "$0")/.."
ROOT=${SHLIGHT_ARM64_ROOT:-/var/cache/shlight/arm64}
SUITE=bookworm
PACKAGES=python3,python3-dev,python3-numpy,python3-opencv,python3-pytest,python3-hypothesis,python3-threadpoolctl,python3-setuptools,gcc,libc6-dev
TESTS=(tests/core/kernels/test_kernels.py tests/core/kernels/test_kernel_twins.py tests/core/kernels/test_equirect_kernel.py tests/core/kernels/test_lights_kernel.py)

skip() {
    echo "arm64: skipped: $*"
    [ "${SHLIGHT_REQUIRE_ARM64:-0}" = "1" ] && exit 1
    exit 0
}

# The edge install as README's "Edge device" section gives it (a 64-bit Pi OS): a venv that
# sees the system's packages, `pip install .` from PyPI's aarch64 wheels with the kernels
# compiled, then `shlight compute` on a bundled panorama, `shlight serve --help`, and the GL
# harness left out (`shlight[gl]`). Offline it says why and skips. 9.5 min wall (1.3 min of
# CPU) on 2 busy cores, the wheels then cached in the chroot; SHLIGHT_ARM64_INSTALL=0 leaves
# it out.
install_check() {
    local why="" cert=""
    # The host's CA bundle: a machine behind a TLS-inspecting proxy trusts its CA there only.
    for f in "${PIP_CERT:-}" /etc/ssl/certs/ca-certificates.crt; do
        [ -n "$f" ] && [ -f "$f" ] && { cp "$f" "$ROOT/tmp/host-ca.crt" && cert=/tmp/host-ca.crt; break; }
    done
    # A clean environment: the host's pip settings (its index, links, paths) mean nothing there.
    local run=(chroot "$ROOT" env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin HOME=/root LANG=C.UTF-8
               PIP_DISABLE_PIP_VERSION_CHECK=1 DEBIAN_FRONTEND=noninteractive
               ${cert:+PIP_CERT=$cert SSL_CERT_FILE=$cert REQUESTS_CA_BUNDLE=$cert})
    if ! "${run[@]}" python3 -c 'import ensurepip' 2>/dev/null; then
        "${run[@]}" sh -c 'apt-get update -q && apt-get install -y -q --no-install-recommends python3-venv' \
            >/dev/null 2>&1 || why="python3-venv cannot be installed in the chroot (apt-get failed: offline?)"
    fi
    [ -z "$why" ] && ! "${run[@]}" python3 -c "import urllib.request; urllib.request.urlopen('https://pypi.org/simple/pip/', timeout=30)" >/dev/null 2>&1 \
        && why="PyPI cannot be reached from the chroot (offline?)"
    if [ -n "$why" ]; then
        echo "arm64: install check skipped: $why"
        [ "${SHLIGHT_REQUIRE_ARM64:-0}" = "1" ] && return 1
        return 0
    fi
    local inst="$ROOT/tmp/shlight-install"
    rm -rf "$inst" && mkdir -p "$inst"
    git ls-files -z | tar --null -T - -cf - 2>/dev/null | tar -x -C "$inst"
    echo "arm64: the edge install: a venv, pip install . (PyPI's aarch64 wheels), shlight compute, serve --help"
    "${run[@]}" sh -c '
        set -e
        cd /tmp/shlight-install && rm -rf /tmp/shlight-venv
        python3 -m venv --system-site-packages /tmp/shlight-venv
        /tmp/shlight-venv/bin/pip install -q .
        cd /    # away from the copy: the installed package is the one imported
        /tmp/shlight-venv/bin/shlight compute /tmp/shlight-install/provider/data/hdri/bridge.exr > /tmp/shlight-compute.json
        /tmp/shlight-venv/bin/python -c "
import json, math
c = json.load(open(\"/tmp/shlight-compute.json\"))[\"coefficients\"]
flat = [v for row in c for v in (row if isinstance(row, list) else [row])]
assert len(flat) == 27 and all(map(math.isfinite, flat)), c
import provider.core.sh9.lens_fold as fold
assert fold.KERNEL, \"the C kernels were not built by pip install\"
print(\"arm64: shlight compute: 27 finite coefficients; the C kernels built by pip\")"
        /tmp/shlight-venv/bin/shlight serve --help | grep -q -- "--source"
        if /tmp/shlight-venv/bin/python -c "import moderngl" 2>/dev/null; then
            echo "arm64: the edge install pulled in moderngl (the gl extra)"; exit 1; fi
        /tmp/shlight-venv/bin/shlight validate-shaders --no-pictures > /tmp/shlight-gl.txt 2>&1 && exit 1
        grep -q "shlight\[gl\]" /tmp/shlight-gl.txt && ! grep -q Traceback /tmp/shlight-gl.txt
        ' || { echo "arm64: the edge install FAILED on aarch64"; return 1; }
    echo "arm64: the edge install works on aarch64 (no GL harness: shlight[gl] named when asked)"
}

[ "$(uname -m)" = "aarch64" ] && skip "this machine is aarch64 itself: bash scripts/test.sh tests its kernels natively"
[ "$(id -u)" = "0" ] || skip "needs root (a chroot, binfmt_misc); as root: bash scripts/arm64.sh"

# qemu-user-static registers aarch64 binaries with the kernel's binfmt_misc: mounted here if
# the container allows it.
if [ ! -e /proc/sys/fs/binfmt_misc/register ]; then
    mount -t binfmt_misc binfmt_misc /proc/sys/fs/binfmt_misc 2>/dev/null \
        || skip "binfmt_misc cannot be mounted (a container without that privilege)"
fi
missing=()
command -v qemu-aarch64-static >/dev/null || missing+=(qemu-user-static)
command -v debootstrap >/dev/null || missing+=(debootstrap)
command -v update-binfmts >/dev/null || missing+=(binfmt-support)
if [ ${#missing[@]} -gt 0 ]; then
    DEBIAN_FRONTEND=noninteractive apt-get install -y -q "${missing[@]}" >/dev/null 2>&1 \
        || skip "cannot install ${missing[*]} (apt-get failed: offline?)"
fi
[ -e /proc/sys/fs/binfmt_misc/qemu-aarch64 ] || update-binfmts --enable qemu-aarch64 >/dev/null 2>&1 \
    || skip "qemu-aarch64 is not registered with binfmt_misc"

if [ ! -x "$ROOT/usr/bin/python3" ]; then
    echo "arm64: building the chroot in $ROOT (Debian $SUITE arm64; once, ~10-15 min)"
    rm -rf "$ROOT.part" && mkdir -p "$(dirname "$ROOT")"
    debootstrap --arch=arm64 --variant=minbase --include="$PACKAGES" "$SUITE" "$ROOT.part" \
        http://deb.debian.org/debian > "$(dirname "$ROOT")/arm64-debootstrap.log" 2>&1 \
        || { rm -rf "$ROOT.part"; skip "debootstrap failed (offline? see $(dirname "$ROOT")/arm64-debootstrap.log)"; }
    mv "$ROOT.part" "$ROOT"
fi

# The repository's tracked files (and what is staged or edited in them) copied in afresh; its
# pyproject.toml left out: Debian 12's setuptools reads setup.py's kernels without it.
WORK="$ROOT/tmp/shlight"
rm -rf "$WORK" && mkdir -p "$WORK"
git ls-files -z | tar --null -T - -cf - 2>/dev/null | tar -x -C "$WORK"
rm -f "$WORK/pyproject.toml"
echo "arm64: building the kernels (aarch64 GCC, NEON) and running ${TESTS[*]} under qemu"
chroot "$ROOT" sh -c "cd /tmp/shlight && SHLIGHT_BUILD_KERNELS=yes python3 setup.py -q build_ext --inplace" \
    || { echo "arm64: the kernels did not build for aarch64"; exit 1; }
# An emulated CPU is 10-50x slower: the tests' waits get that much more patience.
chroot "$ROOT" env SHLIGHT_TEST_PATIENCE=40 PYTHONDONTWRITEBYTECODE=1 sh -c \
    "cd /tmp/shlight && python3 -c 'import platform; print(\"arm64:\", platform.machine(), platform.python_version())' && python3 -m pytest -q -p no:cacheprovider ${TESTS[*]}"
status=$?
[ $status -eq 0 ] && echo "arm64: the kernels' tests pass on aarch64" || echo "arm64: FAILED on aarch64"
[ "${SHLIGHT_ARM64_INSTALL:-1}" = "0" ] && exit $status
install_check || status=1
exit $status
