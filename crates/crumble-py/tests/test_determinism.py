"""Python simulates the bits that Rust does."""

from __future__ import annotations

import json
import re
import subprocess

import numpy as np
import pytest

import crumble
from checksum_scenes import SCENES
from conftest import cargo

STEPS = 240


@pytest.fixture(scope="module")
def rust_checksums() -> dict[str, str]:
    """The lines of the checksum example, by scene. It runs in the test
    profile (optimised, with debug assertions), which CI builds for its
    own checksum comparisons: the release build prints the same lines, and
    building it here would cost a minute of CI."""
    out = cargo("run", "-q", "--profile", "test", "-p", "crumble-physics", "--example", "checksum", "--", str(STEPS))
    lines = {line.split(":")[0]: line for line in out.splitlines() if line.strip()}
    assert set(lines) == set(SCENES), f"the example's scenes changed: {sorted(lines)}"
    return lines


@pytest.mark.parametrize("name", sorted(SCENES))
def test_checksum_scenes_match_the_rust_example(name: str, rust_checksums: dict[str, str]) -> None:
    world = crumble.load_scene(SCENES[name], file_name=f"{name}.toml")
    world.step(STEPS)
    line = f"{name}: {STEPS} steps, {world.body_count} bodies, checksum {world.checksum():016x}"
    assert line == rust_checksums[name]


def test_checksum_scenes_really_move_and_break() -> None:
    """The scenes compared above are not at rest: their checksums change
    with the steps, and the fracture wall breaks, so the comparison covers
    contacts, joints, bonds and splits."""
    world = crumble.load_scene(SCENES["fracture_wall"])
    before = world.checksum()
    world.step(30)
    assert world.checksum() != before
    world.step(STEPS - 30)
    assert len(world) > 106  # pieces joined the rows


def test_step_batches_do_not_change_the_bits() -> None:
    one = crumble.load_scene(SCENES["mortar_wall"])
    for _ in range(90):
        one.step()
    batch = crumble.load_scene(SCENES["mortar_wall"])
    batch.step(45)
    batch.step(0)
    batch.step(45)
    assert one.checksum() == batch.checksum()
    assert one.poses().tobytes() == batch.poses().tobytes()
    assert one.velocities().tobytes() == batch.velocities().tobytes()


def _bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float32).view(np.uint32)


def _glam_normalize(q: np.ndarray) -> np.ndarray:
    """`glam::Quat::normalize` in float32, operation for operation (its
    SSE2 code: the dot product as (x² + z²) + (y² + w²), its square root,
    each component divided by it), so to the bit."""
    q = np.asarray(q, dtype=np.float32)
    sq = q * q
    length = np.sqrt((sq[:, 0] + sq[:, 2]) + (sq[:, 1] + sq[:, 3]))
    return q / length[:, None]


@pytest.mark.parametrize("scene, seconds", [("tower", 1.5), ("brick_wall", 0.5)])
def test_poses_match_crumble_run_json(crumble_cli, tmp_path, scene: str, seconds: float) -> None:
    """Every frame of `crumble run SCENE --out x.json` (one per step at
    60 fps and 1/60 s steps) holds the poses of `World.poses()` after as
    many steps: the same rows (the JSON's bodies but the ground) and the
    same positions to the bit. The JSON's rotations are the engine's
    quaternions normalised once more (glam's `normalize`, repeated here
    to the bit) and negated where needed to stay in the hemisphere of the
    frame before; so are `poses()`'s, here, to the bit."""
    out = tmp_path / "x.json"
    subprocess.run(
        [str(crumble_cli), "run", scene, "--seconds", str(seconds), "--fps", "60", "--quiet", "--out", str(out)],
        check=True,
        capture_output=True,
    )
    doc = json.loads(out.read_text())
    world = crumble.load_scene(scene)
    assert np.float32(doc["dt"]) == np.float32(world.dt)
    bodies = [b for b in doc["bodies"] if b["shape"] != "plane"]
    assert [b["name"] for b in bodies] == world.names
    assert len(doc["frames"]) == round(seconds * 60) + 1
    for k, frame in enumerate(doc["frames"]):
        if k:
            world.step()
        ground = 1 if doc["bodies"][0]["shape"] == "plane" else 0
        pos = np.array(frame["positions"][ground:], dtype=np.float32)
        rot = np.array(frame["rotations"][ground:], dtype=np.float32)
        poses = world.poses()
        assert np.array_equal(_bits(poses[:, :3]), _bits(pos)), f"positions of frame {k}"
        mine = _glam_normalize(poses[:, 3:])
        flip = np.sum(mine * rot, axis=1) < 0
        mine[flip] = -mine[flip]
        assert np.array_equal(_bits(mine), _bits(rot)), f"rotations of frame {k}"


def test_load_scene_accepts_names_paths_and_text(tmp_path) -> None:
    from conftest import REPO

    path = REPO / "scenes" / "brick_wall.toml"
    by_name = crumble.load_scene("brick_wall")
    by_path = crumble.load_scene(path)
    by_str_path = crumble.load_scene(str(path))
    by_text = crumble.load_scene(path.read_text())
    for w in (by_name, by_path, by_str_path, by_text):
        w.step(20)
    sums = {w.checksum() for w in (by_name, by_path, by_str_path, by_text)}
    assert len(sums) == 1
    assert re.fullmatch(r"\d+\.\d+\.\d+", crumble.__version__)
