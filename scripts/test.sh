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
# 4. when GL is wanted and a GL adapter exists, runs the GPU test binaries
#    again with WGPU_BACKEND=gl (CPU-only tests and the fuzz corpus do not
#    depend on the backend and run once).
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
backends=${OXYGEN_BACKENDS:-vulkan gl}
export OXYGEN_BACKENDS="$backends"
scripts/ensure-gpu.sh

# A virtual X server for the window test (tests/viewer_window.rs), installed
# like the drivers when run as root on Debian/Ubuntu; without it that test
# says so and is skipped.
if ! command -v xvfb-run >/dev/null 2>&1; then
  if [ "$(id -u)" -eq 0 ] && command -v apt-get >/dev/null 2>&1; then
    say "installing xvfb (a virtual X server) for the window test"
    if (apt-get update && DEBIAN_FRONTEND=noninteractive apt-get install -y xvfb xauth) >/tmp/oxygen-xvfb-setup.log 2>&1; then
      say "installed xvfb"
    else
      say "could not install xvfb (log: /tmp/oxygen-xvfb-setup.log); the window test will say it is skipped"
    fi
  else
    say "no xvfb-run here: the window test will say it is skipped (as root: apt-get install -y xvfb)"
  fi
fi

say "building tests (the first build compiles wgpu and takes a few minutes)"
cargo build --locked --workspace --tests --examples

# The adapter wgpu gives for WGPU_BACKEND=$1, printed; fails when none.
adapter_for() {
  WGPU_BACKEND=$1 cargo run --locked --quiet --example adapter_info 2>&1
}

# The integration-test binaries that render (they open an adapter).
gpu_test_binaries() {
  grep -l -E 'gpu_renderer|GpuContext|new_headless' tests/*.rs | xargs -n1 basename | sed 's/\.rs$//'
}

failed=()
for backend in $backends; do
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
      ;;
    gl)
      say "=== backend: GL (WGPU_BACKEND=gl): the GPU test binaries ==="
      if ! info=$(adapter_for gl) || ! printf '%s' "$info" | grep -q '(Gl,'; then
        say "no GL adapter here (${info:-nothing}); skipping the GL run (OXYGEN_BACKENDS=vulkan silences this)"
        continue
      fi
      printf '%s\n' "$info" >&2
      args=()
      for t in $(gpu_test_binaries); do args+=(--test "$t"); done
      say "GPU test binaries: ${args[*]}"
      WGPU_BACKEND=gl cargo test --locked --no-fail-fast "${args[@]}" "$@" || failed+=("gl")
      ;;
    *)
      say "unknown backend '$backend' in OXYGEN_BACKENDS (use vulkan and/or gl)"
      exit 2
      ;;
  esac
done

if [ "${#failed[@]}" -ne 0 ]; then
  say "tests FAILED on: ${failed[*]}"
  exit 1
fi
say "all tests passed on: $backends"
