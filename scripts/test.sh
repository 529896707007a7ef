#!/usr/bin/env bash
# The whole test suite: lint and types (ruff, mypy), the Rust tests (`cargo test`, no
# Python involved) and the Python tests (pytest, tests/python). Exits non-zero on any
# failure. Extra arguments go to pytest.
#
# The Rust tests are built and run in the background from the start, beside set-up's
# downloads and pytest (which runs on one core); their output goes to
# target/cargo-test.log and is printed when both are done. `cargo test` alone runs the
# same tests (and builds the examples too).
#
# A run that passed leaves a fingerprint of its inputs (every file of the checkout that
# git does not ignore, the set-up's stamp and the arguments) in target/tests-passed; run
# again on the same inputs, the command says so and stops at once. FORCE=1 runs
# everything anyway.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

mkdir -p target
fingerprint() {
    { git ls-files -z --cached --others --exclude-standard | xargs -0 sha256sum 2>/dev/null
      cat .venv/.chaincart-setup 2>/dev/null || true
      printf '%s\n' "$@"; } | sha256sum | cut -d' ' -f1
}
passed=target/tests-passed
if [ "${FORCE:-0}" != 1 ] && [ -f "$passed" ] && [ -f .venv/.chaincart-setup ] &&
    [ "$(head -1 "$passed")" = "$(fingerprint "$@")" ]; then
    echo "== nothing changed since the run that passed at $(sed -n 2p "$passed"): not run again (FORCE=1 runs it)"
    exit 0
fi
log=target/cargo-test.log
rust_tests() {
    # The library's test binary (its unit tests and tests/it, which src/lib.rs includes)
    # and the doc tests; the examples and benchmarks are type-checked (building them
    # would only compile the engine again, and they are not tests). rustdoc runs only
    # where a doc comment holds a code block other than `text` (today none: half a
    # minute of CPU for no test).
    cargo test -p chaincart --lib &&
        { ! doc_examples || cargo test -p chaincart --doc; } &&
        cargo check --examples --benches
}
# Whether a doc comment of src/ opens a code block rustdoc tests (no language, or Rust's).
doc_examples() {
    # shellcheck disable=SC2046  # file names without spaces, one awk over all of them
    awk '
        FNR == 1 { open = 0 }
        /^[[:space:]]*\/\/[\/!][[:space:]]*```/ {
            info = $0; sub(/^[[:space:]]*\/\/[\/!][[:space:]]*```[[:space:]]*/, "", info)
            if (!open && info ~ /^(|rust|ignore|no_run|should_panic|compile_fail|edition)([,[:space:]].*)?$/) found = 1
            open = !open
        }
        END { exit !found }' $(find src -name '*.rs')
}
# At the lowest priority: set-up's build and pytest, one after the other, are the
# longer path; the Rust build takes the cycles they leave.
(renice -n 19 "$BASHPID" >/dev/null && rust_tests) >"$log" 2>&1 &
cargo_job=$!
trap 'kill "$cargo_job" 2>/dev/null || true' EXIT

scripts/setup.sh  # with every extra: the suite tests each optional path
inputs=$(fingerprint "$@")  # what this run tests (edits made while it runs are not)

echo "== ruff ($(date -u +%T))"
.venv/bin/ruff check chaincart_env tests/python
echo "== mypy ($(date -u +%T))"
.venv/bin/python -m mypy chaincart_env

echo "== pytest ($(date -u +%T))"
pytest_status=0
# The 20 slowest tests are listed at the end: the suite's time goes to few of them.
.venv/bin/python -m pytest tests/python --durations=20 "$@" || pytest_status=$?

echo "== cargo test ($(date -u +%T); its output, from $log)"
cargo_status=0
wait "$cargo_job" || cargo_status=$?
trap - EXIT
cat "$log"

verdict() { [ "$1" = 0 ] && echo passed || echo "FAILED (exit $1)"; }
echo "== cargo test $(verdict "$cargo_status"); pytest $(verdict "$pytest_status")"
if [ "$cargo_status" = 0 ] && [ "$pytest_status" = 0 ]; then
    printf '%s\n%s\n' "$inputs" "$(date -u '+%Y-%m-%d %H:%M UTC')" >"$passed"
    exit 0
fi
rm -f "$passed"
exit 1
