//! Poses of every body sampled at a fixed frame rate.

use crumble::{Pose, Quat, Vec3};
use crumble_scene::{BodyInfo, Simulation};
use serde::Serialize;

/// Most bytes of frame data a run records: 2 GiB. Every frame is kept
/// until the run ends (the glTF animation and the rendered outputs are
/// made from the whole recording), so this bounds the memory a run's
/// settings imply, at 28 bytes per body per frame: 1000 fps for an hour
/// of 15 bodies fits, or 30 fps for 25 s of 100,000. A `.glb` is built in
/// memory as well, which can double it.
pub const MAX_RECORDING_BYTES: u64 = 2 << 30;

/// Bytes a frame of `bodies` bodies takes: a position (3 × f32) and a
/// rotation (4 × f32) per body, and 56 for the frame's time and vectors.
pub fn frame_bytes(bodies: u64) -> u64 {
    bodies.saturating_mul(28).saturating_add(56)
}

/// Frames a run of `seconds` records at `fps`: `t = 0, 1/fps, …` up to
/// `seconds`.
pub fn frame_count(seconds: f64, fps: u32) -> u64 {
    ((seconds + 1e-9) * fps as f64).floor() as u64 + 1
}

/// The poses of every body at one instant.
#[derive(Clone, Debug, Serialize)]
pub struct Frame {
    /// Time, seconds.
    pub t: f64,
    /// Body centres, metres, in body order.
    pub positions: Vec<[f32; 3]>,
    /// Unit quaternions `[x, y, z, w]`, in body order.
    pub rotations: Vec<[f32; 4]>,
}

/// An animation: the bodies and their sampled poses.
#[derive(Clone, Debug)]
pub struct Recording {
    /// Frames per second.
    pub fps: u32,
    /// Simulation step, seconds.
    pub dt: f32,
    /// The bodies, in output order.
    pub bodies: Vec<BodyInfo>,
    /// The frames, at `t = k / fps`.
    pub frames: Vec<Frame>,
}

impl Recording {
    /// An empty recording of `sim`'s bodies.
    pub fn new(sim: &Simulation, fps: u32) -> Self {
        Self { fps, dt: sim.dt, bodies: sim.bodies.clone(), frames: Vec::new() }
    }

    /// Time of the next frame to record, seconds.
    pub fn next_time(&self) -> f64 {
        self.frames.len() as f64 / self.fps as f64
    }

    /// Records the current poses as the next frame. Each quaternion is
    /// flipped if needed to stay in the same hemisphere as the frame before,
    /// so that interpolating between frames takes the short way round.
    pub fn capture(&mut self, sim: &Simulation) {
        self.take_new_bodies(sim);
        let t = self.next_time();
        let n = self.bodies.len();
        let mut positions = Vec::with_capacity(n);
        let mut rotations = Vec::with_capacity(n);
        for i in 0..n {
            let pose = sim.pose(i);
            let mut q = pose.rotation.normalize();
            if let Some(prev) = self.frames.last() {
                let p = prev.rotations[i];
                if q.x * p[0] + q.y * p[1] + q.z * p[2] + q.w * p[3] < 0.0 {
                    q = -q;
                }
            }
            positions.push(pose.position.to_array());
            rotations.push(q.to_array());
        }
        self.frames.push(Frame { t, positions, rotations });
    }

    /// Follows the bodies that joined or left since the last frame: pieces
    /// of boxes that broke join the recording with a pose in every earlier
    /// frame, where they move as a part of their parent (its pose there
    /// times their pose in its frame), and a body that broke keeps the
    /// time and pose it left at.
    fn take_new_bodies(&mut self, sim: &Simulation) {
        for (mine, theirs) in self.bodies.iter_mut().zip(&sim.bodies) {
            mine.despawn = theirs.despawn;
        }
        for info in &sim.bodies[self.bodies.len().min(sim.bodies.len())..] {
            for f in &mut self.frames {
                let pose = match info.parent {
                    Some((p, local)) => {
                        let parent = Pose::new(Vec3::from_array(f.positions[p]), Quat::from_array(f.rotations[p]));
                        parent.mul_pose(&local)
                    }
                    None => info.initial,
                };
                f.positions.push(pose.position.to_array());
                f.rotations.push(pose.rotation.normalize().to_array());
            }
            self.bodies.push(info.clone());
        }
    }

    /// Bytes the frames hold so far (see [`frame_bytes`]).
    pub fn bytes(&self) -> u64 {
        frame_bytes(self.bodies.len() as u64).saturating_mul(self.frames.len() as u64)
    }

    /// The first non-finite number, as (frame, body), if any.
    pub fn first_non_finite(&self) -> Option<(usize, usize)> {
        for (k, f) in self.frames.iter().enumerate() {
            if !f.t.is_finite() {
                return Some((k, 0));
            }
            for (i, (p, q)) in f.positions.iter().zip(&f.rotations).enumerate() {
                if !p.iter().chain(q.iter()).all(|x| x.is_finite()) {
                    return Some((k, i));
                }
            }
        }
        None
    }
}
