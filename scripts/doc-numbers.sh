#!/usr/bin/env bash
# Regenerates every figure the docs quote (docs/numbers.txt) with the
# release `qpv` binary and compares it with the text:
#
#     scripts/doc-numbers.sh            # print quoted and fresh figures, exit 1 on a drift
#     scripts/doc-numbers.sh --write    # rewrite the docs with the fresh figures
#     scripts/doc-numbers.sh --cheap    # only the records `cargo test` checks too
#
# Wall times (`precision = any`) are measured here and only rewritten,
# never compared; run on an idle machine before --write.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --bin qpv --example doc_numbers
target="${CARGO_TARGET_DIR:-target}"
exec "$target/release/examples/doc_numbers" --bin "$target/release/qpv" "$@"
