"""Type stubs and reference of the native module ``crumble._crumble``
(re-exported by ``crumble``). The manual is ``docs/python.md``."""

from __future__ import annotations

import os
from typing import Any, Iterable, Literal, Mapping, Optional, Sequence, TypedDict, Union

import numpy as np
import numpy.typing as npt

__version__: str

SceneSource = Union[str, "os.PathLike[str]"]
ArrayLike = npt.ArrayLike

class ContactEvent(TypedDict):
    """A contact that began or ended during a step."""

    time: float
    """Simulated time at the end of the step, s."""
    kind: Literal["began", "ended"]
    a: Optional[int]
    """Row of the first body; ``None`` for the ground plane."""
    b: Optional[int]
    """Row of the second body; ``None`` for the ground plane."""
    normal_impulse: float
    """Normal impulse the pair exchanged over the step, N·s (0 for ``ended``)."""

class JointBreak(TypedDict):
    """A joint whose force or torque over a step went above its threshold."""

    time: float
    a: Optional[int]
    """Row of body ``a``; ``None`` for the world or the ground."""
    b: Optional[int]
    force: float
    """N."""
    torque: float
    """N·m."""

class BondBreak(TypedDict):
    """A mortar bond that broke."""

    time: float
    a: Optional[int]
    """Row of body ``a``; ``None`` for the ground."""
    b: Optional[int]
    mode: Literal["tension", "shear", "separated"]
    force: float
    """The force that broke it, N (0 for ``separated``)."""

class Split(TypedDict):
    """A breakable box that split in two (``docs/fracture.md``)."""

    time: float
    parent: Optional[int]
    """Row of the box that broke (it stays, at the pose it broke at)."""
    pieces: tuple[Optional[int], Optional[int]]
    """Rows of its pieces (new rows, at the end): negative side of the cut, then positive."""
    axis: int
    """The cut's axis in the parent's frame: 0, 1 or 2."""
    offset: float
    """The cut's offset from the parent's centre along ``axis``, m."""
    mode: Literal["tension", "shear"]
    ratio: float
    """Stress over strength, at least 1."""

class Events(TypedDict):
    contacts: list[ContactEvent]
    joint_breaks: list[JointBreak]
    bond_breaks: list[BondBreak]
    splits: list[Split]

def load_scene(
    scene: SceneSource,
    *,
    no_sleep: bool = False,
    file_name: Optional[str] = None,
    set: Union[Mapping[str, Any], Sequence[str], None] = None,
    seed: Optional[int] = None,
) -> World:
    """Loads a scene and builds it exactly as ``crumble run SCENE`` does.

    ``scene`` is, in this order of precedence:

    1. an ``os.PathLike`` (e.g. ``pathlib.Path``): a scene file;
    2. a ``str`` holding a line break: TOML text;
    3. a ``str`` naming an existing file: that file (as ``crumble run``);
    4. a ``str`` naming a built-in scene (``"brick_wall"``, with or without
       ``.toml``; see ``builtin_scenes()``);
    5. a ``str`` holding ``=``: one line of TOML text.

    ``no_sleep=True`` is ``crumble run --no-sleep``: bodies never fall asleep.
    ``file_name`` names TOML text in error messages (default ``<string>``).

    ``set`` changes values of the scene by their paths, as ``crumble run
    --set KEY=VALUE`` (``docs/sweeps.md``): a dict such as
    ``{"projectile.0.velocity": [0, 0, -25], "wall.0.rows": 12}`` (values as
    Python bools, numbers, strings, lists or dicts) or a list of
    ``"KEY=VALUE"`` strings. ``seed`` is ``--seed``: every wall's jitter seed.

    Raises ``SceneError`` (a ``ValueError``) with the engine's message
    ``file:line:column: `key`: what`` for an unknown name, an unreadable
    file, bad TOML, a value out of range or overlapping bodies.
    """

def rollout(
    scenes: Iterable[Union[SceneSource, World]],
    steps: int,
    *,
    threads: Optional[int] = None,
    frames: bool = False,
    no_sleep: bool = False,
) -> list[np.ndarray]:
    """Steps many scenes ``steps`` steps each on a pool of ``threads``
    threads (default: the machine's cores), with the GIL released.

    Each scene is anything ``load_scene`` takes, or a ``World``, which is
    stepped in place (its ``events()`` then are those of this rollout).
    Returns one float32 array per scene, in order: its final poses, shape
    ``(N, 7)`` as ``World.poses()``; with ``frames=True`` its poses after
    every step, shape ``(steps, N, 7)``, N the rows at the end (a piece
    that broke off later is shown, in the frames before, moving as a part
    of its parent, as ``crumble run``'s outputs show it).

    The results do not depend on ``threads``: every scene is simulated on
    its own, to the same bits as ``World.step``.
    """

def builtin_scenes() -> list[tuple[str, str]]:
    """The built-in scenes: ``(name, one-line description)``."""

