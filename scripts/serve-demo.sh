#!/usr/bin/env bash
# One command on a fresh machine: install shlight into .venv and serve the built-in demo
# source on ws://127.0.0.1:8765 (dashboard at http://127.0.0.1:8765/). Extra arguments go
# to `shlight serve`.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
exec .venv/bin/shlight serve "$@"
