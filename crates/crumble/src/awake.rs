//! The awake set and sleep: which bodies a step simulates, the sleeping
//! islands, and the rules by which islands fall asleep and wake (after
//! Box2D's `solver_set.c` and `island.c`).
//!
//! A step looks only at the awake dynamic and kinematic bodies and at the
//! active contacts (those with an awake body). An island whose bodies have
//! all rested for `WorldSettings::time_to_sleep` leaves both; a sleeping
//! body stands in the solver as a static one until something disturbs it
//! (`docs/solver.md`, "Sleep").

use crate::arena::Arena;
use crate::body::{Body, BodyType};
use crate::contact::{ContactSet, NONE, SCAN_AHEAD};
use crate::island::UnionFind;
use crate::math::Vec3;
use crate::world::{Visits, WorldSettings};

/// The awake bodies, the sleeping islands, and per body slot the state
/// bits the contact loops read.
#[derive(Default)]
pub(crate) struct AwakeSet {
    /// Slots of the awake dynamic and kinematic bodies in increasing slot
    /// order, kept incrementally (see `refresh`).
    list: Vec<u32>,
    /// `list` has gained bodies (pushed at the end) or lost some (still
    /// listed) since it was last put in order.
    dirty: bool,
    /// Per body slot: its position in `list` (meaningful for awake bodies
    /// after `refresh`). The union–find works on these positions.
    index: Vec<u32>,
    /// Per body slot: what the contact loops ask of a body (`MOVES`,
    /// `DYNAMIC`, `SLEEPING`; 0 for a free slot), kept with the body's own
    /// flags: one byte per body instead of a `Body` record read twice per
    /// contact in each of the islands stage's loops.
    body_state: Vec<u8>,
    /// Bodies of each sleeping island, by island id.
    sleep_islands: Vec<Vec<u32>>,
    free_sleep_islands: Vec<u32>,
    /// Per body slot: the sleeping island it belongs to, or `u32::MAX`.
    body_island: Vec<u32>,
    /// The islands of the step's awake bodies, on their positions in
    /// `list` (built by `find_islands`, read by `update_sleep`).
    union_find: UnionFind,
    // Scratch of `update_sleep`, kept so that steady state does not
    // allocate.
    newly_asleep: Vec<u32>,
    island_min_rest: Vec<f32>,
    island_of_root: Vec<u32>,
}

impl AwakeSet {
    /// The awake bodies' slots, in slot order once refreshed.
    pub(crate) fn list(&self) -> &[u32] {
        &self.list
    }

    /// Takes in a new body in slot `index`, awake or asleep as `body` says.
    pub(crate) fn insert(&mut self, index: u32, body: &Body) {
        let idx = index as usize;
        if self.body_island.len() <= idx {
            self.body_island.resize(idx + 1, u32::MAX);
            self.index.resize(idx + 1, u32::MAX);
            self.body_state.resize(idx + 1, 0);
        }
        let state = BodyState::of(body);
        self.body_state[idx] = state;
        self.body_island[idx] = u32::MAX;
        if state & BodyState::SLEEPING != 0 {
            let island = self.new_sleep_island();
            self.sleep_islands[island as usize].push(index);
            self.body_island[idx] = island;
        } else if state & BodyState::MOVES != 0 {
            self.list.push(index);
            self.dirty = true;
        }
    }

    /// Forgets the body of slot `index` (woken first if it slept): its
    /// entry in the list is dropped at the next refresh.
    pub(crate) fn remove(&mut self, index: u32) {
        self.body_state[index as usize] = 0;
        self.dirty = true;
    }

    /// Whether a body takes part in this step (dynamic/kinematic and awake).
    pub(crate) fn is_awake(&self, body: u32) -> bool {
        self.state(body) & (BodyState::MOVES | BodyState::SLEEPING) == BodyState::MOVES
    }

