//! State files: a [`Simulation`] saved between two steps as bytes, and a
//! simulation resumed from them that continues as the saved one would have.
//!
//! The world's own snapshot ([`World::snapshot`]) carries the physics; a
//! state file embeds it as one length-prefixed blob and adds the scene's
//! side: the bodies in output order (names, shapes, pieces of broken boxes
//! with their parents), the projectiles still to launch, the step, and a
//! [`RunInfo`] for the program that continues the run. The layout, version
//! [`STATE_VERSION`], is in `docs/output-formats.md` ("State files"): a
//! 36-byte header (magic bytes, version, length and FNV-1a checksum of the
//! contents), then the contents, little-endian, floats as their IEEE bits.
//!
//! Reading checks everything before anything is used: the header, the
//! checksum, every length against the bytes left, every number (finite,
//! in range), every index (a piece's parent comes before it, a projectile's
//! body exists and waits), every handle (a body of the restored world, one
//! body each), and that the world's time is the state's. A failure is a
//! [`StateError`] naming the byte and the field, never a panic.

use std::collections::{HashMap, HashSet};

use crumble::{BodyHandle, Material, Pose, Quat, Shape, Strength, Vec3, World};

use crate::build::{BodyInfo, BodyShape, Launch, ScheduledSpawn, Simulation};
use crate::spec::CameraSpec;

/// The first 16 bytes of a state file: a byte that is not ASCII (so that
/// no text file begins so), the words, and a CR LF (which a transfer in
/// text mode would change).
pub const STATE_MAGIC: [u8; 16] = *b"\x89crumble state\r\n";

/// The version of the state format this crate writes and reads.
pub const STATE_VERSION: u32 = 1;

/// Bytes of the header: magic, version (u32), length (u64) and checksum
/// (u64) of the contents.
pub const STATE_HEADER_BYTES: usize = 16 + 4 + 8 + 8;

/// What a run carries beside its simulation, for the one that resumes it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunInfo {
    /// The scene's name as messages show it, e.g.
    /// `scenes/brick_wall.toml (built-in)`.
    pub scene: String,
    /// The scene's `[camera]`, if it has one.
    pub camera: Option<CameraSpec>,
    /// The last frame the run sampled, if it sampled any.
    pub frame: Option<SampledFrame>,
}

/// A frame a run sampled: the poses of the first `positions.len()` bodies
/// as recorded (each quaternion in the hemisphere of the frame before it,
/// so that a recording that resumes from it at the same rate continues
/// with the same signs).
#[derive(Clone, Debug, PartialEq)]
pub struct SampledFrame {
    /// Frames per second of the run.
    pub fps: u32,
    /// The frame's number: it shows time `index / fps`.
    pub index: u64,
    /// Body centres, metres, in body order.
    pub positions: Vec<[f32; 3]>,
    /// Unit quaternions `[x, y, z, w]`, in body order.
    pub rotations: Vec<[f32; 4]>,
}

/// Why a state file was refused. Offsets count bytes from the start of
/// the file.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum StateError {
    /// No bytes at all.
    #[error("the file is empty (a state file is at least its {STATE_HEADER_BYTES}-byte header)")]
    Empty,
    /// The magic bytes are not a state file's.
    #[error("not a crumble state file ({0})")]
    NotState(String),
    /// The file ends inside the header.
    #[error("truncated: {0} bytes, inside the {STATE_HEADER_BYTES}-byte header")]
    TruncatedHeader(usize),
    /// A version this crate does not read.
    #[error(
        "version {0} of the state format; this crumble reads version {STATE_VERSION} only (save the state \
         again with this crumble)"
    )]
    Version(u32),
    /// Fewer bytes than the header announces.
    #[error("truncated: the header announces {expected} bytes of contents, {found} follow it")]
    Truncated {
        /// Bytes announced.
        expected: u64,
        /// Bytes present.
        found: u64,
    },
    /// More bytes than the header announces.
    #[error("{0} bytes after the end of the contents the header announces")]
    Trailing(u64),
    /// The contents do not match their checksum.
    #[error("corrupted: the contents' checksum is {found:#018x}, the header says {expected:#018x}")]
    Checksum {
        /// The header's.
        expected: u64,
        /// The contents'.
        found: u64,
    },
    /// A field that cannot be right.
    #[error("byte {offset}: {field}: {problem}")]
    Invalid {
        /// Where the field starts.
        offset: usize,
        /// Which field, e.g. `body 3 (`wall0/3`): initial pose`.
        field: String,
        /// What is wrong with it.
        problem: String,
    },
    /// The world refused its snapshot.
    #[error("byte {offset}: the world's snapshot: {message}")]
    World {
        /// Where the snapshot starts.
        offset: usize,
        /// The world's refusal.
        message: String,
    },
}

