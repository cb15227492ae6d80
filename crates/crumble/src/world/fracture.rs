//! The fracture stage of the step (`fracture.rs` has the model): the
//! breakable boxes' velocities are noted when the step starts; the boxes
//! are judged on the step's impulses (contacts, bonds, joints) before the
//! bonds are (which use theirs up), and split once the step is over, in a
//! fixed order, so that the same bodies split into the same pieces with
//! the same handles on any thread count.

use crate::body::{BodyBuilder, BodyHandle, BodyType};
use crate::bond::BondSpec;
use crate::collider::{ColliderBuilder, Material, Strength};
use crate::contact::NONE;
use crate::fracture::{piece, worst_cut, BoxState, Cut, FractureEvent, Load};
use crate::math::{Mat3, Pose, Vec3};
use crate::shape::Shape;

use super::World;

/// A body that may break, as `World::breakable` finds it.
struct Breakable {
    /// Its collider's pose.
    pose: Pose,
    half: Vec3,
    material: Material,
    strength: Strength,
}

/// The fracture stage's state: the events of the last step and per-step
/// scratch.
#[derive(Default)]
pub(super) struct FractureSet {
    /// Whether a collider of a breakable material was ever inserted: until
    /// then the stage costs nothing.
    pub any: bool,
    /// The splits of the last step.
    pub events: Vec<FractureEvent>,
    /// Per step: the breakable bodies awake when the solver starts, with
    /// what they were then.
    start: Vec<Start>,
    /// Per step: the bodies that break, with their plane.
    cuts: Vec<(u32, Cut)>,
    loads: Vec<Load>,
    /// Per body: each contact's friction (centre, impulse, twist).
    frictions: Vec<(Vec3, Vec3, Vec3)>,
    /// Per step: the joints' loads, by body slot, the point in the
    /// body's frame.
    jointed: Vec<(u32, Load)>,
}

/// A breakable body when the solver starts its step.
#[derive(Clone, Copy)]
struct Start {
    body: u32,
    /// Its pose and its collider's.
    pose: Pose,
    collider_pose: Pose,
    linear_velocity: Vec3,
    angular_velocity: Vec3,
    /// The force and torque the caller applied for the step.
    force: Vec3,
    torque: Vec3,
}

impl World {
    /// A body that may break (dynamic, with one collider, a box of a
    /// breakable material), with its collider's pose, its box's half
    /// extents and its material.
    fn breakable(&self, body: u32) -> Option<Breakable> {
        let b = self.bodies.at(body)?;
        if b.body_type != BodyType::Dynamic || b.colliders.len() != 1 {
            return None;
        }
        let c = self.colliders.at(b.colliders[0])?;
        match (&c.shape, c.material.strength) {
            (Shape::Cuboid(cuboid), Some(strength)) => {
                Some(Breakable { pose: c.world_pose, half: cuboid.half_extents(), material: c.material, strength })
            }
            _ => None,
        }
    }

    /// Notes the awake breakable bodies as the solver is about to start:
    /// their poses (the narrow phase found their contacts' points there),
    /// velocities, and the forces applied to them. (After the islands,
    /// which wake the sleeping bodies the step disturbs: a sleeping brick
    /// struck in this step is judged on the blow that woke it.)
    pub(super) fn begin_fracture(&mut self) {
        self.fracture.start.clear();
        if !self.fracture.any {
            return;
        }
        for k in 0..self.awake.list().len() {
            let i = self.awake.list()[k];
            if let Some(br) = self.breakable(i) {
                let b = self.bodies.at(i).expect("awake bodies are live");
                self.fracture.start.push(Start {
                    body: i,
                    pose: b.pose,
                    collider_pose: br.pose,
                    linear_velocity: b.linear_velocity,
                    angular_velocity: b.angular_velocity,
                    force: b.force,
                    torque: b.torque,
                });
            }
        }
    }

