#!/usr/bin/env bash
# Compiles the wrapper and its tests (tsc) and runs them with node's test runner against the
# module `scons web` built (copied next to the compiled wrapper).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
[ -f src/wasm/ikchain_wasm.mjs ] || { echo "unit: src/wasm/ikchain_wasm.mjs is missing: run 'scons web' first" >&2; exit 1; }
rm -rf .test-out
npx tsc -p tsconfig.test.json
mkdir -p .test-out/src/wasm && cp src/wasm/ikchain_wasm.mjs .test-out/src/wasm/
exec node --test --test-reporter=spec .test-out/tests/unit/
