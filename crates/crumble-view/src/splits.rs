//! Bricks that break in the viewer: each split is counted, and its two
//! pieces flash, lit up in their own colour, for half a second of
//! simulated time, so that a split is seen where it happens (the pieces
//! fill the brick's space exactly, and at first they move together).
//!
//! The simulation appends the pieces to its bodies
//! ([`crumble_scene::Simulation::bodies`], each with
//! [`crumble_scene::BodyInfo::parent`]); the viewer learns them after each
//! step ([`Splits::take`]) by body index, which stays valid: bodies are
//! only ever appended.

use std::ops::Range;

use crumble_render::Material;
use crumble_scene::BodyInfo;

use crate::fading::{Fading, Stamped};

/// Simulated seconds a fresh piece flashes: half a bond mark's second
/// ([`crate::bonds::BREAK_MARK_SECONDS`]), since the pieces themselves
/// stay in view after it.
pub const SPLIT_FLASH_SECONDS: f64 = 0.5;
/// Most pieces flashing at once: a wall shattered in one step can split
/// thousands of bricks; beyond this many the oldest flashes go first.
pub const MAX_SPLIT_FLASHES: usize = 4096;

/// What a flashing piece's colour is lifted towards: a warm white, the
/// colour of fresh brick dust in sunlight.
const FLASH: [f32; 3] = [1.0, 0.93, 0.8];
/// How far towards [`FLASH`] the colour goes as the piece appears.
const FLASH_MIX: f32 = 0.75;

/// A piece that appeared, and when.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Flash {
    /// Its index in the simulation's bodies.
    pub body: usize,
    /// Simulated time of the step it appeared in, seconds.
    pub time: f64,
}

impl Stamped for Flash {
    fn time(&self) -> f64 {
        self.time
    }
}

/// The pieces that appeared in the last [`SPLIT_FLASH_SECONDS`] of
/// simulated time, oldest first, at most [`MAX_SPLIT_FLASHES`]; and how
/// many bodies split in all.
#[derive(Clone, Debug)]
pub struct Splits {
    flashes: Fading<Flash>,
    total: usize,
}

impl Default for Splits {
    fn default() -> Self {
        Self { flashes: Fading::new(SPLIT_FLASH_SECONDS, MAX_SPLIT_FLASHES), total: 0 }
    }
}

impl Splits {
    /// Learns the bodies `new` (indices into `bodies`) that a step ending
    /// at `time` added: each piece flashes, and each body they broke from
    /// counts once as a split. Drops the flashes whose time is over.
    pub fn take(&mut self, bodies: &[BodyInfo], new: Range<usize>, time: f64) {
        let mut parents: Vec<usize> = bodies[new.clone()].iter().filter_map(|b| b.parent.map(|(p, _)| p)).collect();
        parents.sort_unstable();
        parents.dedup();
        self.total += parents.len();
        for body in new.filter(|&i| bodies[i].parent.is_some()) {
            self.flashes.push(Flash { body, time });
        }
        self.flashes.expire(time);
    }

    /// The pieces flashing at `now`, each with what is left of its time,
    /// from 1 as it appeared to 0 when it stops.
    pub fn visible(&self, now: f64) -> impl Iterator<Item = (&Flash, f32)> {
        self.flashes.visible(now)
    }

    /// Pieces flashing (their time not yet dropped).
    pub fn len(&self) -> usize {
        self.flashes.len()
    }

    /// True when no piece is flashing.
    pub fn is_empty(&self) -> bool {
        self.flashes.is_empty()
    }

    /// Bodies split since the scene (re)started.
    pub fn total(&self) -> usize {
        self.total
    }
}