    /// Judges each breakable body noted at the start of the step on the
    /// step's impulses (`fracture.rs`); keeps those that break, the most
    /// overloaded first, at most `max_new_pieces / 2` of them.
    pub(super) fn judge_fractures(&mut self, dt: f32) {
        self.fracture.cuts.clear();
        if self.fracture.start.is_empty() {
            return;
        }
        let start = std::mem::take(&mut self.fracture.start);
        let mut loads = std::mem::take(&mut self.fracture.loads);
        let substeps = self.settings.substeps as f32;
        // The joints' loads on their bodies, by body slot: the step's force
        // at the anchor (on b; a feels the opposite) and the angular rows'
        // torque.
        let mut jointed = std::mem::take(&mut self.fracture.jointed);
        jointed.clear();
        for (_, j) in self.joints.arena.iter() {
            let (f, t) = (j.force * dt, j.torque * dt);
            for (body, local, sign) in [(j.a, j.local_a, -1.0), (j.b, j.local_b, 1.0)] {
                if self.bodies.at(body).is_some() {
                    jointed.push((body, Load { point: local, impulse: f * sign, angular: t * sign }));
                }
            }
        }
        jointed.sort_by_key(|&(body, _)| body);
        for st in &start {
            let i = st.body;
            let Some(br) = self.breakable(i) else {
                continue;
            };
            let b = self.bodies.at(i).expect("breakable");
            // A body the step faulted was put back and stopped: its change
            // of velocity is no load's.
            if b.faulted {
                continue;
            }
            loads.clear();
            // Friction's resultant and moment (with the twist), gathered
            // over the contacts and applied once at the friction's centre:
            // the resultant is determinate, but how a rigid solver shares
            // it among several sticking contacts is not, and the pairs of
            // opposite frictions it may leave (a brick on two supports
            // squeezed by them) would read as an axial force and a
            // moment across every section.
            let (mut f_sum, mut f_weight, mut f_centre) = (Vec3::ZERO, 0.0f32, Vec3::ZERO);
            let first_friction = self.fracture.frictions.len();
            let mut id = self.contacts.first_of(i);
            while id != NONE {
                let ct = &self.contacts.list[id as usize];
                let next = self.contacts.next_of(id, i);
                let points = ct.manifold.points();
                if !points.is_empty() {
                    // Impulses in the contact are on B; A takes the opposite.
                    let sign = if ct.body_b == i { 1.0 } else { -1.0 };
                    let n = ct.manifold.normal;
                    let centre = points.iter().map(|p| p.point).sum::<Vec3>() / points.len() as f32;
                    let (friction, twist) = if ct.bond != NONE {
                        let bi = ct.bond_impulse;
                        for (k, p) in points.iter().enumerate() {
                            loads.push(Load {
                                point: p.point,
                                impulse: n * (bi.normal[k] * sign),
                                angular: Vec3::ZERO,
                            });
                        }
                        (bi.friction * sign, n * (bi.twist * sign) + ct.rolling_impulse * (substeps * sign))
                    } else {
                        // The step's normal impulse shared over the points
                        // as the last substep shared it; friction and twist
                        // as the last substep's, once a substep.
                        let last: f32 = ct.normal_impulse[..points.len()].iter().sum();
                        for (k, p) in points.iter().enumerate() {
                            let share =
                                if last > 0.0 { ct.normal_impulse[k] / last } else { 1.0 / points.len() as f32 };
                            loads.push(Load {
                                point: p.point,
                                impulse: n * (ct.step_impulse * share * sign),
                                angular: Vec3::ZERO,
                            });
                        }
                        let turn = n * ct.twist_impulse + ct.rolling_impulse;
                        (ct.friction_impulse * (substeps * sign), turn * (substeps * sign))
                    };
                    f_sum += friction;
                    f_weight += friction.length();
                    f_centre += centre * friction.length();
                    self.fracture.frictions.push((centre, friction, twist));
                }
                id = next;
            }
            let first = jointed.partition_point(|&(body, _)| body < i);
            loads.extend(
                jointed[first..]
                    .iter()
                    .take_while(|&&(body, _)| body == i)
                    .map(|&(_, l)| Load { point: st.pose.transform_point(l.point), ..l }),
            );
            let c_f = if f_weight > 0.0 { f_centre / f_weight } else { st.collider_pose.position };
            let mut f_moment = Vec3::ZERO;
            for &(p, f, t) in &self.fracture.frictions[first_friction..] {
                f_moment += (p - c_f).cross(f) + t;
            }
            self.fracture.frictions.truncate(first_friction);
            loads.push(Load { point: c_f, impulse: f_sum, angular: f_moment });
            let r = glam::Mat3::from_quat(st.pose.rotation);
            let inv_inertia = r * b.local_inv_inertia * r.transpose();
            let state = BoxState {
                centre: st.collider_pose.position,
                rotation: st.collider_pose.rotation,
                rotation_end: br.pose.rotation,
                half: br.half,
                mass: b.mass,
                v0: st.linear_velocity,
                w0: st.angular_velocity,
                v1: b.linear_velocity,
                w1: b.angular_velocity,
                body_impulse: (self.settings.gravity * (b.gravity_scale * b.mass) + st.force) * dt,
                torque_spin: inv_inertia * st.torque * dt,
            };
            if let Some(cut) = worst_cut(&state, &loads, br.strength, dt, self.settings.min_piece) {
                if cut.ratio >= 1.0 {
                    self.fracture.cuts.push((i, cut));
                }
            }
        }
        // The most overloaded first (ties: the lower slot), within the cap;
        // then split in slot order.
        let cuts = &mut self.fracture.cuts;
        cuts.sort_by(|a, b| b.1.ratio.total_cmp(&a.1.ratio).then(a.0.cmp(&b.0)));
        cuts.truncate((self.settings.max_new_pieces / 2) as usize);
        cuts.sort_by_key(|c| c.0);
        self.fracture.start = start;
        self.fracture.loads = loads;
        self.fracture.jointed = jointed;
    }

