"""crumble: a deterministic rigid-body physics engine (boxes, spheres,
ground; brick walls that stand still and break), from Python.

    >>> import crumble
    >>> world = crumble.load_scene("brick_wall")
    >>> world.step(60)                    # one second, GIL released
    >>> poses = world.poses()             # (N, 7) float32: x y z qx qy qz qw

A ``World`` runs a scene exactly as ``crumble run SCENE`` does: the same
bodies, in the same rows as the JSON output (the ground plane left out),
and the same bits. ``crumble.sweep`` runs the jobs of a parameter sweep on
any ``concurrent.futures`` executor (a Dask cluster's too). See
``docs/python.md`` and ``docs/sweeps.md`` for the manual.
"""

from __future__ import annotations

from ._crumble import World, __version__, builtin_scenes, load_scene, rollout
from ._errors import CrumbleError, PanicError, SceneError, StepError
from ._sweep import SweepJob, sweep, sweep_jobs

__all__ = [
    "World",
    "load_scene",
    "rollout",
    "builtin_scenes",
    "sweep",
    "sweep_jobs",
    "SweepJob",
    "CrumbleError",
    "SceneError",
    "StepError",
    "PanicError",
    "__version__",
]
