"""Arrays, rows, adding bodies, events, threads and errors."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

import crumble
from checksum_scenes import SCENES

DROP = """\
[world.ground]

[[body]]
name = "cube"
shape = "box"
size = [0.2, 0.2, 0.2]
position = [0.0, 1.0, 0.0]
"""


def test_poses_and_velocities_shapes_and_dtypes() -> None:
    world = crumble.load_scene("brick_wall")
    n = len(world)
    assert n == 106  # 105 bricks and the ball; the ground has no row
    assert world.names[0] == "wall/0" and world.names[-1] == "ball"
    poses, vel = world.poses(), world.velocities()
    assert poses.shape == (n, 7) and poses.dtype == np.float32 and poses.flags.c_contiguous
    assert vel.shape == (n, 6) and vel.dtype == np.float32
    # The ball waits at its launch point until the first step launches it.
    assert np.array_equal(poses[-1, 3:], [0, 0, 0, 1])
    assert not vel.any()
    world.step()
    assert world.velocities()[-1, 2] < -14.0
    assert world.half_extents.shape == (n, 3) and world.half_extents.dtype == np.float32
    assert np.allclose(world.half_extents[-1], 0.075)
    assert world.shapes.count("sphere") == 1
    assert world.is_static.dtype == bool and not world.is_static.any()
    handles = world.handles
    assert handles.dtype == np.int64 and len(set(handles.tolist())) == n and (handles >= 0).all()


def test_time_dt_and_step_count() -> None:
    world = crumble.load_scene(DROP)
    assert world.time == 0.0 and world.step_count == 0
    assert world.dt == np.float32(1 / 60)
    world.step(3)
    world.step()
    assert world.step_count == 4
    assert world.time == pytest.approx(4 * world.dt, rel=1e-12)
    assert world.poses()[0, 1] < 1.0  # falling


def test_writes_into_the_callers_arrays() -> None:
    world = crumble.load_scene("brick_wall")
    world.step(10)
    out = np.full((len(world), 7), np.nan, dtype=np.float32)
    got = world.poses(out=out)
    assert got is out
    assert np.array_equal(out, world.poses())
    vout = np.full((len(world), 6), np.nan, dtype=np.float32)
    assert world.velocities(out=vout) is vout
    assert np.array_equal(vout, world.velocities())


@pytest.mark.parametrize(
    "bad, why",
    [
        (np.zeros((106, 7)), "float64"),
        (np.zeros((105, 7), np.float32), "(105, 7)"),
        (np.zeros((106, 6), np.float32), "(106, 6)"),
        (np.zeros((7, 106), np.float32).T, "not C-contiguous"),
        (np.zeros(106 * 7, np.float32), "(742,)"),
        ([[0.0] * 7] * 106, "list"),
    ],
)
def test_a_wrong_out_array_is_refused(bad, why: str) -> None:
    world = crumble.load_scene("brick_wall")
    with pytest.raises(ValueError, match=r"shape \(106, 7\)") as e:
        world.poses(out=bad)
    assert why in str(e.value)


def test_a_read_only_out_array_is_refused() -> None:
    world = crumble.load_scene("brick_wall")
    out = np.zeros((len(world), 7), np.float32)
    out.flags.writeable = False
    with pytest.raises(ValueError, match="read-only"):
        world.poses(out=out)


def test_added_bodies_come_after_the_scenes_rows_and_fall() -> None:
    world = crumble.load_scene(DROP)
    rows = world.add_boxes(
        half_extents=[[0.1, 0.1, 0.1], [0.2, 0.05, 0.1]],
        positions=[[2.0, 0.5, 0.0], [-2.0, 0.5, 0.0]],
        rotations=[[0.0, 0.0, 0.0, 2.0], [0.0, 0.0, 0.0, 1.0]],
        material="brick",
    )
    assert rows.tolist() == [1, 2]
    balls = world.add_balls(
        radii=np.array([0.05], np.float64),
        positions=np.array([[0.0, 2.0, 1.0]]),
        velocities=[[1.0, 0.0, 0.0]],
        names=["marble"],
    )
    assert balls.tolist() == [3]
    assert world.names == ["cube", "box/1", "box/2", "marble"]
    assert world.shapes == ["box", "box", "box", "sphere"]
    poses = world.poses()
    assert np.array_equal(poses[1], [2.0, 0.5, 0.0, 0.0, 0.0, 0.0, 1.0])  # rotation normalised
    assert np.array_equal(world.half_extents[2], np.float32([0.2, 0.05, 0.1]))
    world.step(30)
    after = world.poses()
    assert (after[:, 1] < poses[:, 1]).all()
    assert after[3, 0] > 0.4  # the marble keeps its velocity
    assert world.velocities()[3, 0] == pytest.approx(1.0, abs=0.01)


def test_added_bodies_are_deterministic() -> None:
    def run() -> bytes:
        world = crumble.load_scene("wall_rest")
        k = 8
        world.add_balls(np.full(k, 0.05), np.stack([np.linspace(-0.5, 0.5, k), np.full(k, 1.5), np.full(k, 1.0)], 1),
                        velocities=np.tile([0.0, 0.0, -5.0], (k, 1)))
        world.step(60)
        return world.poses().tobytes()

    assert run() == run()


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(half_extents=[[0.1, 0.1, 0.1]], positions=[[0, 1, 0], [0, 2, 0]]), r"positions: expected shape \(1, 3\), got \[2, 3\]"),
        (dict(half_extents=[0.1, 0.1, 0.1], positions=[[0, 1, 0]]), r"half_extents: expected shape \(N, 3\), got \[3\]"),
        (dict(half_extents=[[0.1, -0.1, 0.1]], positions=[[0, 1, 0]]), "half_extents: row 0 must be positive"),
        (dict(half_extents=[[0.1, 0.1, 0.1]], positions=[[0, np.nan, 0]]), "positions: row 0 holds a non-finite"),
        (dict(half_extents=[[0.1, 0.1, 0.1]], positions=[[0, 1, 0]], rotations=[[0, 0, 0, 0]]), "rotations: row 0 must be a finite non-zero quaternion"),
        (dict(half_extents=[[0.1, 0.1, 0.1]], positions=[[0, 1, 0]], velocities=[[1, 2]]), r"velocities: expected shape \(1, 3\)"),
        (dict(half_extents=[[0.1, 0.1, 0.1]], positions=[[0, 1, 0]], material="cheese"), "unknown material `cheese` .known: default, brick, steel"),
        (dict(half_extents=[[0.1, 0.1, 0.1]], positions=[[0, 1, 0]], names=["cube"]), "a body is called `cube` already"),
        (dict(half_extents=[["a", 0.1, 0.1]], positions=[[0, 1, 0]]), "half_extents: expected numbers"),
    ],
)
def test_bad_bodies_are_refused_with_what_is_wrong(kwargs, message: str) -> None:
    world = crumble.load_scene(DROP)
    with pytest.raises(ValueError, match=message):
        world.add_boxes(**kwargs)
    assert len(world) == 1  # nothing was added


def test_events_of_the_last_step_call() -> None:
    world = crumble.load_scene(SCENES["fracture_wall"])
    world.step(4)
    ev = world.events()
    assert set(ev) == {"contacts", "joint_breaks", "bond_breaks", "splits"}
    began = [e for e in ev["contacts"] if e["kind"] == "began"]
    # The bricks of the bottom row land on the ground (None).
    assert any(e["a"] is None or e["b"] is None for e in began)
    world.step(40)
    splits = world.events()["splits"]
    assert splits, "the ball breaks bricks"
    names = world.names
    for s in splits:
        parent, (p0, p1) = s["parent"], s["pieces"]
        assert names[p0] == names[parent] + ".0" and names[p1] == names[parent] + ".1"
        assert s["mode"] in ("tension", "shear") and s["ratio"] >= 1.0 and s["axis"] in (0, 1, 2)
        assert 0 < s["time"] <= world.time
    world.step(0)
    assert world.events() == {"contacts": [], "joint_breaks": [], "bond_breaks": [], "splits": []}


def test_bond_and_joint_breaks_are_reported() -> None:
    world = crumble.load_scene(SCENES["mortar_wall"])
    world.step(30)
    bonds = world.events()["bond_breaks"]
    assert bonds and all(b["mode"] in ("tension", "shear", "separated") for b in bonds)
    rope = """\
