#!/usr/bin/env bash
# Runs every Oxygen test, as CI does (.ci/run calls exactly this).
#
# 1. checks for a Rust toolchain;
# 2. makes sure the drivers are there (installs Mesa's lavapipe, and Mesa's
#    GL drivers when GL is wanted, when run as root on Debian/Ubuntu;
#    otherwise prints the command to run), and a virtual X server (xvfb)
#    for the window test when it can;
# 3. runs the whole workspace's tests (unit, snapshot, layout, GPU) on
#    Vulkan, printing the adapter first;
# 4. when GL is wanted, runs the GPU test binaries again with
#    WGPU_BACKEND=gl (CPU-only tests and the fuzz corpus do not depend on
#    the backend and run once);
# 5. prints, per backend, the tests that could not run their subject on its
#    adapter (tests/support/skip.rs) and, under CI, fails when they are not
#    exactly the set docs/backends.md expects;
# 6. checks the code as a reviewer would: formatting, clippy with warnings
#    as errors, `cargo check` of every target (benches and the fuzz target
#    included), and one smoke run of every bench with tiny arguments.
#
# Under CI (`CI` set; .ci/run sets it) nothing is optional: a missing GL
# adapter or virtual X server fails the run with the command that installs
# it, and goldens and snapshots are never written (an update request fails).
#
# OXYGEN_BACKENDS picks the backends, in order: "vulkan gl" (the default),
# "vulkan" or "gl". docs/backends.md says what differs between them.
# Fails when any run fails; says which backend each run used.
set -euo pipefail
cd "$(dirname "$0")/.."

say() { printf '[oxygen] %s\n' "$*" >&2; }

if ! command -v cargo >/dev/null 2>&1; then
  say "cargo not found: install Rust (https://rustup.rs), then rerun $0"
  exit 1
fi
case "${CI:-}" in
  ""|0|[Ff][Aa][Ll][Ss][Ee]) ci=0 ;;
  *) ci=1 ;;
esac

backends=${OXYGEN_BACKENDS:-vulkan gl}
if [ "$ci" = 1 ] && [ "$backends" != "vulkan gl" ]; then
  say "CI runs every backend: OXYGEN_BACKENDS='$backends' is refused under CI (unset it)"
  exit 2
fi
export OXYGEN_BACKENDS="$backends"
scripts/ensure-gpu.sh

# Goldens and snapshots are written by people, never by CI.
if [ "$ci" = 1 ]; then
  if [ "${OXYGEN_UPDATE_GOLDEN:-}" = 1 ]; then
    say "OXYGEN_UPDATE_GOLDEN=1 under CI: goldens are never written by CI (update them locally and commit them)"
    exit 2
  fi
  case "${INSTA_UPDATE:-no}" in
    no) ;;
    *) say "INSTA_UPDATE=${INSTA_UPDATE} under CI: snapshots are never written by CI (review them locally with cargo insta)"
       exit 2 ;;
  esac
  export INSTA_UPDATE=no INSTA_FORCE_PASS=0
  # Every table of the docs must be backed by records: a table marked
  # "figures: owed" fails tests/doc_records.rs here.
  export OXYGEN_RECORDS_STRICT=1
fi

# A virtual X server for the window tests (tests/viewer_window.rs),
# installed like the drivers when run as root on Debian/Ubuntu. Without it
# those tests are counted as skipped, which CI does not accept.
if ! command -v xvfb-run >/dev/null 2>&1; then
  if [ "$(id -u)" -eq 0 ] && command -v apt-get >/dev/null 2>&1; then
    say "installing xvfb (a virtual X server) for the window tests"
    if (apt-get update && DEBIAN_FRONTEND=noninteractive apt-get install -y xvfb xauth) >/tmp/oxygen-xvfb-setup.log 2>&1; then
      say "installed xvfb"
    else
      say "could not install xvfb (log: /tmp/oxygen-xvfb-setup.log)"
    fi
  fi
  if ! command -v xvfb-run >/dev/null 2>&1; then
    if [ "$ci" = 1 ]; then
      say "no xvfb-run: CI needs the window tests; install it with: sudo apt-get install -y xvfb xauth"
      exit 1
    fi
    say "no xvfb-run here: the window tests will be counted as skipped (install: sudo apt-get install -y xvfb xauth)"
  fi
fi

say "building tests (the first build compiles wgpu and takes a few minutes)"
cargo build --locked --workspace --tests --examples

# The adapter wgpu gives for WGPU_BACKEND=$1, printed; fails when none.
# (The binary the build above made: `cargo run` would resolve features for
# the root package alone and compile crates again.)
adapter_for() {
  WGPU_BACKEND=$1 target/debug/examples/adapter_info 2>&1
}

