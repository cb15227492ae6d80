//! Persistent contacts between pairs of colliders, and the events the world
//! reports when two colliders begin or stop touching.

use std::collections::HashMap;
use std::hash::BuildHasherDefault;

use crate::body::BodyHandle;
use crate::collider::ColliderHandle;
#[cfg(test)]
use crate::collision::ContactPoint;
use crate::collision::{Manifold, MAX_MANIFOLD_POINTS};
use crate::edge_list::{self, Edge, Links};
use crate::math::{Pose, Quat, Vec3};
use glam::{Affine3A, Vec3A};

/// A fixed-key hasher: the same keys always land in the same order, so
/// nothing the world does depends on a random seed.
pub(crate) type FixedState = BuildHasherDefault<std::collections::hash_map::DefaultHasher>;

/// Whether a contact began or ended in the last step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ContactEventKind {
    /// The two colliders touch now and did not in the step before.
    Began,
    /// The two colliders touched in the step before and do not now (or one
    /// of them was removed).
    Ended,
}

/// A change in touching between two colliders during the last step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactEvent {
    /// Began or ended.
    pub kind: ContactEventKind,
    /// First collider of the pair.
    pub collider_a: ColliderHandle,
    /// Second collider of the pair.
    pub collider_b: ColliderHandle,
    /// Body of `collider_a`.
    pub body_a: BodyHandle,
    /// Body of `collider_b`.
    pub body_b: BodyHandle,
    /// Normal impulse (N·s) the pair exchanged during the step, over all
    /// its points and substeps: the momentum a hit transferred. 0 for
    /// `Ended`. A hard hit shows as a large impulse at `Began`; a brick
    /// settling on another shows about its weight times the step.
    pub normal_impulse: f32,
}

/// A pair of colliders whose fattened boxes overlap, with the manifold of
/// the last narrow phase and the impulses kept for warm starting.
///
/// The layout is fixed (`repr(C)`): what the per-step loops over the
/// active contacts read of each (its bodies, whether its manifold is
/// empty, its step impulse, its touching flag) comes first, in the first
/// 64 bytes with the manifold's normal and first point; the kept
/// impulses, the recycling cache and the list links follow.
#[derive(Clone, Debug)]
#[repr(C)]
pub(crate) struct Contact {
    pub body_a: u32,
    pub body_b: u32,
    pub collider_a: u32,
    pub collider_b: u32,
    /// Largest per-point accumulated normal impulse of the last step.
    pub max_normal_impulse: f32,
    /// Normal impulse the pair exchanged over the last step (all points).
    pub step_impulse: f32,
    pub touching: bool,
    /// Whether this step's manifold was recycled (see [`Contact::recycle`])
    /// rather than computed by the narrow phase.
    pub recycled: bool,
    /// Steps in a row that this contact was solved, saturating at 255; 0
    /// while its manifold is empty. A unit of mostly new contacts settles
    /// (`WorldSettings::settle_steps`).
    pub solved_steps: u8,
    pub manifold: Manifold,
    /// Accumulated normal impulse per manifold point (same order as points).
    pub normal_impulse: [f32; MAX_MANIFOLD_POINTS],
    /// Accumulated friction impulse of the whole manifold (applied at its
    /// centre), as a world vector so that it survives a change of tangent
    /// basis between steps.
    pub friction_impulse: Vec3,
    /// Accumulated twist-friction impulse about the normal (N·m·s).
    pub twist_impulse: f32,
    /// Accumulated rolling-resistance angular impulse (world vector).
    pub rolling_impulse: Vec3,
    /// Rolling resistance bound per unit normal impulse, metres:
    /// `c_rr × ball radius` (0 when no ball is involved).
    pub rolling_arm: f32,
    pub friction: f32,
    pub restitution: f32,
    /// The manifold in the shapes' own frames, for recycling.
    pub cache: ManifoldCache,
    /// How far the pair may move before its manifold is computed afresh,
    /// `[linear, angular]` (see [`recycle`](Self::recycle)); set by the
    /// world when it makes the pair, from the two shapes. 0 until then:
    /// only an unmoved pair recycles.
    pub recycle_tolerance: [f32; 2],
    /// The bond that glues the pair (its slot in the world's bonds, see
    /// `world/bonds.rs`), or [`NONE`]: while there is one, the manifold
    /// is the bond's four anchors (`follow_bond`) instead of the narrow
    /// phase's, and the solver lets its points pull (see `bond_strength`).
    pub bond: u32,
    /// While bonded: the tension each of the four points may carry and the
    /// cohesion of the whole face, in newtons (`tensile_strength × area /
    /// 4`, `shear_strength × area`); zeros otherwise.
    pub bond_strength: [f32; 2],
    /// While bonded: the impulses the solver applied over the last step,
    /// summed over its substeps (see [`BondImpulse`]); what the end of the
    /// step judges the bond on.
    pub bond_impulse: BondImpulse,
    /// While bonded: how far B's anchors have slid across the face from
    /// A's (their mean, a world vector in the face's plane) and turned
    /// about the normal (radians), at the start of the step
    /// (`follow_bond`): what the solver's shear rows pull back.
    pub bond_slide: Vec3,
    pub bond_twist: f32,
    /// An impact still closing when the last step ended, per manifold
    /// point (same order as the points): the approach speed it started
    /// with (negative, m/s; 0: none under way) and the normal impulse it
    /// has taken since (N·s). Restitution bounces a point once its
    /// approach has been stopped, with what the whole impact took
    /// (`solver/manifold.rs`, `restitute`); one that a speculative contact
    /// has only slowed by the step's end carries its impact here.
    pub impact_approach: [f32; MAX_MANIFOLD_POINTS],
    pub impact_impulse: [f32; MAX_MANIFOLD_POINTS],
    /// Position in [`ContactSet::active`], or [`NONE`] while inactive.
    active_pos: u32,
    /// Its places in the contact lists of `body_a` (index 0) and `body_b`
    /// (index 1) (`edge_list`).
    links: Links,
}

/// The friction coefficient of a pair of materials: the geometric mean of
/// theirs, `√(f_a f_b)`. A product past `f32` (coefficients near its
/// largest, which `Material::validate` accepts) takes the roots first, so
/// that the pair's coefficient stays finite; below that, the product's root
/// (the same bits as ever).
pub(crate) fn combined_friction(a: f32, b: f32) -> f32 {
    let product = a * b;
    if product.is_finite() {
        product.sqrt()
    } else {
        a.sqrt() * b.sqrt()
    }
}

/// The impulses a bonded pair exchanged over a step, summed over the
/// substeps: along the normal at each of the four anchor points (positive
/// pushes the faces apart, negative pulls them together), across the
/// face at its centre (a world vector, on B), and about the normal.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct BondImpulse {
    pub normal: [f32; MAX_MANIFOLD_POINTS],
    pub friction: Vec3,
    pub twist: f32,
}

impl BondImpulse {
    pub const ZERO: BondImpulse = BondImpulse { normal: [0.0; MAX_MANIFOLD_POINTS], friction: Vec3::ZERO, twist: 0.0 };
}

impl Edge for Contact {
    /// Which of the two body lists `body` is on: 0 for `body_a`, 1 for `body_b`.
    #[inline]
    fn side(&self, body: u32) -> usize {
        debug_assert!(self.body_a == body || self.body_b == body);
        usize::from(self.body_a != body)
    }

    #[inline]
    fn links(&self) -> &Links {
        &self.links
    }

    #[inline]
    fn links_mut(&mut self) -> &mut Links {
        &mut self.links
    }
}

/// A manifold kept in the two shapes' local frames, so that a pair whose
/// relative pose has barely changed since the narrow phase last ran re-uses
/// its points (contact recycling, as in Rapier) instead of clipping again.
///
/// Each point is stored twice, as the point on A's surface in A's frame and
/// the point on B's surface in B's frame (`point ∓ separation/2 · n`). With
/// the current poses these give the current separation along the current
/// normal exactly to first order in the motion, which is all the solver
/// uses. What they cannot follow is a change of features (which corners
/// touch): within the tolerances (their values: `recycle_tolerance` in
/// `narrow_phase.rs`) a corner that was not in the manifold can come at most a
/// little nearer, and a clipped corner slide a little along its edge.
///
/// The layout is fixed (`repr(C)`) so that every `Vec3` is followed by a
/// float: the compiler loads a `Vec3` into a SIMD register as 16 bytes and
/// lets the fourth lane ride along through the products. A byte flag or
/// padding there can read as a subnormal float, and then every product on
/// that lane takes a microcode assist (see `Pose`'s `tail` for the same
/// trap).
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub(crate) struct ManifoldCache {
    /// Rotation of B in A's frame when the narrow phase ran (of `A⁻¹ B`).
    pub relative_rotation: Quat,
    /// Position of B in A's frame when the narrow phase ran (of `A⁻¹ B`).
    pub relative_position: Vec3,
    /// The normal in A's frame.
    pub normal_a: Vec3,
    pub local_a: [Vec3; MAX_MANIFOLD_POINTS],
    pub local_b: [Vec3; MAX_MANIFOLD_POINTS],
    /// Speculative margin the narrow phase ran with (after `local_b`: see
    /// above).
    pub margin: f32,
    /// Each point's separation when the narrow phase ran.
    pub separation: [f32; MAX_MANIFOLD_POINTS],
    /// False until the narrow phase has filled it.
    pub valid: bool,
}