    /// `body_state` of a body slot (0 past the end: no body).
    #[inline]
    fn state(&self, body: u32) -> u8 {
        self.body_state.get(body as usize).copied().unwrap_or(0)
    }

    fn new_sleep_island(&mut self) -> u32 {
        if let Some(i) = self.free_sleep_islands.pop() {
            i
        } else {
            self.sleep_islands.push(Vec::new());
            self.sleep_islands.len() as u32 - 1
        }
    }

    /// Wakes the body's sleeping island, if it sleeps: its bodies join the
    /// awake set and all their contacts become active. O(island size +
    /// its contacts).
    pub(crate) fn wake_body(
        &mut self,
        body: u32,
        bodies: &mut Arena<Body>,
        contacts: &mut ContactSet,
        visits: &mut Visits,
    ) {
        let Some(&island) = self.body_island.get(body as usize) else {
            return;
        };
        if island == u32::MAX {
            return;
        }
        let members = std::mem::take(&mut self.sleep_islands[island as usize]);
        for &m in &members {
            self.body_island[m as usize] = u32::MAX;
            if let Some(b) = bodies.at_mut(m) {
                b.sleeping = false;
                b.sleep_time = 0.0;
                self.body_state[m as usize] = BodyState::of(b);
                self.list.push(m);
                self.dirty = true;
            }
            visits.bodies += 1;
        }
        // Every contact of a woken body has an awake body now.
        for &m in &members {
            let mut id = contacts.first_of(m);
            while id != NONE {
                contacts.activate(id);
                visits.contacts += 1;
                id = contacts.next_of(id, m);
            }
        }
        // Give the emptied Vec back so its capacity is reused.
        self.sleep_islands[island as usize] = members;
        self.sleep_islands[island as usize].clear();
        self.free_sleep_islands.push(island);
    }

    /// Puts the list back in order after bodies joined it (pushed at the
    /// end on insert or wake) or left it (still listed after falling
    /// asleep or being removed): drops what is no longer an awake,
    /// non-static body, sorts by slot and drops duplicates (a removed
    /// body's slot may have been reused by a new awake body). Slot order
    /// is the order a scan of every body would give, so the solver's order
    /// does not depend on when bodies woke. O(awake · log awake), and only
    /// when something changed; returns whether it did.
    pub(crate) fn refresh(&mut self, bodies: &Arena<Body>, visits: &mut Visits) -> bool {
        if !self.dirty {
            return false;
        }
        self.dirty = false;
        self.list.retain(|&bi| bodies.at(bi).is_some_and(|b| b.body_type != BodyType::Static && !b.sleeping));
        self.list.sort_unstable();
        self.list.dedup();
        for (k, &bi) in self.list.iter().enumerate() {
            self.index[bi as usize] = k as u32;
        }
        visits.bodies += self.list.len();
        true
    }