/// FNV-1a, 64 bits: any change of a single byte changes it (each byte's
/// step is a bijection of the running value).
fn checksum(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// Appends little-endian fields.
struct Writer(Vec<u8>);

impl Writer {
    fn u8(&mut self, x: u8) {
        self.0.push(x);
    }
    fn u32(&mut self, x: u32) {
        self.0.extend_from_slice(&x.to_le_bytes());
    }
    fn u64(&mut self, x: u64) {
        self.0.extend_from_slice(&x.to_le_bytes());
    }
    fn f32(&mut self, x: f32) {
        self.u32(x.to_bits());
    }
    fn f64(&mut self, x: f64) {
        self.u64(x.to_bits());
    }
    fn len(&mut self, n: usize) {
        // Counts and lengths fit: a run holds fewer than 2^32 bodies, and
        // a name is part of a scene file.
        self.u32(u32::try_from(n).unwrap_or(u32::MAX));
    }
    fn bytes(&mut self, b: &[u8]) {
        self.len(b.len());
        self.0.extend_from_slice(b);
    }
    fn floats<const N: usize>(&mut self, a: [f32; N]) {
        for x in a {
            self.f32(x);
        }
    }
    fn pose(&mut self, p: &Pose) {
        self.floats(p.position.to_array());
        self.floats(p.rotation.to_array());
    }
    fn option_floats<const N: usize>(&mut self, a: Option<[f32; N]>) {
        self.u8(a.is_some() as u8);
        if let Some(a) = a {
            self.floats(a);
        }
    }
}

/// Reads little-endian fields, each checked against the bytes left;
/// errors name the field within `context` (e.g. `body 3`).
struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
    /// Offset of `bytes[0]` in the file.
    base: usize,
    context: String,
}

impl<'a> Reader<'a> {
    fn invalid(&self, at: usize, field: &str, problem: impl Into<String>) -> StateError {
        let field = if self.context.is_empty() { field.to_string() } else { format!("{}: {field}", self.context) };
        StateError::Invalid { offset: self.base + at, field, problem: problem.into() }
    }