// No padding between the points and `margin` (see the layout note above).
const _: () = assert!(
    std::mem::offset_of!(ManifoldCache, margin)
        == std::mem::offset_of!(ManifoldCache, local_b) + 12 * MAX_MANIFOLD_POINTS
);

impl ManifoldCache {
    pub const EMPTY: ManifoldCache = ManifoldCache {
        relative_rotation: Quat::IDENTITY,
        relative_position: Vec3::ZERO,
        normal_a: Vec3::ZERO,
        local_a: [Vec3::ZERO; MAX_MANIFOLD_POINTS],
        local_b: [Vec3::ZERO; MAX_MANIFOLD_POINTS],
        margin: 0.0,
        separation: [0.0; MAX_MANIFOLD_POINTS],
        valid: false,
    };

    /// Keeps `m`, computed at poses `a`, `b` with `margin`.
    pub fn store(&mut self, m: &Manifold, a: &Pose, b: &Pose, margin: f32) {
        let relative = a.inverse().mul_pose(b);
        self.relative_rotation = relative.rotation;
        self.relative_position = relative.position;
        self.margin = margin;
        self.normal_a = a.inverse_transform_vector(m.normal);
        for (k, p) in m.points().iter().enumerate() {
            let half = 0.5 * p.separation * m.normal;
            self.local_a[k] = a.inverse_transform_point(p.point - half);
            self.local_b[k] = b.inverse_transform_point(p.point + half);
            self.separation[k] = p.separation;
        }
        self.valid = true;
    }

    /// Whether the stored manifold of `points` points may be moved to
    /// poses `a`, `b`, before its points are looked at (see
    /// [`moved_point`](Self::moved_point) and [`within`](Self::within)): B
    /// has turned by at most `angular` radians relative to A since it was
    /// computed, `margin` has not grown by more than `linear` (a point that
    /// far beyond the old margin is a speculative point the pair cannot
    /// reach within the tolerance), and, for a manifold without points,
    /// whose points cannot tell, neither body's origin has moved more than
    /// `linear` metres as seen from the other (B's origin alone misses a
    /// large B turning about its own centre under a small A: its surface
    /// there moves by the turn times their distance).
    fn fits(&self, a: &Pose, b: &Pose, margin: f32, linear: f32, angular: f32, points: usize) -> bool {
        if !self.valid || margin > self.margin + linear {
            return false;
        }
        let relative = a.inverse().mul_pose(b);
        // |angle of q1⁻¹ q2| = 2 acos(|w|) ≈ 2 |xyz| for small angles.
        let turned = 2.0 * (self.relative_rotation.inverse() * relative.rotation).xyz().length();
        // (A NaN turn refuses.)
        if turned.is_nan() || turned > angular {
            return false;
        }
        if points > 0 {
            return true;
        }
        // B's origin seen from A, and A's seen from B (`−q⁻¹ p` of `A⁻¹ B =
        // (q, p)`).
        let b_moved = (relative.position - self.relative_position).length();
        let a_then = self.relative_rotation.inverse() * self.relative_position;
        let a_moved = (relative.rotation.inverse() * relative.position - a_then).length();
        b_moved <= linear && a_moved <= linear
    }

    /// Whether stored point `k`, moved to separation `separation` with its
    /// anchors slid apart by `slide2` (squared: see
    /// [`moved_point`](Self::moved_point)), may stay: within `margin`, slid
    /// by at most `linear`, and nearer than when the narrow phase ran by at
    /// most `linear` (the anchors bound each other across the normal, not
    /// along it: a brick on one edge dropped 2 cm kept its two points while
    /// its far edge, beyond the margin when they were found, went 5 mm into
    /// the ground). A NaN refuses.
    #[inline(always)]
    fn within(&self, k: usize, separation: f32, slide2: f32, margin: f32, linear: f32) -> bool {
        separation <= margin && slide2 <= linear * linear && self.separation[k] - separation <= linear
    }

    /// Stored point `k` at poses `a`, `b` (as affine maps: see `moved`):
    /// the point half-way between the two surfaces, their separation along `normal`,
    /// and the square of how far the two anchors have slid apart across
    /// `normal` since the narrow phase (when it ran, B's anchor lay on the
    /// normal through A's: `pb − pa` was the separation times the normal).
    #[inline(always)]
    fn moved_point(&self, k: usize, a: &Affine3A, b: &Affine3A, normal: Vec3A) -> (Vec3, f32, f32) {
        let pa = a.transform_point3a(self.local_a[k].into());
        let pb = b.transform_point3a(self.local_b[k].into());
        let d = pb - pa;
        let separation = d.dot(normal);
        ((0.5 * (pa + pb)).into(), separation, (d - separation * normal).length_squared())
    }

    /// The stored manifold moved to poses `a`, `b` if it [fits](Self::fits)
    /// them and every point stays within `margin` with its anchors slid
    /// apart by at most `linear` (as `Contact::recycle` moves it); `None`
    /// otherwise. `old` supplies the feature ids (the
    /// stored points, in the stored order).
    #[cfg(test)]
    pub fn recycle(
        &self,
        old: &Manifold,
        a: &Pose,
        b: &Pose,
        margin: f32,
        linear: f32,
        angular: f32,
    ) -> Option<Manifold> {
        let (normal, moved) = self.moved(a, b, margin, linear, angular, old.len())?;
        let mut m = Manifold::with_normal(normal);
        for (p, &(point, separation)) in old.points().iter().zip(&moved) {
            m.push(ContactPoint { point, separation, id: p.id });
        }
        Some(m)
    }

    /// The normal and the first `points` stored points at poses `a`, `b`
    /// (each as [`moved_point`](Self::moved_point) gives its place and
    /// separation) if the cache [fits](Self::fits) them and every point
    /// stays [`within`](Self::within) the tolerances; `None` otherwise.
    /// The test both ways of recycling share.
    #[inline(always)]
    fn moved(
        &self,
        a: &Pose,
        b: &Pose,
        margin: f32,
        linear: f32,
        angular: f32,
        points: usize,
    ) -> Option<(Vec3, [(Vec3, f32); MAX_MANIFOLD_POINTS])> {
        if !self.fits(a, b, margin, linear, angular, points) {
            return None;
        }
        // The poses as rotation matrices and translations: the nine
        // vectors moved (the normal and two anchors a point) each cost one
        // matrix product, three multiplies and two adds, where rotating by
        // the quaternion costs two cross and two dot products; the two
        // matrices cost about what two quaternion rotations do. Made only
        // now: most pairs that fail, fail `fits`.
        let affine = |p: &Pose| Affine3A::from_rotation_translation(p.rotation, p.position);
        let (fa, fb) = (&affine(a), &affine(b));
        let normal = fa.transform_vector3a(self.normal_a.into());
        let mut moved = [(Vec3::ZERO, 0.0); MAX_MANIFOLD_POINTS];
        for (k, x) in moved[..points].iter_mut().enumerate() {
            let (point, separation, slide2) = self.moved_point(k, fa, fb, normal);
            if !self.within(k, separation, slide2, margin, linear) {
                return None;
            }
            *x = (point, separation);
        }
        Some((normal.into(), moved))
    }
}

impl Contact {
    /// Asks the cache for the bytes a constraint's build reads of the
    /// contact at `this` (only an address: nothing is read through it) and the end of the step writes back: its bodies, the
    /// manifold, the kept impulses and the material (the fields up to
    /// `restitution`, three or four cache lines). The solver reaches
    /// contacts in its batches' order, not the list's, so each is a
    /// fresh miss the hardware cannot foresee; asked for a batch ahead,
    /// the lines arrive while the batch before is built.
    #[inline(always)]
    pub(crate) fn prefetch_solver_fields(this: *const Contact) {
        let start = this as *const u8;
        let end = std::mem::offset_of!(Contact, restitution) + std::mem::size_of::<f32>();
        let mut offset = 0;
        while offset < end {
            prefetch(start.wrapping_add(offset));
            offset += 64;
        }
        // The struct is not aligned to a line: its last bytes may start one.
        prefetch(start.wrapping_add(end - 1));
    }

