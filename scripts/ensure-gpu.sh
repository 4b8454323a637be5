#!/usr/bin/env bash
# Makes sure wgpu will find an adapter with what Oxygen needs.
#
# On a machine without a GPU that adapter is Mesa's lavapipe (a real Vulkan
# driver running on the CPU). Oxygen needs Mesa >= 25 for descriptor indexing
# and multi-draw-indirect; Debian 12 ships Mesa 22, so there we take it from
# bookworm-backports. As root on Debian/Ubuntu we install it ourselves and say
# so; otherwise we print the exact commands and fail.
#
# When OXYGEN_BACKENDS (default "vulkan gl", see scripts/test.sh) names gl,
# it also makes sure Mesa's GL drivers are there (llvmpipe through EGL:
# libegl1, libegl-mesa0, libgl1-mesa-dri), installed the same way, so that
# wgpu's GL backend finds an adapter too.
#
# Set OXYGEN_SKIP_GPU_SETUP=1 to skip this check (e.g. on a machine with a
# real GPU driver that is not packaged by Debian).
set -euo pipefail

say() { printf '[oxygen] %s\n' "$*" >&2; }

if [ "${OXYGEN_SKIP_GPU_SETUP:-0}" = "1" ]; then
  say "OXYGEN_SKIP_GPU_SETUP=1: not checking for a Vulkan driver"
  exit 0
fi

backends=${OXYGEN_BACKENDS:-vulkan gl}
wants_gl=0
case " $backends " in *" gl "*) wants_gl=1 ;; esac

installed_major() {
  local v
  v=$(dpkg-query -W -f='${Status} ${Version}' "$1" 2>/dev/null || true)
  case "$v" in
    "install ok installed "*) v=${v#install ok installed }; v=${v#*:}; echo "${v%%.*}" ;;
    *) echo 0 ;;
  esac
}
mesa_major() { installed_major mesa-vulkan-drivers; }

# GL through EGL: the loader (libegl1) and Mesa's EGL and DRI drivers
# (llvmpipe lives in libgl1-mesa-dri). Taken from the same Mesa as lavapipe.
gl_packages="libegl1 libegl-mesa0 libgl1-mesa-dri"
gl_ok() {
  local p
  for p in $gl_packages; do
    [ "$(installed_major "$p")" -ge 1 ] || return 1
  done
}

# A vendor driver (NVIDIA, AMD proprietary) is good enough as it is.
vendor=0
if ls /usr/share/vulkan/icd.d/nvidia_icd*.json /etc/vulkan/icd.d/nvidia_icd*.json >/dev/null 2>&1; then
  say "found an NVIDIA Vulkan driver"
  vendor=1
fi

need_vulkan=0
major=$(mesa_major)
if [ "$vendor" = 0 ]; then
  if [ "$major" -ge 25 ]; then
    say "found Mesa $major Vulkan drivers (lavapipe)"
  else
    need_vulkan=1
  fi
fi
need_gl=0
if [ "$wants_gl" = 1 ]; then
  if gl_ok; then
    say "found Mesa GL drivers through EGL ($gl_packages)"
  else
    need_gl=1
  fi
fi
if [ "$need_vulkan" = 0 ] && [ "$need_gl" = 0 ]; then
  exit 0
fi

packages=""
[ "$need_vulkan" = 1 ] && packages="mesa-vulkan-drivers"
[ "$need_gl" = 1 ] && packages="$packages $gl_packages"
packages=${packages# }

if ! command -v apt-get >/dev/null 2>&1 || [ ! -r /etc/os-release ]; then
  say "missing: $packages, and this is not a Debian/Ubuntu machine."
  say "Install Mesa >= 25 with its lavapipe Vulkan driver (often 'mesa-vulkan-drivers')"
  [ "$need_gl" = 1 ] && say "and Mesa's EGL/GL drivers (llvmpipe), or set OXYGEN_BACKENDS=vulkan"
  say "and retry."
  exit 1
fi

. /etc/os-release
codename=${VERSION_CODENAME:-}
install_cmds=()
if [ "${ID:-}" = "debian" ] && [ "$codename" = "bookworm" ]; then
  install_cmds+=("echo 'deb http://deb.debian.org/debian bookworm-backports main' > /etc/apt/sources.list.d/bookworm-backports.list")
  install_cmds+=("apt-get update")
  install_cmds+=("DEBIAN_FRONTEND=noninteractive apt-get install -y -t bookworm-backports $packages")
else
  install_cmds+=("apt-get update")
  install_cmds+=("DEBIAN_FRONTEND=noninteractive apt-get install -y $packages")
fi

if [ "$(id -u)" -ne 0 ]; then
  [ "$need_vulkan" = 1 ] && say "no usable Vulkan driver found (mesa-vulkan-drivers major version: $major, need >= 25)."
  [ "$need_gl" = 1 ] && say "no GL drivers found for wgpu's GL backend (need $gl_packages; or set OXYGEN_BACKENDS=vulkan)."
  say "Run these as root, then retry:"
  for c in "${install_cmds[@]}"; do printf '    sudo sh -c "%s"\n' "$c" >&2; done
  exit 1
fi

say "installing $packages:"
for c in "${install_cmds[@]}"; do
  say "  $c"
  sh -c "$c" >/tmp/oxygen-gpu-setup.log 2>&1 || { say "failed: $c (log: /tmp/oxygen-gpu-setup.log)"; tail -20 /tmp/oxygen-gpu-setup.log >&2; exit 1; }
done
if [ "$need_vulkan" = 1 ]; then
  major=$(mesa_major)
  if [ "$major" -lt 25 ]; then
    say "installed mesa-vulkan-drivers is still version $major (< 25); descriptor indexing will be missing."
    exit 1
  fi
  say "installed Mesa $major lavapipe"
fi
if [ "$need_gl" = 1 ]; then
  gl_ok || { say "GL packages still missing after the install ($gl_packages)"; exit 1; }
  say "installed Mesa GL drivers ($gl_packages)"
fi
