#!/usr/bin/env bash
# The whole test suite: the Rust tests (`cargo test`, no Python involved) and the
# Python tests (pytest, tests/python). Exits non-zero on any failure. Extra arguments
# go to pytest.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

scripts/setup.sh  # with every extra: the suite tests each optional path
echo "== cargo test"
cargo test
echo "== pytest"
.venv/bin/python -m pytest tests/python "$@"