    /// Wakes sleeping islands that an awake body disturbs. Only active
    /// contacts can join an awake body to a sleeping one. A woken island
    /// appends its contacts to the active list, and the loop runs on over
    /// them; they keep the manifolds they had when they fell asleep.
    ///
    /// A sleeping body stands in the solver as a static one, so it may
    /// stay asleep as long as nothing it touches would move it: the two do
    /// not rest one on the other (`leaning`: whichever is below may carry
    /// the other's weight, and a sleeping body's weight is never solved,
    /// so nothing else would show that its support slid away or that a
    /// load tips it), the awake body is resting (`moving`) and their
    /// contact carried no real load in the last step (`pushes`). Otherwise
    /// one woken brick would wake its resting neighbours, they theirs, and
    /// a wall created asleep and hit in one place would wake ring by ring
    /// though only the bricks the hit reaches ever move. What is left
    /// asleep: a sleeping body beside (not above or below) an awake one
    /// that rests, or that presses on it less each step than the
    /// threshold's worth.
    pub(crate) fn wake_touched(
        &mut self,
        bodies: &mut Arena<Body>,
        contacts: &mut ContactSet,
        settings: &WorldSettings,
        visits: &mut Visits,
    ) {
        let threshold = settings.sleep_threshold;
        let up = -settings.gravity.normalize_or_zero();
        let mut k = 0;
        while k < contacts.active.len() {
            contacts.prefetch_active(k + SCAN_AHEAD);
            let i = contacts.active[k] as usize;
            k += 1;
            visits.contacts += 1;
            let c = &contacts.list[i];
            if c.manifold.is_empty() {
                continue;
            }
            let (a, b) = (c.body_a, c.body_b);
            let (awake_a, awake_b) = (self.is_awake(a), self.is_awake(b));
            let sleeping = |x: u32| self.state(x) & BodyState::SLEEPING != 0;
            let (mover, sleeper) = if awake_a && sleeping(b) {
                (a, b)
            } else if awake_b && sleeping(a) {
                (b, a)
            } else {
                continue;
            };
            let (m, s) = (bodies.at(mover).expect("awake"), bodies.at(sleeper).expect("sleeping"));
            if leaning(c.manifold.normal, up) || moving(m, threshold) || pushes(c.step_impulse, s, threshold) {
                self.wake_body(sleeper, bodies, contacts, visits);
            }
        }
    }

    /// Wakes the sleeping body of every joint whose other body is awake
    /// and dynamic, or kinematic and moving (`joints`: the joints' body
    /// slots, `NO_BODY` for the world): a joint carries load whether or
    /// not its bodies touch, so a chain sleeps and wakes as one.
    pub(crate) fn wake_jointed(
        &mut self,
        joints: impl Iterator<Item = (u32, u32)>,
        bodies: &mut Arena<Body>,
        contacts: &mut ContactSet,
        visits: &mut Visits,
    ) {
        for (a, b) in joints {
            let sleeping = |x: u32| self.state(x) & BodyState::SLEEPING != 0;
            let disturbs = |x: u32| {
                self.is_awake(x)
                    && (self.state(x) & BodyState::DYNAMIC != 0 || bodies.at(x).is_some_and(|m| moving(m, 0.0)))
            };
            if sleeping(a) && disturbs(b) {
                self.wake_body(a, bodies, contacts, visits);
            } else if sleeping(b) && disturbs(a) {
                self.wake_body(b, bodies, contacts, visits);
            }
        }
    }

    /// Groups awake dynamic bodies into islands over active contacts with
    /// points and over `joints` (body slots, `NO_BODY` for the world). The
    /// union–find runs on positions in the list, so it is reset in
    /// O(awake). Returns the number of islands.
    pub(crate) fn find_islands(
        &mut self,
        bodies: &Arena<Body>,
        contacts: &ContactSet,
        joints: impl Iterator<Item = (u32, u32)>,
        visits: &mut Visits,
    ) -> usize {
        self.union_find.reset(self.list.len());
        visits.contacts += contacts.active.len();
        for (k, &ci) in contacts.active.iter().enumerate() {
            contacts.prefetch_active(k + SCAN_AHEAD);
            let c = &contacts.list[ci as usize];
            if c.manifold.is_empty() {
                continue;
            }
            let dyn_awake = |x: u32| self.state(x) & (BodyState::DYNAMIC | BodyState::SLEEPING) == BodyState::DYNAMIC;
            if dyn_awake(c.body_a) && dyn_awake(c.body_b) {
                self.union_find.union(self.index[c.body_a as usize], self.index[c.body_b as usize]);
            }
        }
        for (a, b) in joints {
            let dyn_awake = |x: u32| self.state(x) & (BodyState::DYNAMIC | BodyState::SLEEPING) == BodyState::DYNAMIC;
            if dyn_awake(a) && dyn_awake(b) {
                self.union_find.union(self.index[a as usize], self.index[b as usize]);
            }
        }
        let mut count = 0;
        visits.bodies += self.list.len();
        for (k, &bi) in self.list.iter().enumerate() {
            let k = k as u32;
            if bodies.at(bi).is_some_and(|b| b.body_type == BodyType::Dynamic) && self.union_find.find(k) == k {
                count += 1;
            }
        }
        count
    }