    pub fn new(collider_a: u32, collider_b: u32, body_a: u32, body_b: u32, friction: f32, restitution: f32) -> Self {
        Contact {
            collider_a,
            collider_b,
            body_a,
            body_b,
            manifold: Manifold::EMPTY,
            normal_impulse: [0.0; MAX_MANIFOLD_POINTS],
            friction_impulse: Vec3::ZERO,
            twist_impulse: 0.0,
            rolling_impulse: Vec3::ZERO,
            rolling_arm: 0.0,
            max_normal_impulse: 0.0,
            step_impulse: 0.0,
            friction,
            restitution,
            touching: false,
            recycled: false,
            solved_steps: 0,
            cache: ManifoldCache::EMPTY,
            recycle_tolerance: [0.0; 2],
            bond: NONE,
            bond_strength: [0.0; 2],
            bond_impulse: BondImpulse::ZERO,
            bond_slide: Vec3::ZERO,
            impact_approach: [0.0; MAX_MANIFOLD_POINTS],
            impact_impulse: [0.0; MAX_MANIFOLD_POINTS],
            bond_twist: 0.0,
            active_pos: NONE,
            links: Links::NONE,
        }
    }

    /// The first of a restored contact's numbers that no step could have
    /// left (a NaN or an infinity anywhere, a coefficient out of the range
    /// `Material::validate` keeps its inputs in, a negative tolerance), by
    /// name; `None` when all are sound. A step seeds its solver with these
    /// numbers, and a NaN warm start turns every impulse of the pair NaN.
    pub(crate) fn unsound_number(&self) -> Option<&'static str> {
        let m = &self.manifold;
        let k = &self.cache;
        let b = &self.bond_impulse;
        let finite = |xs: &[f32]| xs.iter().all(|x| x.is_finite());
        let vectors = |vs: &[Vec3]| vs.iter().all(|v| v.is_finite());
        let groups: [(&'static str, bool); 10] = [
            ("a manifold point or normal that is not finite", {
                m.normal.is_finite() && m.points().iter().all(|p| p.point.is_finite() && p.separation.is_finite())
            }),
            ("a normal impulse that is not finite", {
                finite(&self.normal_impulse) && finite(&[self.max_normal_impulse, self.step_impulse])
            }),
            ("a friction, twist or rolling impulse that is not finite", {
                vectors(&[self.friction_impulse, self.rolling_impulse]) && self.twist_impulse.is_finite()
            }),
            (
                "a friction coefficient that is negative or not finite",
                self.friction.is_finite() && self.friction >= 0.0,
            ),
            ("a restitution outside 0 to 1", (0.0..=1.0).contains(&self.restitution)),
            ("a rolling arm that is negative or not finite", self.rolling_arm.is_finite() && self.rolling_arm >= 0.0),
            ("a recycling cache or tolerance that is not finite or negative", {
                k.relative_rotation.is_finite()
                    && vectors(&[k.relative_position, k.normal_a])
                    && vectors(&k.local_a)
                    && vectors(&k.local_b)
                    && finite(&k.separation)
                    && k.margin.is_finite()
                    && self.recycle_tolerance.iter().all(|t| t.is_finite() && *t >= 0.0)
            }),
            (
                "a bond strength that is negative or not finite",
                self.bond_strength.iter().all(|x| x.is_finite() && *x >= 0.0),
            ),
            ("a bond impulse, slide or twist that is not finite", {
                finite(&b.normal) && vectors(&[b.friction, self.bond_slide]) && finite(&[b.twist, self.bond_twist])
            }),
            ("a carried impact that is not finite", finite(&self.impact_approach) && finite(&self.impact_impulse)),
        ];
        groups.into_iter().find(|(_, sound)| !sound).map(|(what, _)| what)
    }

    /// What a free slot of [`ContactSet::list`] holds.
    fn dead() -> Self {
        Contact::new(NONE, NONE, NONE, NONE, 0.0, 0.0)
    }

    /// Whether the slot holds a contact (not a freed slot).
    pub fn is_live(&self) -> bool {
        self.collider_a != NONE
    }

    /// Whether the pair touches or nearly touches (it has points): what
    /// the removal or teleport of one body must wake the other for.
    pub fn in_reach(&self) -> bool {
        self.touching || !self.manifold.is_empty()
    }

    /// The body on the other side of the contact from `body`.
    pub fn other(&self, body: u32) -> u32 {
        if self.body_a == body {
            self.body_b
        } else {
            self.body_a
        }
    }

    /// Replaces the manifold, carrying each point's impulses over from the
    /// matching point of the old manifold (zero for a new point).
    ///
    /// A point matches the old point with the same feature id; failing
    /// that, the nearest unmatched old point within `tolerance` metres.
    /// The fallback matters for the most common case in a wall: two equal
    /// faces exactly on top of each other, where each corner is both an
    /// incident vertex and a clipped edge point, and rounding decides which
    /// feature names it from one step to the next. Without warm starting,
    /// a stack re-learns its impulses every step and creeps.
    pub fn set_manifold(&mut self, new: Manifold, tolerance: f32) {
        let old = self.manifold;
        // The same points in the same order (every recycled manifold that
        // kept all its points): each keeps its impulse, which is what the
        // matching gives then, without its searches.
        if !new.is_empty() && new.len() == old.len() && new.points().iter().zip(old.points()).all(|(p, q)| p.id == q.id)
        {
            self.keep_points(new.len());
        } else {
            self.carry_impulses(&old, &new, tolerance);
            self.twist_rule(new.len());
        }
        self.manifold = new;
    }

    /// The impulses of a manifold whose `n` points continue the last ones,
    /// in the same order: each keeps its own.
    fn keep_points(&mut self, n: usize) {
        for x in &mut self.normal_impulse[n..] {
            *x = 0.0;
        }
        for x in self.impact_approach[n..].iter_mut().chain(&mut self.impact_impulse[n..]) {
            *x = 0.0;
        }
        self.twist_rule(n);
    }

    /// A single point has no patch to twist on: the solver gives it no
    /// twist row, so a twist impulse kept from a face contact would be
    /// warm-started every substep and never corrected, a constant spin
    /// about the normal. (`n` points.)
    fn twist_rule(&mut self, n: usize) {
        if n < 2 {
            self.twist_impulse = 0.0;
        }
    }

    /// Moves the manifold with the bodies, to poses `a`, `b`, if its cache
    /// [fits](ManifoldCache::fits) them and every point stays within
    /// `margin` with its two anchors slid apart by at most `linear`
    /// (contact recycling; `margin`, `linear` and `angular` as there), and
    /// says whether it did. The points and the normal are
    /// updated where they lie, and each point keeps its impulses, as
    /// [`set_manifold`](Self::set_manifold) keeps those of the same points
    /// in the same order (without the copies of a new manifold at each
    /// hand-over).
    ///
    /// A point that has left the margin is not dropped here: the pair goes
    /// back to the narrow phase. Dropping it would leave the cache's
    /// points in their stored order while the manifold's were one fewer,
    /// so the next recycling would read the points after the dropped one
    /// from their neighbours' slots (a resting pair whose speculative
    /// corners fall outside a shrinking margin would lose its corners one
    /// by one and warm-start impulses at the wrong ones). An empty manifold (a pair
    /// within the broad phase's margins but not within `margin`) stays
    /// empty and keeps no impulse, as `set_manifold` of an empty one.
    pub fn recycle(&mut self, a: &Pose, b: &Pose, margin: f32, linear: f32, angular: f32) -> bool {
        let n = self.manifold.len();
        let Some((normal, moved)) = self.cache.moved(a, b, margin, linear, angular, n) else {
            return false;
        };
        self.manifold.normal = normal;
        for (p, &(point, separation)) in self.manifold.points_mut().iter_mut().zip(&moved) {
            (p.point, p.separation) = (point, separation);
        }
        // As `set_manifold` with the same points; an empty manifold
        // carries nothing over.
        self.keep_points(n);
        if n == 0 {
            self.drop_patch_impulses();
        }
        true
    }

