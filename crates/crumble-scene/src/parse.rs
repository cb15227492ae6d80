//! Reading a scene file and checking every value before anything is built.

use crate::error::{at_path, deep_dotted_key, line_column, path_at, KeyPath, SceneError, MAX_KEY_PARTS};
use crate::spec::{JointKindSpec, JointSpec, Scene, ShapeKind, WreckingBallSpec};

/// The name that stands for the world (a fixed frame) on either side of a
/// `[[joint]]`; no body may take it.
pub(crate) const WORLD: &str = "world";

/// The mortars every scene knows (`[mortars.NAME]` adds others).
pub const BUILTIN_MORTARS: [&str; 2] = ["lime", "cement"];

/// Most bodies a scene may generate (keeps a typo from eating the memory:
/// a million boxes take about 2.3 GB and 13 s a step).
pub const MAX_BODIES: u64 = 1_000_000;

/// Longest run, seconds of simulated time: an hour covers any demolition,
/// and with [`MAX_STEPS`] it bounds how long a run can take.
pub const MAX_SECONDS: f64 = 3600.0;

/// Most steps in one run: an hour at 1/2000 s steps fits (7.2 million).
/// The cheapest step (one ball) takes about 3 µs, so a run of a few bodies
/// ends within about half a minute, where `dt = 1e-9` would run 3 s of
/// simulated time for hours (3e9 steps).
pub const MAX_STEPS: u64 = 10_000_000;

/// Steps of `dt` seconds that cover `seconds` (at least one; the last may
/// end past `seconds` by less than a step). Saturates at `u64::MAX`.
pub fn step_count(seconds: f64, dt: f32) -> u64 {
    (seconds / dt as f64 - 1e-9).ceil().max(1.0) as u64
}

/// The text of a scene file read as `bytes`. A file that is not UTF-8 is
/// refused with the line and column of its first bad byte.
pub fn decode(bytes: Vec<u8>, file_name: &str) -> Result<String, SceneError> {
    String::from_utf8(bytes).map_err(|e| {
        let valid = e.utf8_error().valid_up_to();
        let bytes = e.as_bytes();
        let before = std::str::from_utf8(&bytes[..valid]).unwrap_or_default();
        let (line, column) = line_column(before, valid);
        let message = format!("not UTF-8 text: byte 0x{:02x} at byte offset {valid}", bytes[valid]);
        SceneError { file: file_name.into(), line, column, key: String::new(), message }
    })
}

/// Parses and validates a scene. `file_name` is only used in messages.
pub fn parse(text: &str, file_name: &str) -> Result<Scene, SceneError> {
    let mut scene: Scene = toml::from_str(text).map_err(|e| {
        let mut message = e.message().trim().to_string();
        let (line, column, key) = match e.span() {
            Some(span) => {
                let (line, column) = line_column(text, span.start);
                (line, column, path_at(text, span.start).to_string())
            }
            // The reader gives no position for a dotted key nested past its
            // limit ("recursion limit"); find the key.
            None => match deep_dotted_key(text) {
                Some((offset, parts)) => {
                    let (line, column) = line_column(text, offset);
                    message = format!(
                        "a dotted key of {parts} parts is nested too deeply: at most {MAX_KEY_PARTS} ({message})"
                    );
                    (line, column, String::new())
                }
                None => (0, 0, String::new()),
            },
        };
        SceneError { file: file_name.into(), line, column, key, message }
    })?;
    scene.file = file_name.into();
    scene.source = text.into();
    validate(&scene)?;
    Ok(scene)
}

/// Checks the values serde could not: finite numbers, positive sizes,
/// known materials, one orientation, and so on.
pub fn validate(scene: &Scene) -> Result<(), SceneError> {
    let v = Validator { scene };
    v.run()
}

struct Validator<'a> {
    scene: &'a Scene,
}

type Check = Result<(), SceneError>;