    /// The island (its root's position in the list) of the awake body at
    /// position `k`, as the step's `find_islands` grouped them.
    pub(crate) fn island_root(&mut self, k: usize) -> u32 {
        self.union_find.find(k as u32)
    }

    /// The position of awake body `body` in the list.
    pub(crate) fn position(&self, body: u32) -> Option<usize> {
        self.is_awake(body).then(|| self.index[body as usize] as usize)
    }

    /// Puts to sleep every island whose bodies have all rested long
    /// enough, and returns the bodies it put to sleep. They leave the list
    /// (at the next refresh) and their contacts leave the active list,
    /// unless the other body is still awake (a kinematic one, or an island
    /// that stays awake), so that from the next step on the island costs
    /// nothing. O(awake + contacts of the bodies put to sleep): the
    /// union–find roots are positions in the list.
    pub(crate) fn update_sleep(
        &mut self,
        bodies: &mut Arena<Body>,
        contacts: &mut ContactSet,
        settings: &WorldSettings,
        visits: &mut Visits,
    ) -> &[u32] {
        self.newly_asleep.clear();
        if !settings.sleep_enabled {
            return &self.newly_asleep;
        }
        let n = self.list.len();
        self.island_min_rest.clear();
        self.island_min_rest.resize(n, f32::INFINITY);
        self.island_of_root.clear();
        self.island_of_root.resize(n, u32::MAX);
        visits.bodies += 2 * n;
        for k in 0..n {
            let b = bodies.at(self.list[k]).expect("awake");
            if b.body_type != BodyType::Dynamic {
                continue;
            }
            let root = self.union_find.find(k as u32) as usize;
            let rest = if b.can_sleep { b.sleep_time } else { 0.0 };
            self.island_min_rest[root] = self.island_min_rest[root].min(rest);
        }
        let time_to_sleep = settings.time_to_sleep;
        for k in 0..n {
            let bi = self.list[k];
            if bodies.at(bi).expect("awake").body_type != BodyType::Dynamic {
                continue;
            }
            let root = self.union_find.find(k as u32) as usize;
            if self.island_min_rest[root] < time_to_sleep {
                continue;
            }
            if self.island_of_root[root] == u32::MAX {
                self.island_of_root[root] = self.new_sleep_island();
            }
            let island = self.island_of_root[root];
            self.sleep_islands[island as usize].push(bi);
            self.body_island[bi as usize] = island;
            let b = bodies.at_mut(bi).expect("awake");
            b.sleeping = true;
            b.linear_velocity = Vec3::ZERO;
            b.angular_velocity = Vec3::ZERO;
            self.body_state[bi as usize] = BodyState::of(b);
            self.newly_asleep.push(bi);
        }
        if self.newly_asleep.is_empty() {
            return &self.newly_asleep;
        }
        self.dirty = true;
        // Set their contacts aside once every body has its new state (a
        // contact between two bodies of the island is seen from both).
        for &bi in &self.newly_asleep {
            let mut id = contacts.first_of(bi);
            while id != NONE {
                visits.contacts += 1;
                let other = contacts.list[id as usize].other(bi);
                if !self.is_awake(other) {
                    contacts.deactivate(id);
                }
                id = contacts.next_of(id, bi);
            }
        }
        &self.newly_asleep
    }