class World:
    """A simulated scene (from ``load_scene``).

    Rows: every body of the scene but the ground plane, in the order of
    ``crumble run``'s JSON output (``[[body]]`` entries, walls, pyramids,
    stacks, wrecking balls, projectiles, in file order), then bodies added
    with ``add_boxes``/``add_balls`` and pieces of broken boxes, in the
    order they joined. A row never moves or disappears: a projectile rests
    at its launch pose until launched, a broken box stays at the pose it
    broke at (its velocities then read 0).
    """

    def step(self, n: int = 1) -> None:
        """Advances ``n`` steps of ``dt`` (``n >= 0``, else ``ValueError``),
        launching projectiles when due, as ``crumble run``. The GIL is
        released for the whole batch; ``n`` calls of ``step()`` and one of
        ``step(n)`` give the same bits. Raises ``StepError`` if the engine
        refuses a step and ``PanicError`` if it panics."""
    @property
    def time(self) -> float:
        """Simulated time, s."""
    @property
    def dt(self) -> float:
        """The step, s (the scene's ``world.dt``, a float32)."""
    @property
    def step_count(self) -> int:
        """Steps taken since the scene was loaded."""
    @property
    def seconds(self) -> float:
        """The scene's run length, s (``world.seconds``)."""
    def __len__(self) -> int:
        """Number of rows."""
    def poses(self, out: Optional[np.ndarray] = None) -> np.ndarray:
        """``(N, 7)`` float32: ``x, y, z, qx, qy, qz, qw`` per row (metres;
        unit quaternion body to world, glTF order), the engine's own
        numbers. With ``out`` (C-contiguous, writeable float32 of shape
        ``(N, 7)``, else ``ValueError``) writes into it and returns it."""
    def velocities(self, out: Optional[np.ndarray] = None) -> np.ndarray:
        """``(N, 6)`` float32: linear (m/s) then angular (rad/s) velocity per
        row; ``out`` as in ``poses``."""
    @property
    def names(self) -> list[str]:
        """Each row's name (``wall/12``, ``ball``, ``wall/12.0`` for a piece)."""
    @property
    def shapes(self) -> list[str]:
        """Each row's shape: ``"box"`` or ``"sphere"``."""
    @property
    def half_extents(self) -> np.ndarray:
        """``(N, 3)`` float32: a box's half extents, a sphere's radius thrice."""
    @property
    def is_static(self) -> np.ndarray:
        """``(N,)`` bool: rows that never move."""
    @property
    def handles(self) -> np.ndarray:
        """``(N,)`` int64: each row's body slot in the engine (``BodyHandle::index``),
        -1 while the body is not in the world."""
    @property
    def body_count(self) -> int:
        """Bodies in the engine's world now, the ground included."""
    def checksum(self) -> int:
        """FNV-1a hash of every body's position, rotation and velocities
        (float32 bits, handle order): the number the Rust example
        ``cargo run --release -p crumble-physics --example checksum`` prints."""
    def events(self) -> Events:
        """What happened during the last ``step(n)`` call (all its steps):
        contacts that began or ended, joints and bonds that broke, boxes
        that split. Bodies are given by row."""
    def add_boxes(
        self,
        half_extents: ArrayLike,
        positions: ArrayLike,
        rotations: Optional[ArrayLike] = None,
        velocities: Optional[ArrayLike] = None,
        angular_velocities: Optional[ArrayLike] = None,
        *,
        material: str = "brick",
        names: Optional[Sequence[str]] = None,
    ) -> np.ndarray:
        """Adds N dynamic boxes: ``half_extents`` and ``positions`` ``(N, 3)``,
        ``rotations`` ``(N, 4)`` quaternions ``x, y, z, w`` (normalised;
        default identity), ``velocities`` and ``angular_velocities``
        ``(N, 3)`` (default 0), converted to float32. ``material`` is one of
        the scene's materials or ``default``, ``brick`` (breakable),
        ``steel``. Names default to ``box/<row>``. Returns the new rows
        (int64), which come after every existing row. Bad input raises
        ``ValueError`` naming the argument and row; nothing is added then.
        No overlap check is made."""
    def add_balls(
        self,
        radii: ArrayLike,
        positions: ArrayLike,
        velocities: Optional[ArrayLike] = None,
        angular_velocities: Optional[ArrayLike] = None,
        *,
        material: str = "steel",
        names: Optional[Sequence[str]] = None,
    ) -> np.ndarray:
        """Adds N dynamic balls: ``radii`` ``(N,)``, the rest as in
        ``add_boxes``. Names default to ``ball/<row>``."""

def _manifest_text(manifest: dict[str, Any]) -> str: ...
def _sweep_jobs(
    text: str, file: str, base: str, default_out: str
) -> tuple[str, list[tuple[int, str, list[tuple[str, str]], Optional[int]]]]: ...
def _sweep_run(text: str, file: str, base: str, default_out: str, index: int) -> tuple[bool, str]: ...