    /// The manifold of a bonded pair at poses `a`, `b`: the bond's four
    /// anchors (stored in `cache`, which a bond fills: see
    /// `Bond::anchors`) moved with the bodies, each point half-way
    /// between its two anchors and its separation their distance along the
    /// normal fixed in A. No tolerance applies: the anchors are the bond's,
    /// not a guess at where the surfaces touch, so they stay the points
    /// however far the pair turns. Each point keeps its impulses.
    pub fn follow_bond(&mut self, a: &Pose, b: &Pose) {
        let affine = |p: &Pose| Affine3A::from_rotation_translation(p.rotation, p.position);
        let (fa, fb) = (&affine(a), &affine(b));
        let normal = fa.transform_vector3a(self.cache.normal_a.into());
        let mut m = Manifold::with_normal(normal.into());
        let mut slides = [Vec3A::ZERO; MAX_MANIFOLD_POINTS];
        for (k, slide) in slides.iter_mut().enumerate() {
            let (pa, pb) = (
                fa.transform_point3a(self.cache.local_a[k].into()),
                fb.transform_point3a(self.cache.local_b[k].into()),
            );
            let d = pb - pa;
            let separation = d.dot(normal);
            *slide = d - separation * normal;
            m.push(crate::collision::ContactPoint {
                point: (0.5 * (pa + pb)).into(),
                separation,
                id: BOND_POINT_ID + k as u32,
            });
        }
        // The mean slide, and the turn about the normal that best explains
        // the rest: `Σ rⱼ × (dⱼ − d̄) · n / Σ |rⱼ|²`, rⱼ each point from
        // the points' centre.
        let mean = 0.25 * ((slides[0] + slides[1]) + (slides[2] + slides[3]));
        let points = m.points();
        let center = 0.25 * ((points[0].point + points[1].point) + (points[2].point + points[3].point));
        let (mut turn, mut spread) = (0.0, 0.0);
        for (p, slide) in points.iter().zip(&slides) {
            let r = Vec3A::from(p.point - center);
            turn += r.cross(*slide - mean).dot(normal);
            spread += r.length_squared();
        }
        self.bond_slide = mean.into();
        self.bond_twist = if spread > 0.0 { turn / spread } else { 0.0 };
        self.manifold = m;
        self.recycled = true;
    }

    /// Gives each point of `new` the normal impulse of the point of `old`
    /// it continues (same feature id, else the nearest within
    /// `tolerance`), and drops the patch's friction impulses when no point
    /// carried over (see `set_manifold`).
    fn carry_impulses(&mut self, old: &Manifold, new: &Manifold, tolerance: f32) {
        let old_n = self.normal_impulse;
        self.normal_impulse = [0.0; MAX_MANIFOLD_POINTS];
        let (old_approach, old_impulse) = (self.impact_approach, self.impact_impulse);
        self.impact_approach = [0.0; MAX_MANIFOLD_POINTS];
        self.impact_impulse = [0.0; MAX_MANIFOLD_POINTS];
        let carry = |c: &mut Contact, i: usize, j: usize| {
            c.normal_impulse[i] = old_n[j];
            c.impact_approach[i] = old_approach[j];
            c.impact_impulse[i] = old_impulse[j];
        };
        let mut taken = [false; MAX_MANIFOLD_POINTS];
        let mut matched = [false; MAX_MANIFOLD_POINTS];
        for (i, p) in new.points().iter().enumerate() {
            if let Some(j) = old.points().iter().enumerate().position(|(j, q)| !taken[j] && q.id == p.id) {
                taken[j] = true;
                matched[i] = true;
                carry(self, i, j);
            }
        }
        let tol2 = tolerance * tolerance;
        for (i, p) in new.points().iter().enumerate() {
            if matched[i] {
                continue;
            }
            let mut best = None;
            let mut best_d2 = tol2;
            for (j, q) in old.points().iter().enumerate() {
                let d2 = (q.point - p.point).length_squared();
                if !taken[j] && d2 <= best_d2 {
                    best = Some(j);
                    best_d2 = d2;
                }
            }
            if let Some(j) = best {
                taken[j] = true;
                carry(self, i, j);
            }
        }
        // Friction belongs to the patch, not to a point: keep it while any
        // point carried over, drop it when the contact changed entirely.
        if !taken.iter().any(|&t| t) {
            self.drop_patch_impulses();
        }
    }

    /// Forgets every impulse the contact keeps from its steps (the
    /// points', the patch's, the carried impacts, the bond's, and the
    /// step's sums) and counts it as new (`solved_steps` 0): the next step
    /// starts it cold, as a contact just made.
    pub(crate) fn start_cold(&mut self) {
        self.normal_impulse = [0.0; MAX_MANIFOLD_POINTS];
        (self.step_impulse, self.max_normal_impulse) = (0.0, 0.0);
        self.drop_patch_impulses();
        self.impact_approach = [0.0; MAX_MANIFOLD_POINTS];
        self.impact_impulse = [0.0; MAX_MANIFOLD_POINTS];
        self.bond_impulse = BondImpulse::ZERO;
        self.solved_steps = 0;
    }

    /// Forgets the impulses of the patch as a whole: friction, twist and
    /// rolling.
    fn drop_patch_impulses(&mut self) {
        self.friction_impulse = Vec3::ZERO;
        self.twist_impulse = 0.0;
        self.rolling_impulse = Vec3::ZERO;
    }

    /// What the end of the step must do with this contact
    /// (`World::report_events`), as bits: [`REPORT_TOUCHING`] when it
    /// touches now (a bond that holds, a normal impulse in the step, or a
    /// point of its manifold inside the other shape), and
    /// [`REPORT_NEEDS`] when anything is to be done: its touching flag
    /// changes, or its manifold is empty and it still holds impulses of
    /// the step before, to be cleared.
    #[inline]
    pub(crate) fn report_mark(&self) -> u8 {
        let touching = self.bond != NONE
            || self.max_normal_impulse > 0.0
            || self.manifold.min_separation().is_some_and(|s| s < 0.0);
        // Bits, not values: a −0.0 left in place would be other bits than
        // the 0.0 that clearing writes.
        let stale = self.manifold.is_empty() && (self.max_normal_impulse.to_bits() | self.step_impulse.to_bits()) != 0;
        let needs = touching != self.touching || stale;
        (u8::from(needs) * REPORT_NEEDS) | (u8::from(touching) * REPORT_TOUCHING)
    }
}

/// [`Contact::report_mark`]: something is to be done at the step's end.
pub(crate) const REPORT_NEEDS: u8 = 1;
/// [`Contact::report_mark`]: the contact touches now.
pub(crate) const REPORT_TOUCHING: u8 = 2;

/// "No contact" in the links and "not active" in `active_pos`.
pub(crate) const NONE: u32 = u32::MAX;

/// The feature id of a bond's first anchor point (the others follow): no
/// shape pair's features number this high, so a bond's points never take
/// a narrow-phase point's impulse by id.
pub(crate) const BOND_POINT_ID: u32 = 0xB0_0000;

/// All contacts, plus the two structures that let a step ignore the ones
/// at rest:
///
/// - each contact keeps its slot in `list` for its whole life (freed slots
///   are reused), so that an index can be held in other lists;
/// - `active` lists the slots of the contacts the step must look at: those
///   with at least one awake, non-static body. Contacts enter it at the end
///   and leave it by swap-remove, so in a world where nothing sleeps it
///   holds the contacts in the order `list` would with the same moves;
/// - every body heads a doubly linked list of its contacts (`edge_list`,
///   links inside the contacts), so that waking or sleeping a body, or
///   removing a collider, touches only that body's contacts.
///
/// The map from the collider pair to the slot is only ever looked up, never
/// iterated, so its hashing cannot leak into any order.
#[derive(Default)]
pub(crate) struct ContactSet {
    /// Contact slots; a free slot holds a dead contact ([`Contact::is_live`]).
    pub list: Vec<Contact>,
    free: Vec<u32>,
    index: HashMap<(u32, u32), u32, FixedState>,
    /// Slots of the active contacts, in a deterministic order (see above).
    pub active: Vec<u32>,
    /// Per body slot: the first contact of the body's list, or [`NONE`].
    body_first: Vec<u32>,
    count: usize,
    /// Per contact slot: its [`Contact::report_mark`], written by the
    /// stages that change what the mark reads (the solver's selection for
    /// the contacts it does not solve, its write-back for those it does, a
    /// bond's end), so that the end of the step finds the few contacts
    /// with something to report by reading one byte each, not each
    /// contact. Scratch: each step writes it for every active contact
    /// before it is read.
    pub report: Vec<u8>,
}

/// How many active contacts ahead of the one it reads a scan over the
/// active list asks for ([`ContactSet::prefetch_active`]).
pub(crate) const SCAN_AHEAD: usize = 8;

