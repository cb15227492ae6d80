#!/usr/bin/env bash
# Installs what building and testing crumble needs on a fresh machine.
# The Rust toolchain (cargo, rustc, rustfmt, clippy) is expected on the PATH.
set -euo pipefail
for tool in cargo rustc; do
  command -v "$tool" >/dev/null || { echo "error: $tool not found; install Rust (rustup)" >&2; exit 1; }
done
rustup component add rustfmt clippy >/dev/null 2>&1 || true

# Rendering (crumble-render; `crumble run --out x.gif|x.mp4|frames/`) needs a
# Vulkan driver: on a machine without a GPU, Mesa's lavapipe
# (mesa-vulkan-drivers) renders on the CPU. ffmpeg is only needed for .mp4;
# it is installed here so that CI tests that path too. `crumble view`'s test
# opens a real window under Xvfb (xvfb-run needs xauth) and clicks its panel
# with xdotool. scripts/blender_render.py's test renders in Debian's Blender
# (3.4; its glTF importer needs numpy): 82 packages, about 120 MB to fetch,
# 25 s to install on the 2-core CI machine. GNU parallel runs a sweep's
# jobs two at a time in scripts/sweep-tests.sh. In CI (CI set) a test whose
# tool is missing fails rather than skipping. Packages already installed
# are skipped, so this stays quick on a developer machine.
if command -v apt-get >/dev/null 2>&1 && command -v dpkg-query >/dev/null 2>&1; then
  missing=()
  for pkg in libvulkan1 mesa-vulkan-drivers ffmpeg xvfb xauth xdotool blender python3-numpy parallel; do
    dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
  done
  if [ "${#missing[@]}" -gt 0 ]; then
    sudo=""
    if [ "$(id -u)" -ne 0 ]; then
      if command -v sudo >/dev/null 2>&1; then sudo="sudo"; else
        echo "error: need root (or sudo) to install: ${missing[*]}" >&2; exit 1
      fi
    fi
    echo "== installing ${missing[*]}"
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
  fi
else
  echo "note: no apt-get here; for rendering install a Vulkan driver (a GPU's, or Mesa's lavapipe)," \
    "and ffmpeg for .mp4 output; the tests also use xvfb-run, xdotool and blender" >&2
fi
