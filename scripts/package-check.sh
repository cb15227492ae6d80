#!/usr/bin/env bash
# Packages the engine crate (crumble-physics) as `cargo publish` would
# upload it, and checks the package: its readme and both license files are
# in it, and its sources build alone, outside the workspace (`cargo
# package` builds the unpacked .crate). Prints the package's file count
# and the .crate's size.
set -euo pipefail
cd "$(dirname "$0")/.."

list=$(cargo package --list -p crumble-physics)
for f in Cargo.toml README.md LICENSE-MIT LICENSE-APACHE src/lib.rs; do
    if ! grep -qx "$f" <<<"$list"; then
        echo "the crumble-physics package lacks $f:"
        echo "$list"
        exit 1
    fi
done

cargo package -p crumble-physics

version=$(cargo pkgid -p crumble-physics | sed 's/.*@//')
crate="${CARGO_TARGET_DIR:-target}/package/crumble-physics-$version.crate"
echo "crumble-physics $version: $(wc -l <<<"$list") files, $(stat -c %s "$crate") bytes in $crate"