impl ContactSet {
    /// Asks for the first line of the contact at position `k` of the
    /// active list (its bodies, its impulse and flags, its point count:
    /// what the scans over every active contact read first), if there is
    /// one. The active list's slots lie anywhere in the list, so each
    /// contact a scan reaches is a miss the hardware cannot foresee; asked
    /// for [`SCAN_AHEAD`] contacts ahead, its line arrives while the ones
    /// before are handled.
    #[inline(always)]
    pub(crate) fn prefetch_active(&self, k: usize) {
        if let Some(&i) = self.active.get(k) {
            let start = self.list.as_ptr().wrapping_add(i as usize) as *const u8;
            prefetch(start);
            // The head's last byte (the point count), which may start the
            // next line: the struct is not aligned to one.
            prefetch(start.wrapping_add(std::mem::offset_of!(Contact, manifold)));
        }
    }

    /// Adds a contact (inactive) and links it into its two bodies' lists.
    /// Returns its slot, or `None` when the pair already has a contact.
    pub fn insert(&mut self, mut c: Contact) -> Option<u32> {
        let key = (c.collider_a, c.collider_b);
        if self.index.contains_key(&key) {
            return None;
        }
        debug_assert_ne!(c.body_a, c.body_b, "a contact joins two bodies");
        let id = self.free.pop().unwrap_or(self.list.len() as u32);
        let top = c.body_a.max(c.body_b) as usize;
        if self.body_first.len() <= top {
            self.body_first.resize(top + 1, NONE);
        }
        c.active_pos = NONE;
        c.links = edge_list::link_front(&mut self.list, &mut self.body_first, id, [c.body_a, c.body_b]);
        if id as usize == self.list.len() {
            self.list.push(c);
        } else {
            self.list[id as usize] = c;
        }
        self.index.insert(key, id);
        self.count += 1;
        Some(id)
    }

    /// Slot of the collider pair's contact.
    pub fn id_of(&self, a: u32, b: u32) -> Option<u32> {
        self.index.get(&(a, b)).copied()
    }

    /// Removes the contact of the collider pair; returns it when it existed.
    pub fn remove(&mut self, a: u32, b: u32) -> Option<Contact> {
        let id = self.id_of(a, b)?;
        Some(self.remove_at(id))
    }

    /// Removes the contact in slot `id` (live): out of the active list, out
    /// of both body lists, slot freed.
    pub fn remove_at(&mut self, id: u32) -> Contact {
        self.deactivate(id);
        let c = std::mem::replace(&mut self.list[id as usize], Contact::dead());
        debug_assert!(c.is_live(), "removing a free contact slot");
        edge_list::unlink(&mut self.list, &mut self.body_first, [c.body_a, c.body_b], c.links);
        self.index.remove(&(c.collider_a, c.collider_b));
        self.free.push(id);
        self.count -= 1;
        c
    }

    /// Whether the contact in slot `id` is in the active list.
    #[inline]
    pub fn is_active(&self, id: u32) -> bool {
        self.list[id as usize].active_pos != NONE
    }

    /// Position of the contact in the active list, or [`NONE`].
    #[inline]
    pub fn active_pos(&self, id: u32) -> u32 {
        self.list[id as usize].active_pos
    }

    /// Appends the contact to the active list (no-op if already there).
    pub fn activate(&mut self, id: u32) {
        let c = &mut self.list[id as usize];
        if c.active_pos == NONE {
            c.active_pos = self.active.len() as u32;
            self.active.push(id);
            // Woken after the solver's selection (a bond or joint that
            // broke woke its island), the contact is read by this step's
            // events: its mark is its own, not what its slot last held.
            self.remark(id);
        }
    }

    /// Writes contact `id`'s end-of-step mark ([`Contact::report_mark`])
    /// after a change to what it reads, outside the solver (which writes
    /// the marks of every contact it selects). A slot past the marks (a
    /// contact made since the last selection) is marked by the next one.
    pub fn remark(&mut self, id: u32) {
        let mark = self.list[id as usize].report_mark();
        if let Some(m) = self.report.get_mut(id as usize) {
            *m = mark;
        }
    }

    /// Takes the contact out of the active list by swap-remove (no-op if not
    /// there).
    pub fn deactivate(&mut self, id: u32) {
        let pos = std::mem::replace(&mut self.list[id as usize].active_pos, NONE);
        if pos == NONE {
            return;
        }
        self.active.swap_remove(pos as usize);
        if let Some(&moved) = self.active.get(pos as usize) {
            self.list[moved as usize].active_pos = pos;
        }
    }

    /// The first contact in `body`'s list, or [`NONE`]. Walk on with
    /// [`next_of`](Self::next_of).
    #[inline]
    pub fn first_of(&self, body: u32) -> u32 {
        self.body_first.get(body as usize).copied().unwrap_or(NONE)
    }

    /// The contact after `id` in `body`'s list, or [`NONE`].
    #[inline]
    pub fn next_of(&self, id: u32, body: u32) -> u32 {
        self.list[id as usize].next_in(body)
    }

    /// Live contacts in slot order.
    pub fn iter(&self) -> impl Iterator<Item = &Contact> {
        self.list.iter().filter(|c| c.is_live())
    }

    /// Number of live contacts.
    pub fn len(&self) -> usize {
        self.count
    }

    /// Checks the links, the active positions and the map; panics on the
    /// first inconsistency. O(contacts + bodies). For tests.
    pub fn validate(&self) {
        let mut live = 0;
        for (id, c) in self.list.iter().enumerate() {
            if !c.is_live() {
                assert_eq!(c.active_pos, NONE, "free slot {id} is active");
                continue;
            }
            live += 1;
            assert_eq!(self.index.get(&(c.collider_a, c.collider_b)), Some(&(id as u32)), "map of {id}");
            if c.active_pos != NONE {
                assert_eq!(self.active.get(c.active_pos as usize), Some(&(id as u32)), "active position of {id}");
            }
        }
        assert_eq!(live, self.count, "contact count");
        assert_eq!(self.index.len(), self.count, "map size");
        for (k, &id) in self.active.iter().enumerate() {
            assert_eq!(self.list[id as usize].active_pos, k as u32, "active list entry {k}");
        }
        // Every live contact is on exactly its two bodies' lists.
        let mut listed = 0;
        for (body, &first) in self.body_first.iter().enumerate() {
            let body = body as u32;
            listed += edge_list::check_list(&self.list, body, first, |id, c| {
                assert!(c.is_live() && (c.body_a == body || c.body_b == body), "contact {id} on list of {body}");
            });
        }
        assert_eq!(listed, 2 * self.count, "body list entries");
    }
}