    /// Splits the bodies `judge_fractures` kept; returns how many split.
    pub(super) fn apply_fractures(&mut self) -> usize {
        let cuts = std::mem::take(&mut self.fracture.cuts);
        for &(i, cut) in &cuts {
            self.split(i, cut);
        }
        let n = cuts.len();
        self.fracture.cuts = cuts;
        n
    }

    /// Replaces body `i` by the two pieces of `cut` (`fracture.rs`, "The
    /// pieces").
    pub(super) fn split(&mut self, i: u32, cut: Cut) {
        let Some(Breakable { pose, half, material, .. }) = self.breakable(i) else {
            return;
        };
        let b = self.bodies.at(i).expect("breakable");
        let parent = BodyHandle(self.bodies.handle_at(i).expect("live"));
        let (v, w) = (b.linear_velocity, b.angular_velocity);
        let builder = BodyBuilder {
            linear_damping: b.linear_damping,
            angular_damping: b.angular_damping,
            gravity_scale: b.gravity_scale,
            can_sleep: b.can_sleep,
            bullet: b.bullet,
            user_data: b.user_data,
            ..BodyBuilder::dynamic()
        };
        let r = Mat3::from_quat(pose.rotation);
        // The parent's bonds, to pass on to the pieces that still touch
        // (from the bonds themselves: a bond made this step, to a piece of
        // a neighbour that split before this body, has no contact yet).
        let bonded: Vec<(BodyHandle, BondSpec)> = self
            .bonds
            .arena
            .iter()
            .filter(|(_, bond)| bond.body_a == i || bond.body_b == i)
            .map(|(_, bond)| (if bond.body_a == i { bond.handle_b } else { bond.handle_a }, bond.spec))
            .collect();
        let joints = self.joints_of(i);
        let body_pose = b.pose;
        // Both pieces must be bodies the world takes (a piece too thin or
        // too light for `f32` masses is refused), else the body stays whole.
        let shapes = [-1.0f32, 1.0].map(|side| {
            let (centre, h) = piece(half, cut.axis, cut.offset, side);
            let shape = ColliderBuilder::cuboid(h.x, h.y, h.z).ok()?;
            crate::mass::check_shape(&shape.shape, material.density).ok()?;
            Some((centre, shape))
        });
        let [Some(negative), Some(positive)] = shapes else {
            return;
        };
        // The pieces' bodies, in the parent's rigid field (`fracture.rs`,
        // "The pieces"); a velocity past `f32` there (a parent spinning
        // near its largest) keeps the body whole.
        let bodies = [negative, positive].map(|(centre, shape)| {
            let at = pose.position + r * centre;
            let linear_velocity = v + w.cross(at - pose.position);
            let body =
                BodyBuilder { pose: Pose::new(at, pose.rotation), linear_velocity, angular_velocity: w, ..builder };
            (at.is_finite() && linear_velocity.is_finite()).then_some((body, shape))
        });
        let [Some(negative), Some(positive)] = bodies else {
            return;
        };
        if self.remove_body(parent).is_err() {
            return;
        }
        let mut pieces = [parent; 2];
        for (k, (body, shape)) in [negative, positive].into_iter().enumerate() {
            // (Neither can fail: the pose and velocities are finite, the
            // rotation is the collider's (of unit length), and the shapes
            // were checked.)
            let Ok(handle) = self.insert_body(body) else { continue };
            if self.insert_collider(shape.material(material), handle).is_err() {
                let _ = self.remove_body(handle);
                continue;
            }
            pieces[k] = handle;
        }
        debug_assert!(pieces.iter().all(|&p| p != parent), "a checked piece was refused");
        // The parent's joints pass to the piece that holds their anchor.
        if pieces.iter().all(|&p| p != parent) {
            let (axis, offset) = (cut.axis, cut.offset);
            for joint in joints {
                let pick = |anchor: Vec3| pieces[usize::from(pose.inverse_transform_point(anchor)[axis] > offset)];
                self.pass_joint(joint, i, body_pose, pick);
            }
        }
        for &(other, spec) in &bonded {
            for &p in &pieces {
                if p != parent {
                    // A piece that no longer touches the neighbour face to
                    // face keeps no bond with it.
                    let _ = self.insert_bond(p, other, spec);
                }
            }
        }
        self.fracture.events.push(FractureEvent::Split {
            parent,
            pieces,
            axis: cut.axis,
            offset: cut.offset,
            mode: cut.mode,
            ratio: cut.ratio,
        });
    }

    /// What broke in the last step (see [`FractureEvent`]), in the order
    /// the bodies split.
    pub fn fracture_events(&self) -> &[FractureEvent] {
        &self.fracture.events
    }
}

crate::snapshot::codec::persist!(FractureSet { any } scratch { events, start, cuts, loads, frictions, jointed });
