"""The Python side of docs/python.md's step cost: the time of
``World.step`` on a built-in scene over three spans of 600 steps, the
spans ``cargo run --release -p crumble-py --example step_cost`` times
``Simulation::step`` over in Rust.

Run: ``python crates/crumble-py/bench/step_cost.py [SCENE [ROUNDS]]``
(default ``brick_wall``, 5 rounds; each round loads the scene anew with
sleep off and times steps 0-600 as 600 calls of ``world.step()``, steps
600-1200 as one ``world.step(600)``, steps 1200-1800 as 600 calls of
``world.step()`` each followed by ``world.poses(out=...)``, each span as a
whole, loop included; then 100,000 calls of ``world.step(0)``, the
crossing into Rust and back alone; the medians over the rounds are printed).
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
        step = world.step
        t = time.perf_counter()
        for _ in range(600):
            step()
        single.append((time.perf_counter() - t) / 600)
        t = time.perf_counter()
        world.step(600)
        batch.append((time.perf_counter() - t) / 600)
        out = np.empty((len(world), 7), np.float32)
        t = time.perf_counter()
        for _ in range(600):
            step()
            world.poses(out=out)
        with_poses.append((time.perf_counter() - t) / 600)
    # The crossing alone: a call that steps nothing (GIL released and
    # taken back, the events cleared).
    crossing = []
    for _ in range(rounds):
        t = time.perf_counter()
        for _ in range(100_000):
            step(0)
        crossing.append((time.perf_counter() - t) / 100_000)
    us = lambda v: statistics.median(v) * 1e6  # noqa: E731
    print(f"{name}: World.step, median of {rounds} rounds")
    print(f"  steps 0-600, 600 calls of world.step():      {us(single):.1f} us a step")
    print(f"  steps 600-1200, one world.step(600):         {us(batch):.1f} us a step")
    print(f"  steps 1200-1800, world.step() + poses(out=): {us(with_poses):.1f} us a step")
    print(f"  a world.step(0) call, the crossing alone:    {us(crossing) * 1000:.0f} ns")


if __name__ == "__main__":
    main()
