//! Poses of every body sampled at a fixed frame rate.

use crate::{BodyInfo, SampledFrame, Simulation};
use crumble::{Pose, Quat, Vec3};
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
    frames_until(0, seconds, fps)
}

/// Frames a recording records at `fps` from frame `first` (at `first /
/// fps`) to time `end`, seconds.
pub fn frames_until(first: u64, end: f64, fps: u32) -> u64 {
    (((end + 1e-9) * fps as f64).floor() as u64 + 1).saturating_sub(first)
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

impl Frame {
    /// Appends a body that joined after this frame: a piece of a box that
    /// broke as a part of its parent (its parent's pose here times its pose
    /// in its parent's frame), any other body at its initial pose.
    fn push_joining(&mut self, info: &BodyInfo) {
        let pose = match info.parent {
            Some((p, local)) => {
                let parent = Pose::new(Vec3::from_array(self.positions[p]), Quat::from_array(self.rotations[p]));
                parent.mul_pose(&local)
            }
            None => info.initial,
        };
        self.positions.push(pose.position.to_array());
        self.rotations.push(pose.rotation.normalize().to_array());
    }
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
    /// The number of `frames[0]`: frame `k` shows time `k / fps`. 0 for a
    /// run from the start; a resumed run's recording starts later.
    pub first: u64,
    /// The frames, at `t = k / fps` for `k = first, first + 1, …`.
    pub frames: Vec<Frame>,
    /// Whether every frame is kept; when not, only the last one is (for
    /// a state file, [`Recording::sampled`]), as a run without outputs
    /// needs.
    pub keep_all: bool,
    /// What happened between the frames, in the order it happened (see
    /// [`Recording::note_events`]); kept with the frames.
    pub events: Vec<Event>,
}

/// Something that happened to the bodies during a run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Event {
    /// When, seconds: a launch's time, or the end of the step in which a
    /// body broke or a bond or joint broke.
    pub t: f64,
    /// What.
    pub kind: EventKind,
    /// The bodies involved, by row in [`Recording::bodies`]: the launched
    /// body, the broken body, a bond's or joint's two sides (`None` for a
    /// joint's world side).
    pub a: Option<usize>,
    /// See `a`; `None` for a launch and a split.
    pub b: Option<usize>,
}

/// The kinds of [`Event`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EventKind {
    /// A projectile entered the world.
    Launch,
    /// A box broke in two (its pieces are rows whose `parent` is it).
    Split,
    /// A bond (mortar) broke.
    BondBroken,
    /// A joint broke.
    JointBroken,
}

impl EventKind {
    /// The name outputs use.
    pub fn name(self) -> &'static str {
        match self {
            EventKind::Launch => "launch",
            EventKind::Split => "split",
            EventKind::BondBroken => "bond_broken",
            EventKind::JointBroken => "joint_broken",
        }
    }
}

impl Recording {
    /// An empty recording of `sim`'s bodies, from frame 0.
    pub fn new(sim: &Simulation, fps: u32) -> Self {
        Self {
            fps,
            dt: sim.dt,
            bodies: sim.bodies.clone(),
            first: 0,
            frames: Vec::new(),
            keep_all: true,
            events: Vec::new(),
        }
    }

    /// A recording of `sim` resumed from a state file, whose run sampled
    /// `sampled` last. At the same rate, it starts with that frame, so
    /// that its frames are the ones an uninterrupted run records from
    /// there on, quaternion signs included (each continues the frame
    /// before it). At another rate, or without one, it starts empty, at
    /// the first frame a step ending at `sim`'s time records.
    pub fn resume(sim: &Simulation, fps: u32, sampled: Option<&SampledFrame>) -> Self {
        let mut rec = Self::new(sim, fps);
        let seed = sampled.filter(|f| {
            f.fps == fps && f.positions.len() == f.rotations.len() && f.positions.len() <= sim.bodies.len()
        });
        match seed {
            Some(f) => {
                rec.first = f.index;
                let mut frame =
                    Frame { t: rec.next_time(), positions: f.positions.clone(), rotations: f.rotations.clone() };
                // Pieces that broke off since the frame: there, they move
                // as a part of their parent.
                for info in &sim.bodies[f.positions.len()..] {
                    frame.push_joining(info);
                }
                rec.frames.push(frame);
            }
            None => {
                // The frames a step ending at `now` records are those after
                // half a step before it (`next_time() <= now + dt / 2`).
                let after = sim.time() - 0.5 * sim.dt as f64;
                let mut k = (after * fps as f64).floor().max(-1.0) as i64 + 1;
                while k > 0 && (k - 1) as f64 / fps as f64 > after {
                    k -= 1;
                }
                while (k as f64 / fps as f64) <= after {
                    k += 1;
                }
                rec.first = k.max(0) as u64;
            }
        }
        rec
    }

