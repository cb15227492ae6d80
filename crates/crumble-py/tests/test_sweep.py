"""Scene settings from Python and sweeps (docs/sweeps.md): ``load_scene(...,
set=, seed=)`` runs what ``crumble run --set --seed`` runs, and
``crumble.sweep`` on a Dask cluster of two worker processes writes exactly
the files of a serial run and of ``crumble sweep``, skipping finished jobs."""

from __future__ import annotations

import concurrent.futures
import json
import subprocess
from pathlib import Path

import numpy as np
import pytest

import crumble

# Eight short jobs: the seed's wall hit at two speeds, each with two
# seeds of the mortar's jitter, then two heights of wall in two widths.
MANIFEST = {
    "scene": "mortar_wall",
    "seconds": 0.2,
    "fps": 20,
    "set": {"world.sleep": False},
    "grid": [
        {"projectile.0.velocity": [[0, 0, -10], [0, 0, -25]], "seed": [1, 2]},
        {"wall.0.rows": [4, 6], "wall.0.bricks_per_row": [3, 5]},
    ],
}


def files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def manifest_in(folder: Path) -> dict:
    return {**MANIFEST, "out": str(folder)}


def test_set_and_seed_change_the_scene_as_the_command_does() -> None:
    plain = crumble.load_scene("mortar_wall")
    faster = crumble.load_scene("mortar_wall", set={"projectile.0.velocity": [0, 0, -30], "wall.0.rows": 6})
    listed = crumble.load_scene("mortar_wall", set=["projectile.0.velocity=[0, 0, -30]", "wall.0.rows=6"])
    assert len(faster) == len(listed) < len(plain)
    faster.step(1)
    assert faster.velocities()[-1, 2] < -29.0, "the ball leaves at 30 m/s"
    faster.step(9)
    listed.step(10)
    assert np.array_equal(faster.poses(), listed.poses())
    # The seed of the jitter: the same as setting the wall's own seed, and
    # the bricks' masses follow it.
    a = crumble.load_scene("mortar_wall", seed=5)
    b = crumble.load_scene("mortar_wall", set={"wall.0.seed": 5})
    for w in (a, b, plain):
        w.step(20)
    assert a.checksum() == b.checksum() != plain.checksum()
    with pytest.raises(crumble.SceneError) as e:
        crumble.load_scene("mortar_wall", set={"projectile.3.speed": 1})
    assert "there is no `projectile.3`" in str(e.value)
    with pytest.raises(crumble.SceneError) as e:
        crumble.load_scene("mortar_wall", set={"wall.0.rows": 0})
    assert e.value.key == "wall[0].rows" and "--set wall.0.rows=0" in e.value.file
    with pytest.raises(TypeError):
        crumble.load_scene("mortar_wall", set={"wall.0.rows": object()})
    # NumPy values read as their Python values.
    numpy_set = crumble.load_scene(
        "mortar_wall", set={"projectile.0.velocity": np.array([0, 0, -30], np.float32), "wall.0.rows": np.int64(6)}
    )
    numpy_set.step(10)
    assert np.array_equal(numpy_set.poses(), listed.poses())
    with pytest.raises(ValueError, match="seed must be 0 or more"):
        crumble.load_scene("mortar_wall", seed=-1)
    with pytest.raises(ValueError, match="at most 64 bits"):
        crumble.load_scene("mortar_wall", set={"wall.0.seed": 2**70})
    with pytest.raises(ValueError):
        crumble.load_scene("mortar_wall", set=["rows"])


def test_jobs_are_numbered_as_the_command_numbers_them(crumble_cli: Path, tmp_path: Path) -> None:
    jobs = crumble.sweep_jobs(manifest_in(tmp_path / "r"))
    assert [j[0] for j in jobs] == list(range(8))
    assert jobs[1][2] == [("world.sleep", "false"), ("projectile.0.velocity", "[0, 0, -10]")] and jobs[1][3] == 2
    text = crumble._crumble._manifest_text(manifest_in(tmp_path / "r"))
    (tmp_path / "m.toml").write_text(text)
    listed = subprocess.run([crumble_cli, "sweep", tmp_path / "m.toml", "--list"], capture_output=True, text=True)
    assert [line.split()[1] for line in listed.stdout.splitlines()] == [j[1] for j in jobs]


def test_a_dask_cluster_writes_what_a_serial_run_and_the_command_write(crumble_cli: Path, tmp_path: Path) -> None:
    distributed = pytest.importorskip("distributed")
    serial = crumble.sweep(manifest_in(tmp_path / "serial"), concurrent.futures.ThreadPoolExecutor(max_workers=1))
    assert [j.index for j in serial] == list(range(8)) and all(j.ran for j in serial)
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster, distributed.Client(cluster) as client:
        first = crumble.sweep(manifest_in(tmp_path / "dask"), client.get_executor())
        again = crumble.sweep(manifest_in(tmp_path / "dask"), client.get_executor())
    assert all(j.ran for j in first) and not any(j.ran for j in again), "the second pass skips every job"
    assert [j.id for j in first] == [j.id for j in serial]
    want = files(tmp_path / "serial")
    assert len(want) == 16 and files(tmp_path / "dask") == want
    # The command, job by job: the same bytes.
    (tmp_path / "m.toml").write_text(crumble._crumble._manifest_text(manifest_in(tmp_path / "cli")))
    for i in range(8):
        subprocess.run([crumble_cli, "sweep", tmp_path / "m.toml", "--index", str(i)], check=True, capture_output=True)
    assert files(tmp_path / "cli") == want
    job = json.loads((serial[3].path / "job.json").read_text())
    assert job["index"] == 3 and job["seed"] == 2 and job["crumble"] == crumble.__version__
    z = np.load(serial[3].path / "result.npz")
    assert z["poses"].shape == (5, len(z["names"]), 7) and z["poses"].dtype == np.float32


def test_the_default_process_pool_and_a_manifest_file(tmp_path: Path) -> None:
    m = manifest_in(tmp_path / "pool")
    m["grid"] = [{"wall.0.rows": [3, 4]}]
    (tmp_path / "m.toml").write_text(crumble._crumble._manifest_text({**m, "out": "pool"}))
    done = crumble.sweep(tmp_path / "m.toml")
    assert [j.ran for j in done] == [True, True]
    assert all(j.path.parent == tmp_path / "pool" for j in done), "a file's paths start from its folder"
    assert [j.ran for j in crumble.sweep(tmp_path / "m.toml")] == [False, False]
    # A manifest file whose path holds `=` is a file, not TOML text.
    odd = tmp_path / "run=1"
    odd.mkdir()
    (odd / "m.toml").write_text((tmp_path / "m.toml").read_text())
    assert [j[0] for j in crumble.sweep_jobs(str(odd / "m.toml"))] == [0, 1]
    with pytest.raises(crumble.SceneError) as e:
        crumble.sweep({"scene": "brick_wall", "grid": [{"x": 3}]})
    assert "`grid[0].x`: must be a list" in str(e.value)
