#!/usr/bin/env bash
# The README's code-built scene, compiled and run as a user would: pasted unchanged into the
# main.rs of a new crate outside the repository that depends on haze, and run from a directory
# that is not the repository (issue 38: it read the repository's media/ through
# CARGO_MANIFEST_DIR, which in a user's crate is theirs). Shares the repository's target
# directory, so only haze and the snippet compile. Usage: tests/readme-snippet.sh [PROFILE]
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
profile="${1:-release}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/app/src" "$work/elsewhere"
# The README's runnable ```rust block (the file-loading example is marked no_run).
awk '/^```rust$/ {n++; if (n == 1) {on = 1; next}} on && /^```$/ {on = 0} on' "$repo/README.md" \
    >"$work/app/src/main.rs"
if ! grep -q 'fn main' "$work/app/src/main.rs"; then
    echo "!!! README SNIPPET: the README's runnable rust block has no main()"
    exit 1
fi
cat >"$work/app/Cargo.toml" <<TOML
[package]
name = "app"
version = "0.1.0"
edition = "2024"

[dependencies]
haze = { path = "$repo", default-features = false }

[workspace]
TOML
cp "$repo/Cargo.lock" "$work/app/Cargo.lock"
export CARGO_TARGET_DIR="$repo/target"
flag=(); [ "$profile" = release ] && flag=(--release)
(cd "$work/app" && cargo build "${flag[@]}" --quiet)
rm -f "${TMPDIR:-/tmp}/haze-smoke.png"
(cd "$work/elsewhere" && "$CARGO_TARGET_DIR/$profile/app")
test -s "${TMPDIR:-/tmp}/haze-smoke.png"
echo "README snippet: built outside the repository and ran from $work/elsewhere; wrote ${TMPDIR:-/tmp}/haze-smoke.png"