    /// The number of the next frame to record.
    pub fn next_index(&self) -> u64 {
        self.first + self.frames.len() as u64
    }

    /// Time of the next frame to record, seconds.
    pub fn next_time(&self) -> f64 {
        self.next_index() as f64 / self.fps as f64
    }

    /// The last frame recorded, as a state file keeps it.
    pub fn sampled(&self) -> Option<SampledFrame> {
        let last = self.frames.last()?;
        Some(SampledFrame {
            fps: self.fps,
            index: self.next_index() - 1,
            positions: last.positions.clone(),
            rotations: last.rotations.clone(),
        })
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
        if !self.keep_all && self.frames.len() > 1 {
            let dropped = self.frames.len() - 1;
            self.frames.drain(..dropped);
            self.first += dropped as u64;
        }
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
                f.push_joining(info);
            }
            self.bodies.push(info.clone());
        }
    }

    /// Advances `sim` one step, noting its events when every frame is
    /// kept (see [`note_events`](Self::note_events)). Runs and sweeps
    /// step through this, and then [`capture_due`](Self::capture_due), so
    /// that they record the same frames and events.
    pub fn step(&mut self, sim: &mut Simulation) -> Result<(), crumble::WorldError> {
        // The projectiles waiting (rows), to tell which the step launches.
        let waiting: Vec<usize> = sim.pending.iter().map(|s| s.index).collect();
        sim.step()?;
        if self.keep_all {
            let launched: Vec<usize> = waiting.into_iter().filter(|&i| sim.bodies[i].handle.is_some()).collect();
            self.note_events(sim, &launched);
        }
        Ok(())
    }

    /// Captures the frames due by `sim`'s time, up to the run's `end`
    /// (seconds): those whose time is at most half a step past. Returns
    /// false, having captured them, when the frames went past
    /// [`MAX_RECORDING_BYTES`] (pieces of broken boxes join as they appear).
    pub fn capture_due(&mut self, sim: &Simulation, end: f64) -> bool {
        let now = sim.time();
        while self.next_time() <= now + 0.5 * sim.dt as f64 && self.next_time() <= end + 1e-9 {
            self.capture(sim);
            if self.bytes() > MAX_RECORDING_BYTES {
                return false;
            }
        }
        true
    }

    /// Records what the step `sim` just took did: the projectiles of
    /// `launched` (rows) entered, and the world's fracture, bond and joint
    /// events of the step. Pieces of a split join the bodies first, so that
    /// every row named exists.
    pub fn note_events(&mut self, sim: &Simulation, launched: &[usize]) {
        let world = &sim.world;
        let quiet = launched.is_empty()
            && world.fracture_events().is_empty()
            && world.bond_events().is_empty()
            && world.joint_events().is_empty();
        if quiet {
            return;
        }
        self.take_new_bodies(sim);
        let now = sim.time();
        for &i in launched {
            self.events.push(Event { t: sim.bodies[i].spawn_time, kind: EventKind::Launch, a: Some(i), b: None });
        }
        // The row of a body in the world now, or of one that left it in this
        // step (the latest row with its handle).
        let row = |h: crumble::BodyHandle| sim.bodies.iter().rposition(|b| b.handle == Some(h));
        for e in world.fracture_events() {
            let crumble::FractureEvent::Split { parent, .. } = *e;
            self.events.push(Event { t: now, kind: EventKind::Split, a: row(parent), b: None });
        }
        for e in world.bond_events() {
            let crumble::BondEvent::Broken { body_a, body_b, .. } = *e;
            self.events.push(Event { t: now, kind: EventKind::BondBroken, a: row(body_a), b: row(body_b) });
        }
        for e in world.joint_events() {
            let crumble::JointEvent::Broken { body_a, body_b, .. } = *e;
            let (a, b) = (body_a.and_then(row), body_b.and_then(row));
            self.events.push(Event { t: now, kind: EventKind::JointBroken, a, b });
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