/// A hint that `p`'s cache line will be read soon (no effect elsewhere
/// than on x86-64; never faults, whatever `p` is).
#[inline(always)]
pub(crate) fn prefetch(p: *const u8) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch reads nothing the program sees and cannot fault;
    // SSE is part of x86-64.
    #[allow(unused_unsafe)]
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p as *const i8)
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collision::contact_manifold;
    use crate::math::Quat;
    use crate::shape::Shape;

    /// Margin of the brick pairs below, metres.
    const MARGIN: f32 = 0.008;

    /// A seed brick A and, resting on it offset by `offset` (x, z) in A's
    /// frame, another B: the shape, both poses, their face manifold and
    /// the cache that stored it.
    fn brick_on_brick_stored(offset: Vec3) -> (Shape, Pose, Pose, Manifold, ManifoldCache) {
        let brick = Shape::cuboid(Vec3::new(0.1075, 0.0325, 0.05125)).unwrap();
        let a = Pose::new(Vec3::new(0.3, 0.0325, -0.2), Quat::from_rotation_y(0.3));
        let b0 = a.mul_pose(&Pose::from_translation(Vec3::new(offset.x, 0.065, offset.z)));
        let first = contact_manifold(&brick, &a, &brick, &b0, MARGIN);
        assert_eq!(first.len(), 4, "face contact");
        let mut cache = ManifoldCache::EMPTY;
        cache.store(&first, &a, &b0, MARGIN);
        (brick, a, b0, first, cache)
    }

    /// A brick resting on another, the upper one then nudged by `dp` and
    /// turned by `angle` about `axis`: the recycled manifold against the
    /// one the narrow phase computes afresh at the new pose.
    fn compare(dp: Vec3, axis: Vec3, angle: f32) -> (Option<Manifold>, Manifold) {
        let (brick, a, b0, first, cache) = brick_on_brick_stored(Vec3::ZERO);
        let margin = MARGIN;
        let b1 = Pose::new(b0.position + dp, Quat::from_axis_angle(axis.normalize(), angle) * b0.rotation);
        let fresh = contact_manifold(&brick, &a, &brick, &b1, margin);
        (cache.recycle(&first, &a, &b1, margin, 3.25e-4, 1e-3), fresh)
    }

    #[test]
    fn a_recycled_manifold_matches_the_narrow_phase_within_the_tolerance() {
        // 0.2 mm sideways and down, 0.8 mrad of tilt: inside the tolerances
        // (linear 0.325 mm, 1 mrad). The corners move along the normal by
        // up to 0.8e-3 * 0.12 m ≈ 0.1 mm; the recycled separations must
        // follow them to first order: within 1e-6 m (the second-order term
        // is angle² · lever ≈ 1e-7 m).
        let (recycled, fresh) = compare(Vec3::new(1e-4, -1e-4, 1e-4), Vec3::new(1.0, 0.2, 0.5), 8e-4);
        let recycled = recycled.expect("within tolerance: recycled");
        assert_eq!(recycled.len(), fresh.len());
        assert!((recycled.normal - fresh.normal).length() < 1e-3, "{:?} {:?}", recycled.normal, fresh.normal);
        let mut got: Vec<f32> = recycled.points().iter().map(|p| p.separation).collect();
        let mut want: Vec<f32> = fresh.points().iter().map(|p| p.separation).collect();
        got.sort_by(f32::total_cmp);
        want.sort_by(f32::total_cmp);
        for (g, w) in got.iter().zip(&want) {
            assert!((g - w).abs() < 1e-6, "separations {got:?} vs {want:?}");
        }
        // The tilt spreads the corners' separations over ~0.18 mm: the
        // test is not comparing four equal numbers.
        assert!(want[3] - want[0] > 1e-4, "{want:?}");
    }

    /// A brick resting flat on another (the face manifold, with margin
    /// 8 mm) and the two poses.
    fn brick_on_brick() -> (Manifold, Pose, Pose) {
        let brick = Shape::cuboid(Vec3::new(0.1075, 0.0325, 0.05125)).unwrap();
        let a = Pose::from_translation(Vec3::new(0.0, 0.0325, 0.0));
        let b = Pose::from_translation(Vec3::new(0.0, 0.0975, 0.0));
        (contact_manifold(&brick, &a, &brick, &b, 0.008), a, b)
    }

    /// The layout of `Contact`: the fields the per-step loops over active
    /// contacts read lie in its first 64 bytes (one or two cache lines of
    /// a 368-byte contact, instead of spread over it), the manifold's
    /// point count first among them; and its own vectors are followed by floats, not by a
    /// flag byte (see the test below).
    #[test]
    fn a_contacts_hot_fields_share_its_first_64_bytes() {
        use std::mem::offset_of;
        let ends = [
            offset_of!(Contact, body_a) + 4,
            offset_of!(Contact, body_b) + 4,
            offset_of!(Contact, collider_a) + 4,
            offset_of!(Contact, collider_b) + 4,
            offset_of!(Contact, max_normal_impulse) + 4,
            offset_of!(Contact, step_impulse) + 4,
            offset_of!(Contact, touching) + 1,
            // The point count, first in the manifold (`repr(C)`).
            offset_of!(Contact, manifold) + 1,
        ];
        assert!(ends.iter().all(|&e| e <= 64), "{ends:?}");
        assert_eq!(offset_of!(Contact, twist_impulse), offset_of!(Contact, friction_impulse) + 12);
        assert_eq!(offset_of!(Contact, rolling_arm), offset_of!(Contact, rolling_impulse) + 12);
        assert_eq!(offset_of!(Manifold, normal), 4, "the count, then the normal");
    }

    /// Regression: the compiler loads each cached `Vec3` as 16 bytes and
    /// multiplies the fourth lane along, so a flag byte after the last
    /// point reads as a subnormal float and costs one microcode assist per
    /// product (recycling slows down severalfold). Every cached vector must be followed by a float that is
    /// zero or normal, whatever the manifold.
    #[test]
    fn cached_vectors_are_not_followed_by_subnormal_bytes() {
        let (m, a, b) = brick_on_brick();
        assert_eq!(m.len(), MAX_MANIFOLD_POINTS, "a full manifold reaches the last slot");
        let mut cache = ManifoldCache::EMPTY;
        cache.store(&m, &a, &b, 0.008);
        let base = &cache as *const ManifoldCache as *const u8;
        let after = |v: &Vec3| -> f32 {
            let offset = v as *const Vec3 as usize - base as usize + 12;
            assert!(offset + 4 <= std::mem::size_of::<ManifoldCache>());
            // SAFETY: the pointer comes from the whole cache and stays in
            // it (asserted); the layout is `repr(C)` with no padding before
            // `valid` (asserted at compile time below the struct), so these
            // bytes are initialised.
            unsafe { base.add(offset).cast::<f32>().read_unaligned() }
        };
        let vectors =
            [&cache.relative_position, &cache.normal_a].into_iter().chain(&cache.local_a).chain(&cache.local_b);
        for (k, v) in vectors.enumerate() {
            let next = after(v);
            assert!(next == 0.0 || next.is_normal(), "vector {k} is followed by {next:e}");
        }
    }

    /// Regression: a face contact (four points) that tipped onto one of
    /// its corners kept the face's twist impulse, which the solver (no twist
    /// row for one point) warm-started forever.
    #[test]
    fn a_contact_down_to_one_point_drops_its_twist_impulse() {
        let (face, _, _) = brick_on_brick();
        assert_eq!(face.len(), 4, "face contact");
        let mut c = Contact::new(0, 1, 0, 1, 0.6, 0.0);
        c.set_manifold(face, 1e-3);
        c.normal_impulse = [1.0, 2.0, 3.0, 4.0];
        c.twist_impulse = 0.25;
        c.friction_impulse = Vec3::new(0.1, 0.0, 0.0);
        // The same patch, three corners gone: the kept corner carries over.
        let mut corner = Manifold::EMPTY;
        corner.normal = face.normal;
        assert!(corner.push(face.points()[0]));
        c.set_manifold(corner, 1e-3);
        assert_eq!(c.twist_impulse, 0.0, "no twist on one point");
        assert_eq!(c.friction_impulse, Vec3::new(0.1, 0.0, 0.0), "friction belongs to the patch: kept");
        assert_eq!(c.normal_impulse, [1.0, 0.0, 0.0, 0.0], "the corner's normal impulse carried over");
        // Back to a face, the twist builds up again from zero.
        c.set_manifold(face, 1e-3);
        assert_eq!(c.twist_impulse, 0.0);
    }

    /// `Contact::recycle` (in place) leaves the contact as `set_manifold`
    /// of the cache's recycled manifold does, bit for bit: a brick tilted
    /// on another so that its corners' separations spread over 0.2 mm,
    /// both then turned a little (the normal moves with the lower one),
    /// recycled with a margin that keeps all four corners; a pair apart,
    /// whose empty manifold clears the impulses left on it. A margin that
    /// would drop the two highest corners, or a pose moved too far, is not
    /// recycled and leaves the contact as it was.
    #[test]
    fn recycling_in_place_is_set_manifold_of_the_recycled_manifold() {
        let (face, a, b) = brick_on_brick();
        let mut c = Contact::new(0, 1, 0, 1, 0.6, 0.0);
        c.cache.store(&face, &a, &b, 0.008);
        c.set_manifold(face, 1e-3);
        (c.normal_impulse, c.twist_impulse) = ([1.0, 2.0, 3.0, 4.0], 0.25);
        let tilted = Pose::new(b.position + Vec3::new(1e-4, -2e-5, 0.0), Quat::from_rotation_z(8e-4) * b.rotation);
        // A turned too, so that the normal moves (by 0.5 mrad).
        let turned = Pose::new(a.position, Quat::from_rotation_x(5e-4) * a.rotation);
        let tilted = Pose::new(tilted.position, Quat::from_rotation_x(5e-4) * tilted.rotation);
        let bits = |c: &Contact| {
            let m = &c.manifold;
            let points: Vec<[u32; 5]> = m
                .points()
                .iter()
                .map(|p| {
                    let [x, y, z, s] = [p.point.x, p.point.y, p.point.z, p.separation].map(f32::to_bits);
                    [x, y, z, s, p.id]
                })
                .collect();
            let impulses = (c.normal_impulse.map(f32::to_bits), c.twist_impulse.to_bits());
            (m.normal.to_array().map(f32::to_bits), points, impulses, c.friction_impulse.to_array().map(f32::to_bits))
        };
        let m = c.cache.recycle(&face, &turned, &tilted, 0.008, 3.25e-4, 1e-3).expect("within the tolerance");
        assert_eq!(m.len(), 4);
        let mut sorted: Vec<f32> = m.points().iter().map(|p| p.separation).collect();
        sorted.sort_by(f32::total_cmp);
        assert!(sorted[3] - sorted[0] > 1e-4, "the corners spread: {sorted:?}");
        let mut want = c.clone();
        want.set_manifold(m, 1e-3);
        let mut got = c.clone();
        assert!(got.recycle(&turned, &tilted, 0.008, 3.25e-4, 1e-3));
        assert_eq!(bits(&got), bits(&want));
        assert_ne!(bits(&got), bits(&c), "moved");
        // An empty manifold (B 1 cm above A's face, margin 8 mm), with
        // impulses left over to clear.
        let above = Pose::from_translation(b.position + Vec3::new(0.0, 0.01, 0.0));
        let brick = Shape::cuboid(Vec3::new(0.1075, 0.0325, 0.05125)).unwrap();
        let apart = contact_manifold(&brick, &a, &brick, &above, 0.008);
        assert!(apart.is_empty());
        let mut empty = Contact::new(0, 1, 0, 1, 0.6, 0.0);
        empty.cache.store(&apart, &a, &above, 0.008);
        empty.set_manifold(apart, 1e-3);
        (empty.normal_impulse, empty.friction_impulse, empty.twist_impulse) = ([1.0; 4], Vec3::X, 0.5);
        empty.rolling_impulse = Vec3::Y;
        let mut want = empty.clone();
        let moved = empty.cache.recycle(&empty.manifold, &turned, &above, 0.008, 3.25e-4, 1e-3).expect("fits");
        assert!(moved.is_empty());
        want.set_manifold(moved, 1e-3);
        let mut got = empty.clone();
        assert!(got.recycle(&turned, &above, 0.008, 3.25e-4, 1e-3));
        assert_eq!(bits(&got), bits(&want));
        assert_eq!(got.rolling_impulse, want.rolling_impulse);
        assert_eq!(got.manifold, want.manifold);
        let between = 0.5 * (sorted[1] + sorted[2]);
        let far = Pose::from_translation(b.position + Vec3::new(1e-3, 0.0, 0.0));
        for (pose, margin) in [(tilted, between), (far, 0.008)] {
            let mut got = c.clone();
            assert!(!got.recycle(&turned, &pose, margin, 3.25e-4, 1e-3), "margin {margin}");
            assert_eq!(bits(&got), bits(&c), "left as it was");
        }
    }

    /// Regression: a recycled manifold that dropped a point (beyond a
    /// margin that shrank as the pair slowed) kept the cache's points in
    /// their stored order, so the next recycling read each later point
    /// from the slot of the one before it. Step by step as the world does
    /// (recycle, else the narrow phase and a new cache), with the margin
    /// shrinking between the corners' separations: every point must stay
    /// where the narrow phase puts the point of its id.
    #[test]
    fn recycled_points_stay_with_their_ids_when_the_margin_shrinks() {
        let brick = Shape::cuboid(Vec3::new(0.1075, 0.0325, 0.05125)).unwrap();
        let a = Pose::from_translation(Vec3::new(0.0, 0.0325, 0.0));
        // Tilted about z: the corners' separations spread over ~0.17 mm.
        let b = Pose::new(Vec3::new(0.0, 0.0976, 0.0), Quat::from_rotation_z(8e-4));
        let fresh = |margin: f32| contact_manifold(&brick, &a, &brick, &b, margin);
        let mut c = Contact::new(0, 1, 0, 1, 0.6, 0.0);
        let first = fresh(0.008);
        assert_eq!(first.len(), 4);
        c.cache.store(&first, &a, &b, 0.008);
        c.set_manifold(first, 1e-3);
        let mut sorted: Vec<f32> = first.points().iter().map(|p| p.separation).collect();
        sorted.sort_by(f32::total_cmp);
        let between = 0.5 * (sorted[1] + sorted[2]);
        for margin in [0.008, between, between, between] {
            if !c.recycle(&a, &b, margin, 3.25e-4, 1e-3) {
                let m = fresh(margin);
                c.cache.store(&m, &a, &b, margin);
                c.set_manifold(m, 1e-3);
            }
            let want = fresh(margin);
            assert_eq!(c.manifold.len(), want.len(), "margin {margin}");
            for p in c.manifold.points() {
                let q = want.points().iter().find(|q| q.id == p.id).expect("the narrow phase has this point");
                assert!((p.point - q.point).length() < 1e-6, "point {} at {} not {}", p.id, p.point, q.point);
                assert!((p.separation - q.separation).abs() < 1e-6);
            }
        }
    }

    /// A recycled manifold (the same points, ids and order) keeps every
    /// impulse; the same points in another order keep theirs by id; one
    /// point keeps its impulse and drops the twist.
    #[test]
    fn a_manifold_with_the_same_points_keeps_every_impulse() {
        let (face, _, _) = brick_on_brick();
        let mut c = Contact::new(0, 1, 0, 1, 0.6, 0.0);
        c.set_manifold(face, 1e-3);
        c.normal_impulse = [1.0, 2.0, 3.0, 4.0];
        c.twist_impulse = 0.25;
        c.friction_impulse = Vec3::new(0.1, 0.0, 0.0);
        let mut moved = face;
        for p in moved.points_mut() {
            p.point += Vec3::new(1e-4, 0.0, 0.0);
        }
        c.set_manifold(moved, 1e-3);
        assert_eq!(c.normal_impulse, [1.0, 2.0, 3.0, 4.0]);
        assert_eq!((c.twist_impulse, c.friction_impulse), (0.25, Vec3::new(0.1, 0.0, 0.0)));
        let mut reversed = Manifold::EMPTY;
        reversed.normal = face.normal;
        for p in face.points().iter().rev() {
            assert!(reversed.push(*p));
        }
        c.set_manifold(reversed, 1e-3);
        assert_eq!(c.normal_impulse, [4.0, 3.0, 2.0, 1.0], "matched by id");
        let mut one = Manifold::EMPTY;
        one.normal = face.normal;
        assert!(one.push(reversed.points()[0]));
        c.set_manifold(one, 1e-3);
        // The same single point again (the fast path): its impulse kept,
        // the slots beyond it and the twist cleared.
        c.normal_impulse[1] = 5.0;
        c.twist_impulse = 0.25;
        c.set_manifold(one, 1e-3);
        assert_eq!(c.normal_impulse, [4.0, 0.0, 0.0, 0.0]);
        assert_eq!(c.twist_impulse, 0.0, "no twist on one point");
    }

    /// At the world's tolerances for a seed brick (`recycle_tolerance`: 0.65
    /// mm of slide between a point's anchors, 5.3 mrad of turn), nearly
    /// used up (the anchors slide by up to 0.61 mm): the separations still
    /// follow the fresh ones to second order (angle · slide ≈ 3e-3 · 6.5e-4
    /// m and angle² · lever ≈ 1e-5 · 0.12 m, each about 2e-6 m; measured
    /// at most 1.5e-6 m), and every recycled point lies within twice the
    /// linear tolerance (1.3 mm) of a fresh one across the normal.
    #[test]
    fn a_recycled_manifold_at_the_worlds_brick_tolerance_stays_close() {
        let (linear, angular) = (6.5e-4, 5.27e-3);
        let (brick, a, b0, first, cache) = brick_on_brick_stored(Vec3::new(0.05, 0.0, 0.01));
        let margin = MARGIN;
        for (dp, axis, angle) in [
            (Vec3::new(2.5e-4, -1e-4, 2.5e-4), Vec3::new(1.0, 0.2, 0.5), 2.5e-3),
            (Vec3::new(-2e-4, 0.0, 2e-4), Vec3::Y, 3e-3),
            (Vec3::new(0.0, -3e-4, -3e-4), Vec3::new(0.0, 0.3, 1.0), 2.5e-3),
            // Turns near the 5.3 mrad limit: about the normal (the anchors
            // slide 0.6 mm) and a tilt (a corner comes 0.55 mm nearer).
            (Vec3::new(1e-5, 0.0, 1e-5), Vec3::Y, 4.8e-3),
            (Vec3::ZERO, Vec3::new(1.0, 0.0, 0.3), 5e-3),
        ] {
            let b1 = Pose::new(b0.position + dp, Quat::from_axis_angle(axis.normalize(), angle) * b0.rotation);
            let fresh = contact_manifold(&brick, &a, &brick, &b1, margin);
            let recycled = cache.recycle(&first, &a, &b1, margin, linear, angular).expect("within the tolerance");
            assert_eq!(recycled.len(), fresh.len());
            assert!((recycled.normal - fresh.normal).length() < angular, "{:?} {:?}", recycled.normal, fresh.normal);
            let n = fresh.normal;
            for p in recycled.points() {
                // The fresh point nearest across the normal, and how its
                // separation compares.
                let across = |q: &ContactPoint| {
                    let d = q.point - p.point;
                    (d - d.dot(n) * n).length()
                };
                let q = fresh.points().iter().min_by(|x, y| across(x).total_cmp(&across(y))).unwrap();
                assert!(across(q) < 2.0 * linear, "{:?} is {} m from the fresh points", p.point, across(q));
            }
            let mut got: Vec<f32> = recycled.points().iter().map(|p| p.separation).collect();
            let mut want: Vec<f32> = fresh.points().iter().map(|p| p.separation).collect();
            got.sort_by(f32::total_cmp);
            want.sort_by(f32::total_cmp);
            let worst = got.iter().zip(&want).map(|(g, w)| (g - w).abs()).fold(0.0, f32::max);
            assert!(worst < 4e-6, "separations {got:?} vs {want:?}");
            // A tilt spreads the separations by ~0.1 mm or more: the test
            // is not comparing equal numbers (the turn about the normal
            // instead moves the clipped corners most).
            assert!(axis == Vec3::Y || want[3] - want[0] > 1e-4, "{want:?}");
        }
    }

    /// A NaN in a pose refuses recycling, for a manifold with points and
    /// for one without (whose origins are all it goes by); nothing panics.
    #[test]
    fn a_nan_pose_is_never_recycled() {
        let (_, a, b0, first, cache) = brick_on_brick_stored(Vec3::ZERO);
        let mut empty_cache = ManifoldCache::EMPTY;
        empty_cache.store(&Manifold::EMPTY, &a, &b0, MARGIN);
        assert!(cache.recycle(&first, &a, &b0, MARGIN, 6.5e-4, 5.3e-3).is_some(), "unmoved");
        assert!(empty_cache.recycle(&Manifold::EMPTY, &a, &b0, MARGIN, 6.5e-4, 5.3e-3).is_some(), "unmoved");
        let nan_rotation = Pose::new(b0.position, Quat::from_xyzw(f32::NAN, 0.0, 0.0, 1.0));
        let nan_position = Pose::from_translation(Vec3::new(f32::NAN, 0.0, 0.0));
        for b in [nan_rotation, nan_position] {
            assert!(cache.recycle(&first, &a, &b, MARGIN, 6.5e-4, 5.3e-3).is_none(), "{b:?}");
            assert!(empty_cache.recycle(&Manifold::EMPTY, &a, &b, MARGIN, 6.5e-4, 5.3e-3).is_none(), "{b:?}");
        }
    }

    #[test]
    fn a_pair_that_moved_beyond_the_tolerance_is_computed_afresh() {
        assert!(compare(Vec3::new(4e-4, 0.0, 0.0), Vec3::X, 0.0).0.is_none(), "0.4 mm > 0.325 mm");
        assert!(compare(Vec3::ZERO, Vec3::X, 2e-3).0.is_none(), "2 mrad > 1 mrad");
        assert!(compare(Vec3::ZERO, Vec3::X, 0.0).0.is_some(), "unmoved");
    }
}

