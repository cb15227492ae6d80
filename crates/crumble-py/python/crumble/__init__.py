"""crumble: a deterministic rigid-body physics engine (boxes, spheres,
ground; brick walls that stand still and break), from Python.

    >>> import crumble
    >>> world = crumble.load_scene("brick_wall")
    >>> world.step(60)                    # one second, GIL released
    >>> poses = world.poses()             # (N, 7) float32: x y z qx qy qz qw

A ``World`` runs a scene exactly as ``crumble run SCENE`` does: the same
bodies, in the same rows as the JSON output (the ground plane left out),
and the same bits. See ``docs/python.md`` for the manual.
"""

from __future__ import annotations

from ._crumble import World, __version__, builtin_scenes, load_scene, rollout
from ._errors import CrumbleError, PanicError, SceneError, StepError

__all__ = [
    "World",
    "load_scene",
    "rollout",
    "builtin_scenes",
    "CrumbleError",
    "SceneError",
    "StepError",
    "PanicError",
    "__version__",
]