[[body]]
name = "crate"
shape = "box"
size = [0.3, 0.3, 0.3]
position = [0.0, 1.0, 0.0]

[[joint]]
kind = "rope"
a = "world"
b = "crate"
anchors = [[0.0, 2.0, 0.0], [0.0, 1.15, 0.0]]
length = 0.85
break_force = 1.0
"""
    world = crumble.load_scene(rope)
    world.step(2)
    breaks = world.events()["joint_breaks"]
    assert len(breaks) == 1
    assert breaks[0]["a"] is None and breaks[0]["b"] == 0 and breaks[0]["force"] > 1.0


def test_step_releases_the_gil() -> None:
    """A Python thread keeps counting while another is inside step(600)."""
    world = crumble.load_scene("brick_wall", no_sleep=True)
    window: list[float] = []

    def stepper() -> None:
        t0 = time.perf_counter()
        world.step(600)
        window.extend([t0, time.perf_counter()])

    samples: list[float] = []
    thread = threading.Thread(target=stepper)
    thread.start()
    while thread.is_alive():
        samples.append(time.perf_counter())
    thread.join()
    t0, t1 = window
    inside = sum(1 for t in samples if t0 < t < t1)
    assert t1 - t0 > 0.05, "the step batch is long enough to tell"
    # Held for the batch, the GIL would let no sample fall inside it.
    assert inside > 1000, f"{inside} counts in {t1 - t0:.3f} s"
    assert world.step_count == 600


def _bits(frames: list[np.ndarray]) -> list[bytes]:
    return [f.tobytes() for f in frames]


def test_rollout_is_bit_identical_on_one_and_two_threads() -> None:
    def scenes() -> list:
        return ["brick_wall", SCENES["fracture_wall"], "wrecking_ball", crumble.load_scene(SCENES["mortar_wall"])]

    one = crumble.rollout(scenes(), 90, threads=1, frames=True)
    two = crumble.rollout(scenes(), 90, threads=2, frames=True)
    assert _bits(one) == _bits(two)
    assert [f.shape[:1] for f in one] == [(90,)] * 4
    assert all(f.dtype == np.float32 and f.shape[2] == 7 for f in one)
    last = crumble.rollout(scenes(), 90, threads=2)
    assert _bits(last) == _bits([f[-1] for f in one])
    # The same as stepping each world alone.
    alone = crumble.load_scene(SCENES["fracture_wall"])
    alone.step(90)
    assert alone.poses().tobytes() == last[1].tobytes()
    assert len(alone) > 106 and one[1].shape[1] == len(alone)  # pieces, widened into the earlier frames
    # A piece sits inside its parent in the frames before it broke.
    assert np.isfinite(one[1]).all()


def test_rollout_steps_worlds_in_place() -> None:
    world = crumble.load_scene("brick_wall")
    [poses] = crumble.rollout([world], 10)
    assert world.step_count == 10 and poses.tobytes() == world.poses().tobytes()
    with pytest.raises(ValueError, match=r"scenes\[1\]: this World is in use"):
        crumble.rollout([world, world], 1)


def test_errors_name_the_place() -> None:
    with pytest.raises(crumble.SceneError, match="no built-in scene of that name .built-in: brick_wall") as e:
        crumble.load_scene("brick_wal")
    assert isinstance(e.value, ValueError) and isinstance(e.value, crumble.CrumbleError)
    bad = "[world]\ndt = 0.01\n\n[[wall]]\nrows = -3\nbricks_per_row = 4\n"
    with pytest.raises(crumble.SceneError) as e:
        crumble.load_scene(bad, file_name="mine.toml")
    assert (e.value.file, e.value.line, e.value.key) == ("mine.toml", 5, "wall[0].rows")
    assert str(e.value).startswith("mine.toml:5:")
    with pytest.raises(crumble.SceneError) as e:
        crumble.load_scene("[world]\ndt = \n")
    assert e.value.line == 2 and e.value.file == "<string>"
    with pytest.raises(crumble.SceneError, match="unknown material `cheese`"):
        crumble.load_scene("[world.ground]\nmaterial = 'cheese'\n")
    with pytest.raises(crumble.SceneError, match="missing.toml: .*No such file"):
        from pathlib import Path

        crumble.load_scene(Path("missing.toml"))
    with pytest.raises(TypeError, match="got int"):
        crumble.load_scene(3)


def test_negative_steps_and_threads_are_refused() -> None:
    world = crumble.load_scene(DROP)
    with pytest.raises(ValueError, match="steps must be >= 0, got -1"):
        world.step(-1)
    with pytest.raises(ValueError, match="steps: must be >= 0, got -5"):
        crumble.rollout(["brick_wall"], -5)
    with pytest.raises(ValueError, match="threads: must be >= 1, got 0"):
        crumble.rollout(["brick_wall"], 1, threads=0)
    with pytest.raises(crumble.SceneError, match="brick_wal"):
        crumble.rollout(["brick_wall", "brick_wal"], 1)
    assert world.step_count == 0


def test_a_panic_in_a_step_becomes_an_exception() -> None:
    """A panic inside the engine's step (here the test hook's) raises
    PanicError in Python instead of aborting it; the world refuses to go
    on, and other worlds are unaffected."""
    world = crumble.load_scene(DROP)
    world._panic_after(3)
    with pytest.raises(crumble.PanicError, match="panicked at step 4 .*the test hook's panic after step 3"):
        world.step(10)
    assert world.step_count == 3
    with pytest.raises(crumble.PanicError):
        world.step()
    assert np.isfinite(world.poses()).all()
    other = crumble.load_scene(DROP)
    other._panic_after(5)
    with pytest.raises(crumble.PanicError, match=r"scenes\[1\]: the engine panicked at step 6"):
        crumble.rollout(["brick_wall", other], 10, threads=2)
    fine = crumble.load_scene(DROP)
    fine.step(10)
    assert fine.step_count == 10
