#!/usr/bin/env bash
# The sweep acceptance of docs/sweeps.md, end to end with the real tools:
# the jobs of one manifest run by a shell loop and by GNU parallel -j2
# write identical files, a second pass skips every job, and NumPy loads
# each result with the documented names, dtypes and shapes.
# Needs the `crumble` binary (the workspace tests' build, checked here),
# GNU parallel and Python with NumPy.
set -euo pipefail
cd "$(dirname "$0")/.."

# The `crumble` of `cargo test --workspace` (the test profile, the
# workspace's features): after that run this builds nothing, where
# `cargo build -p crumble-cli` would build its dependencies again with
# other features.
cargo test -q --workspace --no-run
crumble="$PWD/target/debug/crumble"
python="${PYTHON:-python3}"
"$python" -c "import numpy" 2>/dev/null || python=/usr/bin/python3
command -v parallel >/dev/null || { echo "error: GNU parallel not found (scripts/install-deps.sh installs it)" >&2; exit 1; }

# The manifest README and docs/sweeps.md show has the jobs they count.
[ "$("$crumble" sweep sweeps/wall_speeds.toml --count)" = 11 ] || { echo "sweeps/wall_speeds.toml: not 11 jobs" >&2; exit 1; }

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
manifest='scene = "brick_wall"
seconds = 0.25
fps = 20
[set]
"world.sleep" = false
[[grid]]
"projectile.0.velocity" = [[0, 0, -10], [0, 0, -20]]
seed = [1, 2]
[[grid]]
"wall.0.rows" = [4, 6]
"wall.0.bricks_per_row" = [3, 5]
'
mkdir "$work/loop" "$work/parallel"
printf '%s' "$manifest" > "$work/loop/m.toml"
printf '%s' "$manifest" > "$work/parallel/m.toml"
jobs=$("$crumble" sweep "$work/loop/m.toml" --count)
[ "$jobs" = 8 ] || { echo "expected 8 jobs, the manifest has $jobs" >&2; exit 1; }

for i in $(seq 0 $((jobs - 1))); do "$crumble" sweep "$work/loop/m.toml" --index "$i"; done
seq 0 $((jobs - 1)) | parallel --will-cite -j2 "$crumble" sweep "$work/parallel/m.toml" --index {}
diff -r "$work/loop/m.results" "$work/parallel/m.results"
echo "loop and parallel -j2: identical files ($(ls "$work/loop/m.results" | wc -l) job folders)"
skipped=$(seq 0 $((jobs - 1)) | parallel --will-cite -j2 "$crumble" sweep "$work/loop/m.toml" --index {} | grep -c "done already")
[ "$skipped" = "$jobs" ] || { echo "a second pass ran $((jobs - skipped)) finished jobs again" >&2; exit 1; }

"$python" - "$work/loop/m.results" <<'PY'
import json, pathlib, sys
import numpy as np
dirs = sorted(pathlib.Path(sys.argv[1]).iterdir())
assert len(dirs) == 8, dirs
for d in dirs:
    job = json.loads((d / "job.json").read_text())
    z = np.load(d / "result.npz")
    frames, bodies = z["t"].shape[0], z["names"].shape[0]
    want = {
        "poses": ("float32", (frames, bodies, 7)), "t": ("float64", (frames,)), "frame": ("int64", (frames,)),
        "fps": ("float64", ()), "dt": ("float64", ()), "sizes": ("float32", (bodies, 3)),
        "static": ("bool", (bodies,)), "parent": ("int32", (bodies,)), "appears": ("float64", (bodies,)),
        "disappears": ("float64", (bodies,)), "event_t": ("float64", z["event_t"].shape),
        "event_a": ("int32", z["event_t"].shape), "event_b": ("int32", z["event_t"].shape),
    }
    for name, (dtype, shape) in want.items():
        assert (str(z[name].dtype), z[name].shape) == (dtype, shape), (d.name, name, z[name].dtype, z[name].shape)
    for name in ("names", "shapes", "event_kind"):
        assert z[name].dtype.kind == "U", (name, z[name].dtype)
    assert (frames, bodies) == (job["frames"], job["bodies"]), job
    assert z["fps"] == 20 and frames == 6, (z["fps"], frames)
    q = z["poses"][..., 3:]
    assert np.allclose(np.linalg.norm(q, axis=-1), 1, atol=1e-5) and np.isfinite(z["poses"]).all()
    assert z["names"][0] == "ground" and z["shapes"][0] == "plane"
print(f"NumPy {np.__version__} loaded {len(dirs)} results with the documented arrays")
PY