crate::snapshot::codec::persist!(BondImpulse { normal, friction, twist });
crate::snapshot::codec::persist!(ManifoldCache {
    relative_rotation,
    relative_position,
    normal_a,
    local_a,
    local_b,
    margin,
    separation,
    valid,
});
crate::snapshot::codec::persist!(Contact {
    body_a, body_b, collider_a, collider_b, max_normal_impulse, step_impulse, touching, recycled,
    solved_steps, manifold, normal_impulse, friction_impulse, twist_impulse, rolling_impulse, rolling_arm,
    friction, restitution, cache, recycle_tolerance, bond, bond_strength, bond_impulse, bond_slide, bond_twist,
    impact_approach, impact_impulse, links,
} scratch { active_pos });

/// The slots (a free one as a single 0 byte), the free list, the active
/// list and the bodies' list heads. The pair map, the count and each
/// contact's place in the active list follow from them; the end-of-step
/// marks are scratch.
impl crate::snapshot::codec::Persist for ContactSet {
    fn save(&self, w: &mut crate::snapshot::codec::Writer) {
        w.len(self.list.len());
        for c in &self.list {
            if c.is_live() {
                w.u8(1);
                c.save(w);
            } else {
                w.u8(0);
            }
        }
        self.free.save(w);
        self.active.save(w);
        self.body_first.save(w);
    }

