#!/usr/bin/env bash
# The code as a reviewer reads it; scripts/test.sh runs this after the tests.
#
# 1. formatting (`cargo fmt --check`);
# 2. clippy over every target of the workspace (library, tests, examples,
#    benches) with warnings as errors: clippy type-checks everything
#    `cargo check --all-targets` would;
# 3. the API docs of every workspace crate with rustdoc's warnings as
#    errors (a broken link in a doc comment fails);
# 4. `cargo check` of the two projects outside the workspace: the fuzz
#    target (fuzz/, its own workspace for cargo-fuzz) and the Bevy peer
#    bench (benches/peer-bevy, its own workspace, checked into this
#    workspace's target folder; the first check downloads and compiles
#    Bevy's crates, a few minutes).
#
# OXYGEN_SKIP_PEER_CHECK=1 leaves out the Bevy check (refused under CI).
set -euo pipefail
cd "$(dirname "$0")/.."

say() { printf '[oxygen] %s\n' "$*" >&2; }
failed=()
step() {
  local what=$1
  shift
  local start=$SECONDS
  say "check: $what"
  if "$@"; then
    say "check: $what passed ($((SECONDS - start)) s)"
  else
    say "check: $what FAILED"
    failed+=("$what")
  fi
}

step "cargo fmt --check" cargo fmt --all -- --check
step "clippy -D warnings (every target)" \
  cargo clippy --locked --workspace --all-targets -- -D warnings
step "cargo doc -D warnings (the workspace's API docs)" \
  env RUSTDOCFLAGS="-D warnings" cargo doc --locked --no-deps --workspace
# The workspace's target folder: the fuzz crate's dependencies are the
# workspace's, already checked by clippy above. Without default features:
# the Rust code only, not libFuzzer's C++ (which `cargo fuzz` builds).
step "cargo check of the fuzz target" \
  env CARGO_TARGET_DIR="$PWD/target" cargo check --locked --manifest-path fuzz/Cargo.toml --all-targets --no-default-features
case "${CI:-}" in ""|0|[Ff][Aa][Ll][Ss][Ee]) ci=0 ;; *) ci=1 ;; esac
if [ "${OXYGEN_SKIP_PEER_CHECK:-0}" = 1 ] && [ "$ci" = 0 ]; then
  say "OXYGEN_SKIP_PEER_CHECK=1: not checking the Bevy peer bench"
else
  # In the workspace's target folder too: the 183 crates it shares with the
  # workspace at the same versions (serde, syn, glam, ...) are not checked
  # again (about 30 s of a cold run).
  step "cargo check of the Bevy peer bench" \
    env CARGO_TARGET_DIR="$PWD/target" cargo check --locked --manifest-path benches/peer-bevy/Cargo.toml --all-targets
fi

if [ "${#failed[@]}" -ne 0 ]; then
  say "checks FAILED: ${failed[*]}"
  exit 1
fi
say "checks passed"