/// The material of a piece with `left` of its flash left (1 as it
/// appears, 0 at the end): its colour lifted towards a warm white, by
/// `FLASH_MIX` (three quarters) at first and linearly less to none. The renderer has no
/// emission: the flash is a lighter colour, which sunlight and shadow
/// still shade.
pub fn flash(m: Material, left: f32) -> Material {
    let t = if left.is_nan() { 0.0 } else { left.clamp(0.0, 1.0) * FLASH_MIX };
    let color = std::array::from_fn(|i| m.color[i] + (FLASH[i] - m.color[i]) * t);
    Material { color, ..m }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crumble::{Pose, Vec3};
    use crumble_scene::BodyShape;

    fn body(name: &str, parent: Option<usize>) -> BodyInfo {
        BodyInfo {
            name: name.into(),
            shape: BodyShape::Box { half_extents: Vec3::splat(0.05) },
            is_static: false,
            source: "wall[0]".into(),
            initial: Pose::IDENTITY,
            handle: None,
            spawn_time: 0.0,
            metal: false,
            parent: parent.map(|p| (p, Pose::IDENTITY)),
            despawn: None,
        }
    }

    #[test]
    fn pieces_flash_for_half_a_second_and_each_split_counts_once() {
        // Two bricks; both break in one step, then a piece of the first
        // breaks again.
        let mut bodies = vec![body("a", None), body("b", None)];
        let mut splits = Splits::default();
        splits.take(&bodies, 0..2, 0.0);
        assert_eq!((splits.total(), splits.len()), (0, 0), "the scene's own bodies are no split");
        bodies.extend([body("a.0", Some(0)), body("a.1", Some(0)), body("b.0", Some(1)), body("b.1", Some(1))]);
        splits.take(&bodies, 2..6, 1.0);
        assert_eq!((splits.total(), splits.len()), (2, 4), "two splits, four pieces");
        assert!(splits.visible(1.0).all(|(_, left)| left == 1.0));
        bodies.extend([body("a.0.0", Some(2)), body("a.0.1", Some(2))]);
        splits.take(&bodies, 6..8, 1.25);
        assert_eq!(splits.total(), 3);
        let left: Vec<(usize, f32)> = splits.visible(1.25).map(|(f, l)| (f.body, l)).collect();
        assert_eq!(left, [(2, 0.5), (3, 0.5), (4, 0.5), (5, 0.5), (6, 1.0), (7, 1.0)]);
        // At 1.5 s the first four are over: dropped at the next step.
        assert_eq!(splits.visible(1.5).count(), 2);
        splits.take(&bodies, 8..8, 1.5);
        assert_eq!(splits.len(), 2);
        assert_eq!(splits.total(), 3, "the count stays when the flashes go");

        // A burst keeps the newest MAX_SPLIT_FLASHES.
        let first = bodies.len();
        bodies.extend((0..MAX_SPLIT_FLASHES + 10).map(|_| body("p", Some(0))));
        splits.take(&bodies, first..bodies.len(), 2.0);
        assert_eq!(splits.len(), MAX_SPLIT_FLASHES);
        assert_eq!(splits.visible(2.0).next().unwrap().0.body, first + 10, "the oldest went first");
    }

    #[test]
    fn a_flash_lifts_the_colour_then_fades_back_to_it() {
        let brick = crumble_render::brick_material(7, Vec3::new(0.1, 0.03, 0.05));
        assert_eq!(flash(brick, 0.0), brick);
        assert_eq!(flash(brick, f32::NAN), brick);
        let lit = flash(brick, 1.0);
        let sum = |m: Material| m.color.iter().sum::<f32>();
        // Three quarters of the way to the warm white: a red brick of
        // about 0.6, 0.25, 0.17 goes to about 0.9, 0.76, 0.64.
        assert!(sum(lit) > sum(brick) + 1.0, "{:?} from {:?}", lit.color, brick.color);
        assert!(lit.color.iter().all(|c| (0.0..=1.0).contains(c)));
        let mut last = lit;
        for i in (0..10).rev() {
            let m = flash(brick, i as f32 / 10.0);
            assert!(sum(m) < sum(last), "dimmer as it fades: {i}");
            last = m;
        }
        assert_eq!((lit.metalness, lit.edge_width), (brick.metalness, brick.edge_width));
    }
}
