#!/usr/bin/env bash
# Fuzzes the scene parser and builder (fuzz/fuzz_targets/scene.rs), then
# World::restore (fuzz/fuzz_targets/snapshot.rs), each for a bounded time,
# starting from its committed corpus (fuzz/corpus/<target>).
# Fails when the target panics, hangs past -timeout, or allocates past
# -rss_limit_mb; libFuzzer then saves the input under fuzz/artifacts/scene/
# and this script prints it. See fuzz/README.md.
# (libFuzzer's artifacts go to fuzz/artifacts/<target>/.)
#
#   bash scripts/fuzz.sh          # 60 s, as CI runs it
#   FUZZ_SECONDS=600 bash scripts/fuzz.sh
set -euo pipefail
cd "$(dirname "$0")/.."

# The fuzz crate is its own workspace, which `cargo fmt --all` skips.
cargo fmt --manifest-path fuzz/Cargo.toml -- --check

seconds="${FUZZ_SECONDS:-60}"
cargo_fuzz_version="0.13.2"

if [ "$(cargo fuzz --version 2>/dev/null || true)" != "cargo-fuzz $cargo_fuzz_version" ]; then
    echo "== installing cargo-fuzz $cargo_fuzz_version"
    cargo install cargo-fuzz --version "$cargo_fuzz_version" --locked
fi

# cargo fuzz builds with unstable compiler flags (-Zsanitizer=address and
# the coverage passes libFuzzer needs), which only a nightly compiler
# accepts. The project builds with one stable toolchain, and
# RUSTC_BOOTSTRAP=1 lets the stable compiler take them. It applies to this
# fuzz build only (its own target directory, fuzz/target), never to the
# crates' ordinary builds or tests.
export RUSTC_BOOTSTRAP=1

# cargo fuzz sets RUSTFLAGS, which replace .cargo/config.toml's
# `+avx`: add it back, so that the fuzzed solver is the shipped build's.
if [ "$(uname -m)" = "x86_64" ]; then
    export RUSTFLAGS="${RUSTFLAGS:-} -C target-feature=+avx"
fi

# fuzz/Cargo.lock is the root Cargo.lock cut to what the fuzz crate uses,
# plus libfuzzer-sys and arbitrary, so that the fuzzed crates build with
# the versions the project ships. With --locked, a lock that no longer
# fits the manifests fails here instead of resolving anew.
if ! cargo metadata --locked --format-version 1 --manifest-path fuzz/Cargo.toml >/dev/null; then
    echo "fuzz/Cargo.lock is out of date: copy Cargo.lock over it and run" \
        "\`cargo metadata --manifest-path fuzz/Cargo.toml\` to add the fuzz crate's dependencies" >&2
    exit 1
fi

# New inputs go to a scratch directory (the first one given), so the
# committed corpus is only read.
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

# Runs target $1 for $seconds from its corpus, with the extra libFuzzer
# arguments that follow; on a failure prints the input (as text: cat -v)
# and exits.
fuzz() {
    local target="$1"
    shift
    local found="$work/found-$target"
    mkdir -p "$found" "fuzz/artifacts/$target"
    touch "$work/start"
    local status=0
    cargo fuzz run "$target" "$found" "fuzz/corpus/$target" -- \
        -max_total_time="$seconds" -timeout=20 -rss_limit_mb=2048 -print_final_stats=1 "$@" \
        || status=$?
    if [ "$status" -ne 0 ]; then
        echo "fuzz: cargo fuzz $target failed (exit $status); the failing input, if any, as text (cat -v):" >&2
        find "fuzz/artifacts/$target" -type f -newer "$work/start" | while read -r f; do
            echo "--- $f" >&2
            cat -v "$f" >&2
            echo >&2
        done
        echo "reproduce: fuzz/target/*/release/$target fuzz/artifacts/$target/<file> (after this script's build)" >&2
        exit "$status"
    fi
}

# -timeout: one input running longer than 20 s is a hang (the targets bound
# their work: the slowest scene inputs measured take about 2.6 s under the
# address sanitizer on a loaded 2-core machine; see fuzz/fuzz_targets/).
# -rss_limit_mb: the fuzzer's whole process, and any single allocation,
# past 2 GB is a failure (the scene target's process peaked at about
# 550 MB in a 5-minute run, its corpus and the sanitizer's quarantine
# included).
# -dict (scene): the format's keys and values, which mutations alone find
# slowly.
fuzz scene -dict=fuzz/scene.dict
fuzz snapshot
