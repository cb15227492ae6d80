"""The Python side of docs/python.md's step cost: the time of
``World.step`` on a built-in scene, in calls of 1 step and in one call of
600, the same rounds as ``cargo run --release -p crumble-py --example
step_cost`` times ``Simulation::step`` in Rust.

Run: ``python crates/crumble-py/bench/step_cost.py [SCENE [ROUNDS]]``
(default ``brick_wall``, 5 rounds; each round loads the scene anew with
sleep off, takes 600 steps one call each, then 600 more in one call, then
600 single steps each followed by ``poses(out=...)``).
"""

from __future__ import annotations

import statistics
import sys
import time

import numpy as np

import crumble


def main() -> None:
    name = sys.argv[1] if len(sys.argv) > 1 else "brick_wall"
    rounds = int(sys.argv[2]) if len(sys.argv) > 2 else 5
    single, batch, with_poses = [], [], []
    for _ in range(rounds):
        world = crumble.load_scene(name, no_sleep=True)
        total = 0.0
        for _ in range(600):
            t = time.perf_counter()
            world.step()
            total += time.perf_counter() - t
        single.append(total / 600)
        t = time.perf_counter()
        world.step(600)
        batch.append((time.perf_counter() - t) / 600)
        out = np.empty((len(world), 7), np.float32)
        t = time.perf_counter()
        for _ in range(600):
            world.step()
            world.poses(out=out)
        with_poses.append((time.perf_counter() - t) / 600)
    us = lambda v: statistics.median(v) * 1e6  # noqa: E731
    print(f"{name}: World.step, median of {rounds} rounds of 600 steps")
    print(f"  steps 0-600, world.step() a step:           {us(single):.1f} us a step")
    print(f"  steps 600-1200, one world.step(600):        {us(batch):.1f} us a step")
    print(f"  steps 1200-1800, step() + poses(out=) each: {us(with_poses):.1f} us a step")


if __name__ == "__main__":
    main()