    /// Checks the bookkeeping against the bodies and contacts and panics on
    /// the first inconsistency (see `World::validate`).
    pub(crate) fn validate(&self, bodies: &Arena<Body>, contacts: &ContactSet) {
        for (i, &state) in self.body_state.iter().enumerate() {
            let want = bodies.at(i as u32).map_or(0, BodyState::of);
            assert_eq!(state, want, "state bits of body slot {i}");
        }
        let mut awake = self.list.clone();
        if self.dirty {
            awake.retain(|&bi| self.is_awake(bi));
            awake.sort_unstable();
            awake.dedup();
        } else {
            assert!(awake.windows(2).all(|w| w[0] < w[1]), "awake set out of order");
            for (k, &bi) in awake.iter().enumerate() {
                assert_eq!(self.index[bi as usize], k as u32, "awake position of body {bi}");
            }
        }
        let expected: Vec<u32> = bodies
            .iter()
            .filter(|(_, b)| !b.sleeping && b.body_type != BodyType::Static)
            .map(|(h, _)| h.index)
            .collect();
        assert_eq!(awake, expected, "awake set");
        for (h, b) in bodies.iter() {
            let island = self.body_island[h.index as usize];
            if b.sleeping {
                assert_ne!(island, u32::MAX, "sleeping body {} in no island", h.index);
                assert!(
                    self.sleep_islands[island as usize].contains(&h.index),
                    "island {island} lost body {}",
                    h.index
                );
            } else {
                assert_eq!(island, u32::MAX, "awake body {} in island {island}", h.index);
            }
        }
        for c in contacts.iter() {
            let id = contacts.id_of(c.collider_a, c.collider_b).expect("indexed");
            let should = self.is_awake(c.body_a) || self.is_awake(c.body_b);
            assert_eq!(contacts.is_active(id), should, "contact {id} activity (bodies {} {})", c.body_a, c.body_b);
        }
    }
}

/// The bits of `AwakeSet::body_state`.
struct BodyState;

impl BodyState {
    /// Dynamic or kinematic (not static).
    const MOVES: u8 = 1;
    /// Dynamic.
    const DYNAMIC: u8 = 2;
    /// Asleep (only a dynamic body sleeps).
    const SLEEPING: u8 = 4;

    /// The bits of a live body.
    fn of(b: &Body) -> u8 {
        let mut s = 0;
        if b.body_type != BodyType::Static {
            s |= Self::MOVES;
        }
        if b.body_type == BodyType::Dynamic {
            s |= Self::DYNAMIC;
        }
        if b.sleeping {
            s |= Self::SLEEPING;
        }
        s
    }
}

/// The sleep threshold's bound for small bodies: speeds below this many of
/// the body's largest extents a second count as resting (see [`resting`]).
const SLEEP_SIZES_PER_SECOND: f32 = 0.5;

/// Whether an awake body moves enough to disturb a sleeping one it
/// touches: a dynamic body at or above the sleep threshold (the speed
/// at which it would not count as resting; angular speed through its
/// largest extent), a kinematic one at any speed (nothing else can stop
/// it, and a static stand-in cannot push back on it).
fn moving(b: &Body, threshold: f32) -> bool {
    match b.body_type {
        BodyType::Kinematic => b.linear_velocity != Vec3::ZERO || b.angular_velocity != Vec3::ZERO,
        _ => !resting(b, threshold),
    }
}

/// Whether a body counts as resting for sleep: slower than `threshold`,
/// or than half its largest extent a second if that is less, its angular
/// speed counted through its largest extent. The threshold (5 cm/s by
/// default) suits bricks and boulders; a 1 mm grain creeping at 5 cm/s
/// crosses fifty times its size a second and is not at rest, so a body
/// smaller than about 10 cm must be slower than half its size a second.
pub(crate) fn resting(b: &Body, threshold: f32) -> bool {
    let threshold = threshold.min(SLEEP_SIZES_PER_SECOND * b.max_extent);
    b.linear_velocity.length() < threshold && b.angular_velocity.length() * b.max_extent < threshold
}