    fn load(r: &mut crate::snapshot::codec::Reader) -> Result<Self, crate::snapshot::SnapshotError> {
        use crate::snapshot::codec::{invalid, Persist};
        let n = r.len()?;
        let mut list = Vec::with_capacity(n.min(1 << 16));
        for _ in 0..n {
            list.push(if bool::load(r)? { Contact::load(r)? } else { Contact::dead() });
        }
        let mut set = ContactSet {
            list,
            free: Persist::load(r)?,
            index: HashMap::default(),
            active: Persist::load(r)?,
            body_first: Persist::load(r)?,
            count: 0,
            report: Vec::new(),
        };
        set.check_restored().map_err(invalid)?;
        Ok(set)
    }

    fn wipe(&mut self) {
        self.report = Vec::new();
    }

    fn layout(out: &mut String) {
        out.push_str("ContactSet{list:Vec<Option<");
        Contact::layout(out);
        out.push_str(">>,free,active,body_first}");
    }
}

impl ContactSet {
    /// Checks a restored set and fills in what follows from it: each live
    /// contact's manifold and links, the free list (every free slot once),
    /// the active list (live contacts, once each), each body's list (a
    /// chain through its contacts, both ways, reaching every contact of
    /// the body once).
    fn check_restored(&mut self) -> Result<(), String> {
        let n = self.list.len();
        let mut free = vec![false; n];
        for &i in &self.free {
            match self.list.get(i as usize) {
                Some(c) if !c.is_live() && !free[i as usize] => free[i as usize] = true,
                _ => return Err(format!("free contact slot {i}")),
            }
        }
        for (id, c) in self.list.iter().enumerate() {
            if !c.is_live() && !free[id] {
                return Err(format!("contact slot {id} neither live nor free"));
            }
            if c.is_live() {
                if c.collider_a == c.collider_b || c.body_a == c.body_b {
                    return Err(format!("contact {id} joins a body or a collider to itself"));
                }
                if c.manifold.len() > MAX_MANIFOLD_POINTS || c.bond != NONE && c.manifold.len() != MAX_MANIFOLD_POINTS {
                    return Err(format!("contact {id}: a manifold of {} points", c.manifold.len()));
                }
                if let Some(what) = c.unsound_number() {
                    return Err(format!("contact {id}: {what}"));
                }
                if self.index.insert((c.collider_a, c.collider_b), id as u32).is_some() {
                    return Err(format!("contact {id}: a second contact of its colliders"));
                }
                self.count += 1;
            }
        }
        for c in &mut self.list {
            c.active_pos = NONE;
        }
        for (pos, &id) in self.active.iter().enumerate() {
            match self.list.get_mut(id as usize) {
                Some(c) if c.is_live() && c.active_pos == NONE => c.active_pos = pos as u32,
                _ => return Err(format!("active contact {id}")),
            }
        }
        // Each body's list: walk it from its head, checking the links back.
        let mut visits = vec![0u8; n];
        for (body, &head) in self.body_first.iter().enumerate() {
            let body = body as u32;
            let (mut id, mut prev, mut steps) = (head, NONE, 0);
            while id != NONE {
                let Some(c) = self.list.get(id as usize).filter(|c| c.is_live()) else {
                    return Err(format!("body {body}'s contact list reaches slot {id}"));
                };
                if c.body_a != body && c.body_b != body {
                    return Err(format!("body {body}'s contact list holds contact {id} of other bodies"));
                }
                let side = c.side(body);
                if c.links.prev[side] != prev {
                    return Err(format!("contact {id}: its link back in body {body}'s list"));
                }
                visits[id as usize] += 1;
                steps += 1;
                if steps > n {
                    return Err(format!("body {body}'s contact list loops"));
                }
                (prev, id) = (id, c.links.next[side]);
            }
        }
        for (id, c) in self.list.iter().enumerate() {
            if c.is_live() && visits[id] != 2 {
                return Err(format!("contact {id} is not in both its bodies' lists"));
            }
        }
        Ok(())
    }
}

impl ContactSet {
    /// Bodies with a contact list head (one past the largest body slot a
    /// contact has named).
    pub(crate) fn heads(&self) -> usize {
        self.body_first.len()
    }
}