# The integration-test binaries that render (one list, shared with
# scripts/wgsl_mutants.py).
gpu_test_binaries() {
  scripts/gpu-test-binaries
}

# Each backend's skipped tests (tests/support/skip.rs appends one line per
# skip to OXYGEN_SKIP_LOG).
skip_dir=target/oxygen-skips
mkdir -p "$skip_dir"

# The skipped tests docs/backends.md expects on backend $1: the lines of its
# fenced block tagged `skips-$1`.
expected_skips() {
  awk -v tag="skips-$1" '
    $0 == "```" tag { inside = 1; next }
    inside && /^```/ { inside = 0 }
    inside && NF { print $1 }
  ' docs/backends.md | sort -u
}

# Prints backend $1's skipped tests and, under CI, compares them with the
# expected set; returns non-zero on a difference.
report_skips() {
  local backend=$1 log="$skip_dir/$1.txt" actual expected
  # (No log: nothing was skipped; `|| true` keeps set -e from ending the run.)
  actual=$({ cut -f1 "$log" 2>/dev/null || true; } | sort -u)
  if [ -s "$log" ]; then
    say "tests skipped on $backend ($(printf '%s\n' "$actual" | grep -c .)), each with its reason:"
    sort -u "$log" | sed 's/^/[oxygen]   /' >&2
  else
    say "no test skipped on $backend"
  fi
  expected=$(expected_skips "$backend")
  if [ "$actual" != "$expected" ]; then
    say "the skipped tests on $backend differ from docs/backends.md's skips-$backend:"
    { diff <(printf '%s\n' "$expected") <(printf '%s\n' "$actual") || true; } |
      sed -n 's/^</[oxygen]   expected but ran:/p; s/^>/[oxygen]   skipped but not expected:/p' >&2
    [ "$ci" = 1 ] && return 1
    say "(not CI: reported only)"
  fi
  return 0
}

failed=()
for backend in $backends; do
  rm -f "$skip_dir/$backend.txt"
  export OXYGEN_SKIP_LOG="$PWD/$skip_dir/$backend.txt"
  case "$backend" in
    vulkan)
      say "=== backend: Vulkan (WGPU_BACKEND=vulkan): the whole workspace ==="
      if ! info=$(adapter_for vulkan); then
        say "no Vulkan adapter: $info"
        failed+=("vulkan (no adapter)")
        continue
      fi
      printf '%s\n' "$info" >&2
      WGPU_BACKEND=vulkan cargo test --locked --no-fail-fast --workspace "$@" || failed+=("vulkan")
      report_skips vulkan || failed+=("vulkan (unexpected skips)")
      ;;
    gl)
      say "=== backend: GL (WGPU_BACKEND=gl): the GPU test binaries ==="
      if ! info=$(adapter_for gl) || ! printf '%s' "$info" | grep -q '(Gl,'; then
        if [ "$ci" = 1 ]; then
          say "no GL adapter here (${info:-nothing}): CI runs the GPU tests on GL too; install Mesa's GL with:"
          say "  sudo apt-get install -y libegl1 libegl-mesa0 libgl1-mesa-dri"
          failed+=("gl (no adapter)")
        else
          say "no GL adapter here (${info:-nothing}); skipping the GL run (OXYGEN_BACKENDS=vulkan silences this)"
        fi
        continue
      fi
      printf '%s\n' "$info" >&2
      args=()
      for t in $(gpu_test_binaries); do args+=(--test "$t"); done
      say "GPU test binaries: ${args[*]}"
      WGPU_BACKEND=gl cargo test --locked --no-fail-fast --workspace "${args[@]}" "$@" || failed+=("gl")
      report_skips gl || failed+=("gl (unexpected skips)")
      ;;
    *)
      say "unknown backend '$backend' in OXYGEN_BACKENDS (use vulkan and/or gl)"
      exit 2
      ;;
  esac
done
unset OXYGEN_SKIP_LOG

# The code as a reviewer reads it, and every bench run once.
if [ "${OXYGEN_SKIP_CHECKS:-0}" = 1 ] && [ "$ci" = 0 ]; then
  say "OXYGEN_SKIP_CHECKS=1: not running the lints and bench smoke runs"
else
  scripts/check.sh || failed+=("checks")
  scripts/bench-smoke.sh || failed+=("bench smoke runs")
fi

if [ "${#failed[@]}" -ne 0 ]; then
  say "tests FAILED on: ${failed[*]}"
  exit 1
fi
say "all tests passed on: $backends"
