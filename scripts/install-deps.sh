#!/usr/bin/env bash
# Installs what building and testing crumble needs on a fresh machine.
# The Rust toolchain (cargo, rustc, rustfmt, clippy) is expected on the PATH.
set -euo pipefail
for tool in cargo rustc; do
  command -v "$tool" >/dev/null || { echo "error: $tool not found; install Rust (rustup)" >&2; exit 1; }
done
rustup component add rustfmt clippy >/dev/null 2>&1 || true