impl Validator<'_> {
    fn err(&self, path: &KeyPath, msg: impl Into<String>) -> SceneError {
        at_path(&self.scene.file, &self.scene.source, path, msg)
    }

    fn finite(&self, path: &KeyPath, values: &[f32]) -> Check {
        if let Some(x) = values.iter().find(|x| !x.is_finite()) {
            return Err(self.err(path, format!("must be a finite number, got {x}")));
        }
        Ok(())
    }

    fn positive(&self, path: &KeyPath, values: &[f32]) -> Check {
        self.finite(path, values)?;
        if let Some(x) = values.iter().find(|x| **x <= 0.0) {
            return Err(self.err(path, format!("must be positive, got {x}")));
        }
        Ok(())
    }

    /// A box's full edge lengths: positive, and each still positive when
    /// halved (the engine's boxes are made from half extents, and in `f32`
    /// half of the smallest subnormal is zero).
    fn box_size(&self, path: &KeyPath, size: &[f32]) -> Check {
        self.positive(path, size)?;
        if let Some(x) = size.iter().find(|x| **x * 0.5 <= 0.0) {
            return Err(self.err(path, format!("is too small: half of {x} m is zero in 32-bit floats")));
        }
        Ok(())
    }

    fn non_negative(&self, path: &KeyPath, value: f32) -> Check {
        self.finite(path, &[value])?;
        if value < 0.0 {
            return Err(self.err(path, format!("must not be negative, got {value}")));
        }
        Ok(())
    }

    fn at_least_one(&self, path: &KeyPath, n: u32) -> Check {
        if n == 0 {
            return Err(self.err(path, "must be at least 1"));
        }
        Ok(())
    }

    /// Adds the `made` bodies of the table at `path` to the running `total`,
    /// refusing the table that takes the scene over [`MAX_BODIES`]. Each
    /// table is checked as it is added, so the sum never exceeds
    /// `MAX_BODIES` plus one table's count (below 2^64: the largest table,
    /// a wall of 2^32 − 1 rows of 2^32 − 1 bricks, makes under 2^64 − 2^32).
    fn count(&self, path: &KeyPath, made: u64, total: &mut u64) -> Check {
        match total.checked_add(made) {
            Some(t) if t <= MAX_BODIES => {
                *total = t;
                Ok(())
            }
            sum => {
                let sum = sum.map_or_else(|| "more than 2^64".to_string(), |t| t.to_string());
                let brings = if *total == 0 { String::new() } else { format!(", which brings the scene to {sum}") };
                let msg = format!(
                    "makes {made} bodies{brings}; a scene makes at most {MAX_BODIES} (the limit keeps a typo \
                     from exhausting memory)"
                );
                Err(self.err(path, msg))
            }
        }
    }

    fn material(&self, path: &KeyPath, name: &str) -> Check {
        if self.scene.materials.contains_key(name) || ["default", "brick", "steel"].contains(&name) {
            return Ok(());
        }
        let mut known: Vec<&str> = vec!["default", "brick", "steel"];
        known.extend(self.scene.materials.keys().map(String::as_str));
        Err(self.err(path, format!("unknown material `{name}` (known: {})", known.join(", "))))
    }

    fn mortar(&self, path: &KeyPath, name: &str) -> Check {
        if self.scene.mortars.contains_key(name) || BUILTIN_MORTARS.contains(&name) {
            return Ok(());
        }
        let mut known: Vec<&str> = BUILTIN_MORTARS.to_vec();
        known.extend(self.scene.mortars.keys().map(String::as_str).filter(|n| !BUILTIN_MORTARS.contains(n)));
        Err(self.err(path, format!("unknown mortar `{name}` (known: {})", known.join(", "))))
    }

    fn run(&self) -> Check {
        let s = self.scene;
        let w = KeyPath::key("world");
        self.finite(&w.join("gravity"), &s.world.gravity)?;
        self.positive(&w.join("dt"), &[s.world.dt])?;
        if s.world.dt > 1.0 {
            return Err(self.err(&w.join("dt"), format!("must be at most 1 s, got {}", s.world.dt)));
        }
        if !(1..=64).contains(&s.world.substeps) {
            return Err(self.err(&w.join("substeps"), format!("must be 1 to 64, got {}", s.world.substeps)));
        }
        self.positive(&w.join("seconds"), &[s.world.seconds])?;
        self.positive(&w.join("min_piece"), &[s.world.min_piece])?;
        if s.world.max_new_pieces > 4096 {
            let msg = format!("must be at most 4096, got {}", s.world.max_new_pieces);
            return Err(self.err(&w.join("max_new_pieces"), msg));
        }
        if s.world.seconds as f64 > MAX_SECONDS {
            let msg = format!("must be at most {MAX_SECONDS} s (the longest run), got {}", s.world.seconds);
            return Err(self.err(&w.join("seconds"), msg));
        }
        let steps = step_count(s.world.seconds as f64, s.world.dt);
        if steps > MAX_STEPS {
            let msg = format!(
                "{} s steps over `world.seconds` = {} s make {steps} steps; a run takes at most {MAX_STEPS} \
                 (so that it ends in reasonable time): use a larger dt or fewer seconds",
                s.world.dt, s.world.seconds
            );
            return Err(self.err(&w.join("dt"), msg));
        }
        if let Some(g) = &s.world.ground {
            let p = w.join("ground");
            self.finite(&p.join("height"), &[g.height])?;
            self.material(&p.join("material"), &g.material)?;
        }
        for (name, m) in &s.materials {
            let p = KeyPath::key("materials").join(name);
            self.positive(&p.join("density"), &[m.density])?;
            self.non_negative(&p.join("friction"), m.friction)?;
            self.non_negative(&p.join("restitution"), m.restitution)?;
            self.non_negative(&p.join("rolling_resistance"), m.rolling_resistance)?;
            if m.restitution > 1.0 {
                return Err(self.err(&p.join("restitution"), format!("must be at most 1, got {}", m.restitution)));
            }
            match (m.tensile_strength, m.shear_strength) {
                (Some(t), Some(sh)) => {
                    self.positive(&p.join("tensile_strength"), &[t])?;
                    self.positive(&p.join("shear_strength"), &[sh])?;
                }
                (Some(_), None) => {
                    return Err(self.err(&p.join("tensile_strength"), "a breakable material needs `shear_strength` too"))
                }
                (None, Some(_)) => {
                    return Err(self.err(&p.join("shear_strength"), "a breakable material needs `tensile_strength` too"))
                }
                (None, None) => {}
            }
        }
        for (name, m) in &s.mortars {
            let p = KeyPath::key("mortars").join(name);
            self.non_negative(&p.join("tensile_strength"), m.tensile_strength)?;
            self.non_negative(&p.join("shear_strength"), m.shear_strength)?;
            self.non_negative(&p.join("friction"), m.friction)?;
        }
        let mut total: u64 = 0;
        for (i, b) in s.body.iter().enumerate() {
            let p = KeyPath::item("body", i);
            self.shape(&p, b.shape, b.size, b.half_extents, b.radius)?;
            self.finite(&p.join("position"), &b.position)?;
            self.finite(&p.join("velocity"), &b.velocity)?;
            self.finite(&p.join("angular_velocity"), &b.angular_velocity)?;
            if let Some(aa) = &b.axis_angle {
                let q = p.join("axis_angle");
                self.finite(&q.join("axis"), &aa.axis)?;
                self.finite(&q.join("degrees"), &[aa.degrees])?;
                if aa.axis.iter().map(|x| x * x).sum::<f32>() < 1e-12 {
                    return Err(self.err(&q.join("axis"), "must not be zero"));
                }
                if b.quaternion.is_some() {
                    return Err(self.err(&p.join("quaternion"), "give either `axis_angle` or `quaternion`, not both"));
                }
            }
            if let Some(q) = &b.quaternion {
                self.finite(&p.join("quaternion"), q)?;
                if q.iter().map(|x| x * x).sum::<f32>() < 1e-12 {
                    return Err(self.err(&p.join("quaternion"), "must not be zero"));
                }
            }
            self.material(&p.join("material"), &b.material)?;
            self.count(&p, 1, &mut total)?;
        }
        for (i, wl) in s.wall.iter().enumerate() {
            let p = KeyPath::item("wall", i);
            self.at_least_one(&p.join("rows"), wl.rows)?;
            self.at_least_one(&p.join("bricks_per_row"), wl.bricks_per_row)?;
            self.box_size(&p.join("brick"), &wl.brick)?;
            self.non_negative(&p.join("gap"), wl.gap)?;
            if wl.gap >= wl.brick[0] {
                return Err(self.err(&p.join("gap"), "must be smaller than the brick's length"));
            }
            self.finite(&p.join("position"), &wl.position)?;
            self.finite(&p.join("facing"), &wl.facing)?;
            if wl.facing[0].hypot(wl.facing[2]) < 1e-6 {
                return Err(self.err(&p.join("facing"), "needs a horizontal (x or z) part"));
            }
            self.material(&p.join("material"), &wl.material)?;
            if let Some(m) = &wl.mortar {
                self.mortar(&p.join("mortar"), m)?;
                // Bonds glue faces that touch: at most a millimetre apart,
                // or 2% of the brick's smallest half extent if that is less
                // (`crumble::World::insert_bond`).
                let touch = (0.01 * wl.brick.iter().fold(f32::INFINITY, |a, &b| a.min(b))).min(1e-3);
                if wl.gap > touch {
                    let msg = format!(
                        "a mortared wall's bricks must touch: a gap of at most {touch} m (the mortar is a \
                         bond between touching faces, not a layer), got {}",
                        wl.gap
                    );
                    return Err(self.err(&p.join("gap"), msg));
                }
            }
            self.non_negative(&p.join("density_jitter"), wl.density_jitter)?;
            if wl.density_jitter >= 1.0 {
                let msg = format!("must be below 1 (a brick's density stays positive), got {}", wl.density_jitter);
                return Err(self.err(&p.join("density_jitter"), msg));
            }
            self.non_negative(&p.join("strength_jitter"), wl.strength_jitter)?;
            if wl.strength_jitter > 1.0 {
                return Err(
                    self.err(&p.join("strength_jitter"), format!("must be at most 1, got {}", wl.strength_jitter))
                );
            }
            self.count(&p, wl.brick_count(), &mut total)?;
        }
        for (i, py) in s.pyramid.iter().enumerate() {
            let p = KeyPath::item("pyramid", i);
            self.at_least_one(&p.join("base"), py.base)?;
            self.box_size(&p.join("size"), &py.size)?;
            self.non_negative(&p.join("gap"), py.gap)?;
            self.finite(&p.join("position"), &py.position)?;
            self.material(&p.join("material"), &py.material)?;
            self.count(&p, py.box_count(), &mut total)?;
        }
        for (i, st) in s.stack.iter().enumerate() {
            let p = KeyPath::item("stack", i);
            self.at_least_one(&p.join("count"), st.count)?;
            self.box_size(&p.join("size"), &st.size)?;
            self.finite(&p.join("offset"), &st.offset)?;
            self.finite(&p.join("position"), &st.position)?;
            self.material(&p.join("material"), &st.material)?;
            self.count(&p, st.count as u64, &mut total)?;
        }
        for (i, wb) in s.wrecking_ball.iter().enumerate() {
            self.wrecking_ball(&KeyPath::item("wrecking_ball", i), wb)?;
            self.count(&KeyPath::item("wrecking_ball", i), wb.body_count(), &mut total)?;
        }
        for (i, pr) in s.projectile.iter().enumerate() {
            let p = KeyPath::item("projectile", i);
            self.shape(&p, pr.shape, pr.size, None, pr.radius)?;
            self.finite(&p.join("from"), &pr.from)?;
            self.non_negative(&p.join("at"), pr.at)?;
            match (pr.velocity, pr.target, pr.speed) {
                (Some(v), None, None) => self.finite(&p.join("velocity"), &v)?,
                (None, Some(t), Some(speed)) => {
                    self.finite(&p.join("target"), &t)?;
                    self.positive(&p.join("speed"), &[speed])?;
                    let d: f32 = t.iter().zip(&pr.from).map(|(a, b)| (a - b) * (a - b)).sum();
                    if d < 1e-12 {
                        return Err(self.err(&p.join("target"), "must differ from `from`"));
                    }
                }
                _ => return Err(self.err(&p, "give either `velocity`, or `target` and `speed`")),
            }
            self.material(&p.join("material"), &pr.material)?;
            self.count(&p, 1, &mut total)?;
        }
        for (i, j) in s.joint.iter().enumerate() {
            self.joint(&KeyPath::item("joint", i), j)?;
        }
        for (i, b) in s.bond.iter().enumerate() {
            let p = KeyPath::item("bond", i);
            self.mortar(&p.join("mortar"), &b.mortar)?;
            if b.a == b.b {
                return Err(self.err(&p.join("b"), format!("a body cannot be bonded to itself (`{}`)", b.b)));
            }
        }
        if let Some(c) = &s.camera {
            let p = KeyPath::key("camera");
            if let Some(eye) = &c.eye {
                self.finite(&p.join("eye"), eye)?;
            }
            if let Some(target) = &c.target {
                self.finite(&p.join("target"), target)?;
            }
            if let (Some(eye), Some(target)) = (c.eye, c.target) {
                let d: f32 = eye.iter().zip(&target).map(|(a, b)| (a - b) * (a - b)).sum();
                if d < 1e-12 {
                    return Err(self.err(&p.join("target"), "must differ from `eye`"));
                }
            }
            self.finite(&p.join("fov_deg"), &[c.fov_deg])?;
            if !(1.0..=170.0).contains(&c.fov_deg) {
                return Err(self.err(&p.join("fov_deg"), format!("must be from 1 to 170 degrees, got {}", c.fov_deg)));
            }
        }
        Ok(())
    }

    fn wrecking_ball(&self, p: &KeyPath, wb: &WreckingBallSpec) -> Check {
        self.finite(&p.join("anchor"), &wb.anchor)?;
        self.at_least_one(&p.join("links"), wb.links)?;
        self.box_size(&p.join("link"), &wb.link)?;
        self.material(&p.join("link_material"), &wb.link_material)?;
        self.positive(&p.join("ball_radius"), &[wb.ball_radius])?;
        self.material(&p.join("ball_material"), &wb.ball_material)?;
        let angle = wb.release_angle_deg;
        self.finite(&p.join("release_angle_deg"), &[angle])?;
        if !(0.0..=180.0).contains(&angle) {
            return Err(self.err(&p.join("release_angle_deg"), format!("must be from 0 to 180 degrees, got {angle}")));
        }
        self.finite(&p.join("direction"), &wb.direction)?;
        if wb.direction[0].hypot(wb.direction[2]) < 1e-6 {
            return Err(self.err(&p.join("direction"), "needs a horizontal (x or z) part"));
        }
        Ok(())
    }

    /// A joint anchor: finite, and within the world's bound (where the
    /// engine takes bodies).
    fn anchor_point(&self, path: &KeyPath, point: &[f32; 3]) -> Check {
        self.finite(path, point)?;
        let bound = crumble::world::WORLD_BOUND;
        if let Some(x) = point.iter().find(|x| x.abs() > bound) {
            return Err(
                self.err(path, format!("must be within {bound:e} m of the origin (the world's bound), got {x}"))
            );
        }
        Ok(())
    }

    /// A break threshold: positive, `inf` for never.
    fn threshold(&self, path: &KeyPath, value: Option<f32>) -> Check {
        match value {
            Some(x) if x.is_nan() || x <= 0.0 => {
                Err(self.err(path, format!("must be positive (leave it out, or `inf`, for never), got {x}")))
            }
            _ => Ok(()),
        }
    }

    /// What `[[joint]]` can check without the bodies: its sides are two
    /// different things, its anchors are given once and finite, and each
    /// key it has belongs to its kind and is in range. The bodies' names
    /// are resolved when the scene is built.
    fn joint(&self, p: &KeyPath, j: &JointSpec) -> Check {
        let kind = j.kind.name();
        if j.a == j.b {
            let msg = if j.a == WORLD {
                "both sides are the world: a joint needs a body on one side".to_string()
            } else {
                format!("joins `{}` to itself: `a` and `b` must be different bodies", j.b)
            };
            return Err(self.err(&p.join("b"), msg));
        }
        let given: Vec<&str> = [
            ("anchor", j.anchor.is_some()),
            ("anchors", j.anchors.is_some()),
            ("local_anchors", j.local_anchors.is_some()),
        ]
        .iter()
        .filter(|(_, g)| *g)
        .map(|(k, _)| *k)
        .collect();
        if let [first, second, ..] = given[..] {
            let msg = format!("give one of `anchor`, `anchors` or `local_anchors`, not both `{first}` and `{second}`");
            return Err(self.err(&p.join(second), msg));
        }
        if let Some(a) = &j.anchor {
            self.anchor_point(&p.join("anchor"), a)?;
        }
        for (key, pair) in [("anchors", &j.anchors), ("local_anchors", &j.local_anchors)] {
            for (k, point) in pair.iter().flatten().enumerate() {
                self.anchor_point(&p.join(key).at(k), point)?;
            }
        }
        let revolute = j.kind == JointKindSpec::Revolute;
        match (&j.axis, revolute) {
            (Some(axis), true) => {
                self.finite(&p.join("axis"), axis)?;
                if axis.iter().map(|x| x * x).sum::<f32>() < 1e-12 {
                    return Err(self.err(&p.join("axis"), "must not be zero"));
                }
            }
            (None, true) => return Err(self.err(&p.join("kind"), "a revolute joint needs `axis`")),
            (Some(_), false) => {
                return Err(self.err(&p.join("axis"), format!("a {kind} joint has no `axis` (a revolute joint has)")))
            }
            (None, false) => {}
        }
        if let Some([lo, hi]) = j.limits_deg {
            let path = p.join("limits_deg");
            if !revolute {
                return Err(self.err(&path, format!("a {kind} joint has no limits (a revolute joint has)")));
            }
            self.finite(&path, &[lo, hi])?;
            if let Some(x) = [lo, hi].into_iter().find(|x| !(-180.0..=180.0).contains(x)) {
                return Err(self.err(&path, format!("must be from -180 to 180 degrees, got {x}")));
            }
            if lo > hi {
                return Err(self.err(&path, format!("are reversed: the lower limit {lo} is above the upper {hi}")));
            }
        }
        let has_length = matches!(j.kind, JointKindSpec::Distance | JointKindSpec::Rope);
        match (j.length, has_length) {
            (Some(length), true) => self.positive(&p.join("length"), &[length])?,
            (None, true) => return Err(self.err(&p.join("kind"), format!("a {kind} joint needs `length`"))),
            (Some(_), false) => {
                let msg = format!("a {kind} joint has no `length` (distance joints and ropes have)");
                return Err(self.err(&p.join("length"), msg));
            }
            (None, false) => {}
        }
        if let Some(spring) = &j.spring {
            let path = p.join("spring");
            if j.kind != JointKindSpec::Distance {
                return Err(self.err(&path, format!("a {kind} joint has no spring (a distance joint has)")));
            }
            self.non_negative(&path.join("hertz"), spring.hertz)?;
            self.non_negative(&path.join("damping_ratio"), spring.damping_ratio)?;
        }
        self.threshold(&p.join("break_force"), j.break_force)?;
        self.threshold(&p.join("break_torque"), j.break_torque)?;
        Ok(())
    }

    fn shape(
        &self,
        p: &KeyPath,
        kind: ShapeKind,
        size: Option<[f32; 3]>,
        half: Option<[f32; 3]>,
        radius: Option<f32>,
    ) -> Check {
        match kind {
            ShapeKind::Cuboid => {
                if radius.is_some() {
                    return Err(self.err(&p.join("radius"), "a box has `size` or `half_extents`, not `radius`"));
                }
                match (size, half) {
                    (Some(s), None) => self.box_size(&p.join("size"), &s),
                    (None, Some(h)) => self.positive(&p.join("half_extents"), &h),
                    (Some(_), Some(_)) => {
                        Err(self.err(&p.join("half_extents"), "give `size` or `half_extents`, not both"))
                    }
                    (None, None) => Err(self.err(&p.join("shape"), "a box needs `size` or `half_extents`")),
                }
            }
            ShapeKind::Sphere => {
                if size.is_some() || half.is_some() {
                    let key = if size.is_some() { "size" } else { "half_extents" };
                    return Err(self.err(&p.join(key), "a sphere has `radius`, not a box size"));
                }
                match radius {
                    Some(r) => self.positive(&p.join("radius"), &[r]),
                    None => Err(self.err(&p.join("shape"), "a sphere needs `radius`")),
                }
            }
        }
    }
}
