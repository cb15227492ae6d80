#!/usr/bin/env bash
# Installs what building and testing crumble needs on a fresh machine.
# The Rust toolchain (cargo, rustc, rustfmt, clippy) is expected on the PATH.
set -euo pipefail
for tool in cargo rustc; do
  command -v "$tool" >/dev/null || { echo "error: $tool not found; install Rust (rustup)" >&2; exit 1; }
done
rustup component add rustfmt clippy >/dev/null 2>&1 || true

# `crumble view`'s test opens a real window under Xvfb (xvfb-run needs xauth);
# the renderer draws on Mesa's software Vulkan driver where there is no GPU.
if command -v apt-get >/dev/null; then
  missing=()
  command -v xvfb-run >/dev/null || missing+=(xvfb)
  command -v xauth >/dev/null || missing+=(xauth)
  dpkg -s mesa-vulkan-drivers >/dev/null 2>&1 || missing+=(mesa-vulkan-drivers)
  if [ ${#missing[@]} -gt 0 ]; then
    sudo_cmd=""
    [ "$(id -u)" -eq 0 ] || sudo_cmd="sudo"
    $sudo_cmd apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq "${missing[@]}"
  fi
fi