    fn take(&mut self, n: usize, field: &str) -> Result<&'a [u8], StateError> {
        let left = self.bytes.len() - self.pos;
        if n > left {
            return Err(self.invalid(self.pos, field, format!("needs {n} bytes, {left} are left")));
        }
        let s = &self.bytes[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    fn array<const N: usize>(&mut self, field: &str) -> Result<[u8; N], StateError> {
        let mut a = [0; N];
        a.copy_from_slice(self.take(N, field)?);
        Ok(a)
    }

    fn u8(&mut self, field: &str) -> Result<u8, StateError> {
        Ok(self.array::<1>(field)?[0])
    }
    fn u32(&mut self, field: &str) -> Result<u32, StateError> {
        Ok(u32::from_le_bytes(self.array(field)?))
    }
    fn u64(&mut self, field: &str) -> Result<u64, StateError> {
        Ok(u64::from_le_bytes(self.array(field)?))
    }

    /// A flag: 0 or 1.
    fn flag(&mut self, field: &str) -> Result<bool, StateError> {
        let at = self.pos;
        match self.u8(field)? {
            0 => Ok(false),
            1 => Ok(true),
            x => Err(self.invalid(at, field, format!("{x} where 0 (absent) or 1 (present) belongs"))),
        }
    }

    /// A finite f64.
    fn f64(&mut self, field: &str) -> Result<f64, StateError> {
        let at = self.pos;
        let x = f64::from_bits(self.u64(field)?);
        if !x.is_finite() {
            return Err(self.invalid(at, field, format!("{x} is not finite")));
        }
        Ok(x)
    }

    /// `N` finite f32.
    fn floats<const N: usize>(&mut self, field: &str) -> Result<[f32; N], StateError> {
        let at = self.pos;
        let mut a = [0.0; N];
        for x in &mut a {
            *x = f32::from_bits(self.u32(field)?);
        }
        if !a.iter().all(|x| x.is_finite()) {
            let problem = match a.as_slice() {
                [x] => format!("{x} is not finite"),
                _ => format!("{a:?}: not all finite"),
            };
            return Err(self.invalid(at, field, problem));
        }
        Ok(a)
    }

    fn f32(&mut self, field: &str) -> Result<f32, StateError> {
        Ok(self.floats::<1>(field)?[0])
    }

    /// A finite f32 above zero.
    fn positive(&mut self, field: &str) -> Result<f32, StateError> {
        let at = self.pos;
        let x = self.f32(field)?;
        if x <= 0.0 {
            return Err(self.invalid(at, field, format!("{x} is not positive")));
        }
        Ok(x)
    }

    /// A count or length, within the bytes left when each item takes at
    /// least `min_bytes`.
    fn count(&mut self, field: &str, min_bytes: usize) -> Result<usize, StateError> {
        let at = self.pos;
        let n = self.u32(field)? as usize;
        let left = self.bytes.len() - self.pos;
        if n.saturating_mul(min_bytes) > left {
            return Err(self.invalid(at, field, format!("{n} items cannot fit in the {left} bytes left")));
        }
        Ok(n)
    }

    fn string(&mut self, field: &str) -> Result<String, StateError> {
        let n = self.count(field, 1)?;
        let at = self.pos;
        let b = self.take(n, field)?;
        String::from_utf8(b.to_vec()).map_err(|e| self.invalid(at, field, format!("not UTF-8: {e}")))
    }

    /// A pose: a finite position and a unit quaternion.
    fn pose(&mut self, field: &str) -> Result<Pose, StateError> {
        let at = self.pos;
        let position = Vec3::from_array(self.floats(field)?);
        let rotation = Quat::from_array(self.floats(field)?);
        if (rotation.length() - 1.0).abs() > 1e-3 {
            return Err(self.invalid(at, field, format!("rotation {rotation} is not a unit quaternion")));
        }
        Ok(Pose::new(position, rotation))
    }

    fn vec3(&mut self, field: &str) -> Result<Vec3, StateError> {
        Ok(Vec3::from_array(self.floats(field)?))
    }
}

/// Bytes of a body's record when its strings are empty and it has nothing
/// optional: for bounding a count by the bytes left.
const MIN_BODY_BYTES: usize = 4 + 4 + 1 + 4 + 1 + 28 + 1 + 8 + 1 + 1;
/// Bytes of a projectile's record at the least.
const MIN_SPAWN_BYTES: usize = 8 + 4 + 28 + 12 + 1 + 4 + 16 + 1;

impl Simulation {
    /// The simulation as the bytes of a state file, with `run`: see the
    /// [module](crate::state) and [`Simulation::resume`].
    pub fn save_state(&self, run: &RunInfo) -> Vec<u8> {
        let mut w = Writer(Vec::new());
        w.bytes(run.scene.as_bytes());
        w.u8(run.camera.is_some() as u8);
        if let Some(c) = &run.camera {
            w.option_floats(c.eye);
            w.option_floats(c.target);
            w.f32(c.fov_deg);
        }
        w.f64(self.world.time());
        w.f32(self.dt);
        w.f32(self.seconds);
        let world = self.world.snapshot();
        w.u64(world.len() as u64);
        w.0.extend_from_slice(&world);
        w.len(self.bodies.len());
        for b in &self.bodies {
            write_body(&mut w, b, &self.world);
        }
        w.len(self.pending.len());
        for s in &self.pending {
            w.f64(s.time);
            w.len(s.index);
            let l = &s.launch;
            w.pose(&l.pose);
            w.floats(l.velocity.to_array());
            write_shape(&mut w, &l.shape);
            let m = &l.material;
            w.floats([m.density, m.friction, m.restitution, m.rolling_resistance]);
            w.option_floats(m.strength.map(|s| [s.tensile, s.shear]));
        }
        w.u8(run.frame.is_some() as u8);
        if let Some(f) = &run.frame {
            w.u32(f.fps);
            w.u64(f.index);
            let n = f.positions.len().min(f.rotations.len());
            w.len(n);
            for (p, q) in f.positions.iter().zip(&f.rotations) {
                w.floats(*p);
                w.floats(*q);
            }
        }
        let contents = w.0;
        let mut out = Vec::with_capacity(STATE_HEADER_BYTES + contents.len());
        out.extend_from_slice(&STATE_MAGIC);
        out.extend_from_slice(&STATE_VERSION.to_le_bytes());
        out.extend_from_slice(&(contents.len() as u64).to_le_bytes());
        out.extend_from_slice(&checksum(&contents).to_le_bytes());
        out.extend_from_slice(&contents);
        out
    }

