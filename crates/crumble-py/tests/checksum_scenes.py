"""The scenes of `crates/crumble/examples/checksum.rs` as scene files.

The example builds each world from the engine's generators
(`crumble::scenes`); each text below makes the same bodies in the same
order (handle order), with the same materials, settings and numbers, so
that `World.checksum()` after the same steps must print the same hash.

- The example's ground and plain walls are of the engine's `BRICK`, which
  never breaks, while scene files' built-in `brick` breaks: `plain_brick`
  here is `BRICK`'s numbers without strengths.
- The example's ball is added after the wall; a `[[body]]` would come
  before it in the world, a `[[projectile]]` launched at 0 s comes after.
- The example computes its positions in float32 (`rows * brick.y * 0.5`
  and so on); they are computed here in float32 too and written with
  every digit of their float64 value, which is exact.
"""

from __future__ import annotations

import numpy as np

f32 = np.float32


def exact(x: np.float32) -> str:
    """A float32 as TOML text that parses back to the same float32."""
    return repr(float(x))


ROWS = f32(10)
BRICK = (f32(0.215), f32(0.065), f32(0.1025))
MID = ROWS * BRICK[1] * f32(0.5)

HEADER = """\
[world]
seconds = 4.0

[materials.plain_brick]
density = 2000.0
friction = 0.6
restitution = 0.1
rolling_resistance = 0.05

[world.ground]
material = "plain_brick"
"""

WALL = """
[[wall]]
name = "wall"
rows = 10
bricks_per_row = 10
material = "{material}"
"""

BALL = f"""
[[projectile]]
name = "ball"
shape = "sphere"
radius = 0.075
from = [0.0, {exact(MID)}, 2.0]
velocity = [0.0, 0.0, -15.0]
material = "steel"
"""

# WreckingBallSpec::default(): 20 links of 0.12 m and a 0.15 m ball; the
# example hangs it so that the ball touches the wall's face at mid-height.
_LENGTH = f32(20) * f32(0.12) + f32(0.15)
_ANCHOR_Y = MID + _LENGTH
_ANCHOR_Z = -f32(0.5) * BRICK[2] - f32(0.15)
WRECKING_BALL = f"""
[[wrecking_ball]]
anchor = [0.0, {exact(_ANCHOR_Y)}, {exact(_ANCHOR_Z)}]
"""

SCENES = {
    "brick_wall": HEADER + WALL.format(material="plain_brick") + BALL,
    "wall_10x10": HEADER + WALL.format(material="plain_brick"),
    "pyramid_20": HEADER
    + """
[[pyramid]]
base = 20
size = [1.0, 1.0, 1.0]
material = "plain_brick"
""",
    "wrecking_ball": HEADER + WALL.format(material="plain_brick") + WRECKING_BALL,
    "mortar_wall": HEADER + WALL.format(material="plain_brick") + 'mortar = "lime"\n' + BALL,
    "fracture_wall": HEADER + WALL.format(material="brick") + BALL,
}