/// Whether a contact with normal `normal` may carry weight: under gravity
/// (`up` the unit vector against it; zero without gravity) a normal
/// within 84° of the vertical (`|n · up| > 0.1`) means one body rests on
/// the other, partly at least. Side contacts of a wall's bricks are
/// horizontal and do not count.
fn leaning(normal: Vec3, up: Vec3) -> bool {
    normal.dot(up).abs() > 0.1
}

/// Whether a contact's normal impulse over the last step, `impulse`,
/// would have set the sleeping body `s` (standing in as static) moving at
/// the sleep threshold or faster, so that it would not count as resting.
/// A brick's weight on an equal brick does at 60 Hz (g·dt = 0.16 m/s
/// against 0.05 m/s); the few cm/s with which bricks at rest relay a
/// distant push through a wall in zero gravity do not.
fn pushes(impulse: f32, s: &Body, threshold: f32) -> bool {
    impulse * s.inv_mass >= threshold
}

// The awake list and the sleeping islands; the per-body records follow
// from them and the bodies (`restored`).
crate::snapshot::codec::persist!(AwakeSet {
    list, dirty, sleep_islands, free_sleep_islands,
} scratch {
    index, body_state, body_island, union_find, newly_asleep, island_min_rest, island_of_root,
});

impl AwakeSet {
    /// Fills in a restored set's per-body records from its list, its
    /// islands and the bodies, checking that they agree: each listed body
    /// in range (and, once the list is in order, live, awake, moving and
    /// listed once), each sleeping body in one island, each island's
    /// bodies asleep, the free islands empty.
    pub(crate) fn restored(&mut self, bodies: &crate::arena::Arena<Body>) -> Result<(), String> {
        let n = bodies.slot_count();
        self.body_state = (0..n as u32).map(|i| bodies.at(i).map_or(0, BodyState::of)).collect();
        self.index = vec![u32::MAX; n];
        self.body_island = vec![u32::MAX; n];
        let mut last = None;
        for (k, &i) in self.list.iter().enumerate() {
            let Some(&state) = self.body_state.get(i as usize) else {
                return Err(format!("awake body {i} out of range"));
            };
            // A list not yet put in order (`dirty`) may still hold bodies
            // since removed or put to sleep, and a slot twice (`refresh`
            // drops them).
            let awake = state & (BodyState::MOVES | BodyState::SLEEPING) == BodyState::MOVES;
            if !self.dirty && (!awake || last.is_some_and(|l| l >= i)) {
                return Err(format!("awake body {i}"));
            }
            last = Some(i);
            self.index[i as usize] = k as u32;
        }
        let mut free = vec![false; self.sleep_islands.len()];
        for &k in &self.free_sleep_islands {
            match free.get_mut(k as usize) {
                Some(f) if !*f && self.sleep_islands[k as usize].is_empty() => *f = true,
                _ => return Err(format!("free sleeping island {k}")),
            }
        }
        for (k, island) in self.sleep_islands.iter().enumerate() {
            for &i in island {
                let asleep = self.body_state.get(i as usize).is_some_and(|&s| s & BodyState::SLEEPING != 0);
                if !asleep || self.body_island[i as usize] != u32::MAX {
                    return Err(format!("sleeping island {k}: body {i}"));
                }
                self.body_island[i as usize] = k as u32;
            }
        }
        for (h, b) in bodies.iter() {
            let i = h.index as usize;
            if b.sleeping && (b.body_type != BodyType::Dynamic || self.body_island[i] == u32::MAX) {
                return Err(format!("body {i} sleeps in no island"));
            }
            // (`refresh` only ever drops bodies from the list.)
            if !b.sleeping && b.body_type != BodyType::Static && self.index[i] == u32::MAX {
                return Err(format!("body {i} is awake but not in the awake list"));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
impl AwakeSet {
    /// Tests: the awake list, to forge a snapshot's.
    pub(crate) fn list_mut(&mut self) -> &mut Vec<u32> {
        &mut self.list
    }
}