    /// The simulation and run info of a state file's `bytes`, as
    /// [`save_state`](Self::save_state) wrote them: stepped on, it
    /// continues as the saved simulation would have. The world runs on
    /// its default threads. Refused with the byte and field at fault when
    /// anything is wrong (see the [module](crate::state)).
    pub fn resume(bytes: &[u8]) -> Result<(Simulation, RunInfo), StateError> {
        let contents = check_header(bytes)?;
        let mut r = Reader { bytes: contents, pos: 0, base: STATE_HEADER_BYTES, context: String::new() };
        let scene = r.string("scene name")?;
        let camera = if r.flag("camera")? {
            let eye = if r.flag("camera eye")? { Some(r.floats("camera eye")?) } else { None };
            let target = if r.flag("camera target")? { Some(r.floats("camera target")?) } else { None };
            let at = r.pos;
            let fov_deg = r.f32("camera field of view")?;
            if !(1.0..=170.0).contains(&fov_deg) {
                return Err(r.invalid(at, "camera field of view", format!("{fov_deg} degrees is not 1 to 170")));
            }
            Some(CameraSpec { eye, target, fov_deg })
        } else {
            None
        };
        let at = r.pos;
        let time = r.f64("time")?;
        if time < 0.0 {
            return Err(r.invalid(at, "time", format!("{time} s is negative")));
        }
        let dt = r.positive("step")?;
        let seconds = r.positive("scene's seconds")?;
        let at = r.pos;
        let n = r.u64("world's snapshot length")?;
        let left = contents.len() - r.pos;
        if n > left as u64 {
            return Err(r.invalid(at, "world's snapshot length", format!("{n} bytes, {left} are left")));
        }
        let world_at = r.pos;
        let world_bytes = r.take(n as usize, "world's snapshot")?;

        let count = r.count("body count", MIN_BODY_BYTES)?;
        let mut bodies: Vec<BodyInfo> = Vec::new();
        // Where each body's handle was read, and its slot in the world.
        let mut slots: Vec<(usize, usize, u32)> = Vec::new();
        let mut names = HashSet::new();
        for i in 0..count {
            r.context = format!("body {i}");
            let at = r.pos;
            let name = r.string("name")?;
            if !names.insert(name.clone()) {
                return Err(r.invalid(at, "name", format!("`{name}` names an earlier body too")));
            }
            r.context = format!("body {i} (`{name}`)");
            let source = r.string("source")?;
            let shape = read_body_shape(&mut r)?;
            let at = r.pos;
            let flags = r.u8("flags")?;
            if flags > 3 {
                return Err(r.invalid(
                    at,
                    "flags",
                    format!("{flags:#04x}: only bits 0 (static) and 1 (metal) mean something"),
                ));
            }
            let initial = r.pose("initial pose")?;
            if r.flag("handle")? {
                let at = r.pos;
                slots.push((at, i, r.u32("handle")?));
            }
            let at = r.pos;
            let spawn_time = r.f64("spawn time")?;
            if spawn_time < 0.0 {
                return Err(r.invalid(at, "spawn time", format!("{spawn_time} s is negative")));
            }
            let parent = if r.flag("parent")? {
                let at = r.pos;
                let p = r.u32("parent")? as usize;
                if p >= i {
                    return Err(r.invalid(at, "parent", format!("body {p} is not an earlier body")));
                }
                Some((p, r.pose("pose in its parent")?))
            } else {
                None
            };
            let despawn =
                if r.flag("broke")? { Some((r.f64("time it broke")?, r.pose("pose it broke at")?)) } else { None };
            let is_static = flags & 1 != 0;
            let metal = flags & 2 != 0;
            bodies.push(BodyInfo {
                name,
                shape,
                is_static,
                source,
                initial,
                handle: None,
                spawn_time,
                metal,
                parent,
                despawn,
            });
        }

        r.context = String::new();
        let count = r.count("projectile count", MIN_SPAWN_BYTES)?;
        let mut pending: Vec<ScheduledSpawn> = Vec::new();
        let mut waiting = HashSet::new();
        for k in 0..count {
            r.context = format!("projectile {k}");
            let at = r.pos;
            let time = r.f64("launch time")?;
            if pending.last().is_some_and(|s| s.time > time) {
                return Err(r.invalid(at, "launch time", format!("{time} s is before the launch before it")));
            }
            let at = r.pos;
            let index = r.u32("body")? as usize;
            let Some(body) = bodies.get(index) else {
                return Err(r.invalid(at, "body", format!("body {index} of {}", bodies.len())));
            };
            if slots.iter().any(|&(_, i, _)| i == index) || body.despawn.is_some() || !waiting.insert(index) {
                let msg = format!("body {index} (`{}`) is not waiting to be launched", body.name);
                return Err(r.invalid(at, "body", msg));
            }
            let pose = r.pose("launch pose")?;
            let velocity = r.vec3("launch velocity")?;
            let shape = read_shape(&mut r)?;
            let at = r.pos;
            let [density, friction, restitution, rolling_resistance] = r.floats("material")?;
            let strength = if r.flag("material strength")? {
                let [tensile, shear] = r.floats("material strength")?;
                Some(Strength { tensile, shear })
            } else {
                None
            };
            let material = Material { density, friction, restitution, rolling_resistance, strength };
            if let Err(e) = material.validate() {
                return Err(r.invalid(at, "material", e.to_string()));
            }
            if let Err(e) = crumble::mass::check_shape(&shape, density) {
                return Err(r.invalid(at, "material", format!("the body cannot be simulated: {e}")));
            }
            pending.push(ScheduledSpawn { time, index, launch: Launch { pose, velocity, shape, material } });
        }

        r.context = String::new();
        let frame = if r.flag("sampled frame")? {
            let at = r.pos;
            let fps = r.u32("sampled frame's rate")?;
            if fps == 0 {
                return Err(r.invalid(at, "sampled frame's rate", "0 frames per second"));
            }
            let at = r.pos;
            let index = r.u64("sampled frame's number")?;
            if index as f64 / fps as f64 > time + dt as f64 {
                let msg = format!("frame {index} at {fps} fps is after the state's time, {time} s");
                return Err(r.invalid(at, "sampled frame's number", msg));
            }
            let at = r.pos;
            let n = r.count("sampled frame's body count", 28)?;
            if n > bodies.len() {
                let msg = format!("{n} bodies, of {} in the state", bodies.len());
                return Err(r.invalid(at, "sampled frame's body count", msg));
            }
            let (mut positions, mut rotations) = (Vec::with_capacity(n), Vec::with_capacity(n));
            for i in 0..n {
                r.context = format!("sampled frame, body {i}");
                positions.push(r.floats("position")?);
                rotations.push(r.floats("rotation")?);
            }
            r.context = String::new();
            Some(SampledFrame { fps, index, positions, rotations })
        } else {
            None
        };
        if r.pos != contents.len() {
            return Err(r.invalid(r.pos, "end", format!("{} bytes follow the last field", contents.len() - r.pos)));
        }

        // Only now, with everything else read, is the world rebuilt.
        let world_offset = STATE_HEADER_BYTES + world_at;
        let world = World::restore(world_bytes)
            .map_err(|e| StateError::World { offset: world_offset, message: e.to_string() })?;
        let world_fault = |message: String| StateError::World { offset: world_offset, message };
        if world.time().to_bits() != time.to_bits() {
            return Err(world_fault(format!("it is at {} s, the state at {time} s", world.time())));
        }
        let live: HashMap<u32, BodyHandle> = world.bodies().map(|(h, _)| (h.index(), h)).collect();
        // Each slot's body in the list.
        let mut taken: HashMap<u32, usize> = HashMap::new();
        for &(at, i, slot) in &slots {
            let problem = match (live.get(&slot), taken.get(&slot)) {
                (None, _) => Some(format!("slot {slot} holds no body in the world")),
                (_, Some(j)) => Some(format!("slot {slot} is body {j}'s too")),
                _ if bodies[i].despawn.is_some() => Some(format!("the body broke, yet has slot {slot} in the world")),
                (Some(&h), None) => {
                    bodies[i].handle = Some(h);
                    taken.insert(slot, i);
                    None
                }
            };
            if let Some(problem) = problem {
                let field = format!("body {i} (`{}`): handle", bodies[i].name);
                return Err(StateError::Invalid { offset: STATE_HEADER_BYTES + at, field, problem });
            }
        }
        if taken.len() != world.body_count() {
            return Err(world_fault(format!(
                "it holds {} bodies, and the state's list {} of them",
                world.body_count(),
                taken.len()
            )));
        }
        let sim = Simulation { world, bodies, pending, dt, seconds };
        Ok((sim, RunInfo { scene, camera, frame }))
    }
}

/// The contents after a checked header.
fn check_header(bytes: &[u8]) -> Result<&[u8], StateError> {
    if bytes.is_empty() {
        return Err(StateError::Empty);
    }
    let magic = &STATE_MAGIC[..bytes.len().min(16)];
    if !bytes.starts_with(magic) {
        return Err(StateError::NotState(what_it_looks_like(bytes)));
    }
    if bytes.len() < STATE_HEADER_BYTES {
        return Err(StateError::TruncatedHeader(bytes.len()));
    }
    let field = |a: usize, b: usize| &bytes[a..b];
    let version = u32::from_le_bytes(field(16, 20).try_into().unwrap_or_default());
    if version != STATE_VERSION {
        return Err(StateError::Version(version));
    }
    let expected = u64::from_le_bytes(field(20, 28).try_into().unwrap_or_default());
    let sum = u64::from_le_bytes(field(28, 36).try_into().unwrap_or_default());
    let contents = &bytes[STATE_HEADER_BYTES..];
    let found = contents.len() as u64;
    if found < expected {
        return Err(StateError::Truncated { expected, found });
    }
    if found > expected {
        return Err(StateError::Trailing(found - expected));
    }
    let actual = checksum(contents);
    if actual != sum {
        return Err(StateError::Checksum { expected: sum, found: actual });
    }
    Ok(contents)
}

/// A guess at what a file that is not a state file is, for the message.
fn what_it_looks_like(bytes: &[u8]) -> String {
    let kind = if bytes.starts_with(b"glTF") {
        Some("a glTF binary, `.glb`")
    } else if bytes.starts_with(b"\x89PNG") {
        Some("a PNG image")
    } else if bytes.starts_with(b"GIF8") {
        Some("a GIF")
    } else if bytes.get(4..8) == Some(b"ftyp") {
        Some("an MP4 video")
    } else if bytes.starts_with(b"frame,t,body") {
        Some("crumble's CSV output")
    } else if bytes.starts_with(b"{") {
        Some("JSON")
    } else if std::str::from_utf8(&bytes[..bytes.len().min(256)]).is_ok() {
        Some("text: a scene file is run with `crumble run`")
    } else {
        None
    };
    let start = "it does not begin with the 16 bytes every state file begins with";
    match kind {
        Some(k) => format!("{start}; it looks like {k}"),
        None => start.to_string(),
    }
}

fn write_body(w: &mut Writer, b: &BodyInfo, world: &World) {
    w.bytes(b.name.as_bytes());
    w.bytes(b.source.as_bytes());
    match b.shape {
        BodyShape::Box { half_extents } => {
            w.u8(0);
            w.floats(half_extents.to_array());
        }
        BodyShape::Sphere { radius } => {
            w.u8(1);
            w.f32(radius);
        }
        BodyShape::Plane { height } => {
            w.u8(2);
            w.f32(height);
        }
    }
    w.u8(b.is_static as u8 | (b.metal as u8) << 1);
    w.pose(&b.initial);
    // A body that broke keeps its handle, which the world no longer holds.
    match b.handle.filter(|&h| world.body(h).is_some()) {
        Some(h) => {
            w.u8(1);
            w.u32(h.index());
        }
        None => w.u8(0),
    }
    w.f64(b.spawn_time);
    w.u8(b.parent.is_some() as u8);
    if let Some((p, pose)) = &b.parent {
        w.len(*p);
        w.pose(pose);
    }
    w.u8(b.despawn.is_some() as u8);
    if let Some((t, pose)) = &b.despawn {
        w.f64(*t);
        w.pose(pose);
    }
}

fn read_body_shape(r: &mut Reader) -> Result<BodyShape, StateError> {
    let at = r.pos;
    Ok(match r.u8("shape")? {
        0 => {
            let h = r.floats("half extents")?;
            if !h.iter().all(|&x| x > 0.0) {
                return Err(r.invalid(at + 1, "half extents", format!("{h:?}: not all positive")));
            }
            BodyShape::Box { half_extents: Vec3::from_array(h) }
        }
        1 => BodyShape::Sphere { radius: r.positive("radius")? },
        2 => BodyShape::Plane { height: r.f32("height")? },
        x => return Err(r.invalid(at, "shape", format!("{x}: not 0 (box), 1 (sphere) or 2 (plane)"))),
    })
}

/// A projectile's collider shape: a box or a ball.
fn write_shape(w: &mut Writer, shape: &Shape) {
    match shape {
        Shape::Cuboid(c) => {
            w.u8(0);
            w.floats(c.half_extents().to_array());
        }
        Shape::Ball(b) => {
            w.u8(1);
            w.f32(b.radius());
        }
        // A scene's projectile is a box or a ball; a half-space is written
        // as a shape `read_shape` refuses.
        Shape::HalfSpace(_) => w.u8(2),
    }
}

fn read_shape(r: &mut Reader) -> Result<Shape, StateError> {
    let at = r.pos;
    let shape = match r.u8("shape")? {
        0 => Shape::cuboid(r.vec3("half extents")?),
        1 => Shape::ball(r.f32("radius")?),
        x => return Err(r.invalid(at, "shape", format!("{x}: not 0 (box) or 1 (ball)"))),
    };
    shape.map_err(|e| r.invalid(at + 1, "shape", e.to_string()))
}
