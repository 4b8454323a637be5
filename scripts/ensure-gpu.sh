#!/usr/bin/env bash
# Makes sure wgpu will find an adapter with what Oxygen needs.
#
# On a machine without a GPU that adapter is Mesa's lavapipe (a real Vulkan
# driver running on the CPU). Oxygen needs Mesa >= 25 for descriptor indexing
# and multi-draw-indirect; Debian 12 ships Mesa 22, so there we take it from
# bookworm-backports. As root on Debian/Ubuntu we install it ourselves and say
# so; otherwise we print the exact commands and fail.
#
# Set OXYGEN_SKIP_GPU_SETUP=1 to skip this check (e.g. on a machine with a
# real GPU driver that is not packaged by Debian).
set -euo pipefail

say() { printf '[oxygen] %s\n' "$*" >&2; }

if [ "${OXYGEN_SKIP_GPU_SETUP:-0}" = "1" ]; then
  say "OXYGEN_SKIP_GPU_SETUP=1: not checking for a Vulkan driver"
  exit 0
fi

mesa_major() {
  local v
  v=$(dpkg-query -W -f='${Status} ${Version}' mesa-vulkan-drivers 2>/dev/null || true)
  case "$v" in
    "install ok installed "*) v=${v#install ok installed }; v=${v#*:}; echo "${v%%.*}" ;;
    *) echo 0 ;;
  esac
}

# A vendor driver (NVIDIA, AMD proprietary) is good enough as it is.
if ls /usr/share/vulkan/icd.d/nvidia_icd*.json /etc/vulkan/icd.d/nvidia_icd*.json >/dev/null 2>&1; then
  say "found an NVIDIA Vulkan driver"
  exit 0
fi

major=$(mesa_major)
if [ "$major" -ge 25 ]; then
  say "found Mesa $major Vulkan drivers (lavapipe)"
  exit 0
fi

if ! command -v apt-get >/dev/null 2>&1 || [ ! -r /etc/os-release ]; then
  say "no usable Vulkan driver found and this is not a Debian/Ubuntu machine."
  say "Install Mesa >= 25 with its lavapipe Vulkan driver (often 'mesa-vulkan-drivers') and retry."
  exit 1
fi

. /etc/os-release
codename=${VERSION_CODENAME:-}
install_cmds=()
if [ "${ID:-}" = "debian" ] && [ "$codename" = "bookworm" ]; then
  install_cmds+=("echo 'deb http://deb.debian.org/debian bookworm-backports main' > /etc/apt/sources.list.d/bookworm-backports.list")
  install_cmds+=("apt-get update")
  install_cmds+=("DEBIAN_FRONTEND=noninteractive apt-get install -y -t bookworm-backports mesa-vulkan-drivers")
else
  install_cmds+=("apt-get update")
  install_cmds+=("DEBIAN_FRONTEND=noninteractive apt-get install -y mesa-vulkan-drivers")
fi

if [ "$(id -u)" -ne 0 ]; then
  say "no usable Vulkan driver found (mesa-vulkan-drivers major version: $major, need >= 25)."
  say "Run these as root, then retry:"
  for c in "${install_cmds[@]}"; do printf '    sudo sh -c "%s"\n' "$c" >&2; done
  exit 1
fi

say "no usable Vulkan driver found (mesa-vulkan-drivers major version: $major); installing Mesa's lavapipe:"
for c in "${install_cmds[@]}"; do
  say "  $c"
  sh -c "$c" >/tmp/oxygen-gpu-setup.log 2>&1 || { say "failed: $c (log: /tmp/oxygen-gpu-setup.log)"; tail -20 /tmp/oxygen-gpu-setup.log >&2; exit 1; }
done
major=$(mesa_major)
if [ "$major" -lt 25 ]; then
  say "installed mesa-vulkan-drivers is still version $major (< 25); descriptor indexing will be missing."
  exit 1
fi
say "installed Mesa $major lavapipe"
