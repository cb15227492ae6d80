//! Independent constraint groups, so that several threads can solve
//! contacts at once while the result stays that of one fixed
//! Gauss–Seidel order.
//!
//! Two constraints that share a moving body cannot be solved at the same
//! time: both read and write that body's velocity. The static stand-in
//! (solver slot 0) is never changed by the solver, so it is not shared.
//!
//! The constraints are cut into *groups*, each solved in the original
//! (bottom-up) order by one thread, so that a pass still carries a
//! correction through a whole stack. An island of at most
//! [`SERIAL_ISLAND_MAX`] constraints is one group, unless it is most of its
//! unit and larger than [`SMALL_STRIPED_MIN`]; a larger island is cut
//! into vertical *stripes* along its longer horizontal axis. A constraint
//! inside a stripe belongs to that stripe's group, one between neighbouring
//! stripes to their *boundary* group, whose constraints are coloured
//! greedily ([`COLOURS`]) so that they do not form one long chain. The
//! groups run in four phases whose groups share no moving body: the small
//! islands and stripe interiors, the even boundaries, the odd boundaries,
//! and the overflow (constraints between stripes further apart).
//!
//! The groups are gathered into *units* that share no moving body (each
//! large island alone, small islands together up to [`UNIT_CONSTRAINTS`]);
//! the solver runs each unit's substeps to the end before the next, and a
//! unit's result is that of solving it alone. The grouping depends only on
//! the constraints, their order and the bodies' positions, never on the
//! number of threads, and it is kept while the pairs stay the same
//! ([`Partition::unchanged`]). Constraints that name a moving body twice or
//! a body out of range are a last unit of their own ([`Partition::odd`]).
//! Why groups rather than colours, and the measurements behind the sizes:
//! `docs/solver.md`, "Groups, stripes and units".

use std::ops::Range;

use crate::island::UnionFind;
use crate::math::Vec3;

/// An island with at most this many constraints is solved as one group,
/// unless it is most of its unit (see [`SMALL_STRIPED_MIN`]).
pub(crate) const SERIAL_ISLAND_MAX: usize = 1024;

/// Constraints per stripe that a larger island is cut into (about).
pub(crate) const STRIPE_CONSTRAINTS: usize = 1024;

/// A small island with more constraints than this that holds at least
/// half of its unit's is cut into stripes of [`SMALL_STRIPE_CONSTRAINTS`]
/// (a unit that is mostly one island has too few chains to fill the
/// solver's lanes).
pub(crate) const SMALL_STRIPED_MIN: usize = 128;

/// Constraints per stripe of a small island that is cut (about).
pub(crate) const SMALL_STRIPE_CONSTRAINTS: usize = 32;

/// Small islands share a unit until it holds at least this many
/// constraints (~0.7 MB of batches, so that a unit's working set stays
/// within a typical second-level cache through its passes).
pub(crate) const UNIT_CONSTRAINTS: usize = 1024;

/// Phases of the groups, in solve order.
pub(crate) const PHASES: usize = 4;

/// Colours of a boundary group (see the module docs); a constraint that
/// would need more takes the last, in its order.
const COLOURS: u32 = 8;
// A body's colours in a boundary are the bits of a `u8`.
const _: () = assert!(COLOURS <= 8);

const INTERIOR: u32 = 0;
const EVEN: u32 = 1;
const ODD: u32 = 2;
const OVERFLOW: u32 = 3;

/// No stripe: the body is not in a striped island.
const NONE: u32 = u32::MAX;

#[derive(Default)]
pub(crate) struct Partition {
    union_find: UnionFind,
    /// Per body, at its island's root: the island's constraint count.
    island_size: Vec<u32>,
    /// Per body, at its island's root: the first local group id of the
    /// island in each of the phases 0–2 within its unit (`NONE` until
    /// seen).
    island_base: Vec<[u32; 3]>,
    /// Per body, at its island's root: the island's unit (`NONE` until
    /// seen).
    unit_of: Vec<u32>,
    /// Per unit: groups in each of the phases 0–2 (the overflow is one).
    unit_groups: Vec<[u32; 3]>,
    /// Per unit: its constraints.
    unit_size: Vec<u32>,
    /// Island roots in the order their first constraint comes (scratch).
    roots: Vec<u32>,
    /// Per body, at its island's root (striped islands): bounding box of the
    /// bodies' centres, then the stripe count in `stripes`.
    bounds: Vec<(Vec3, Vec3)>,
    stripes: Vec<u32>,
    /// Per body: its stripe (striped islands) or `NONE`.
    stripe: Vec<u32>,
    /// Per body, for its even and its odd boundary group: a tag of the
    /// group (`island_base` plus the boundary's index: unique within the
    /// unit, and a body is in one unit) and the colours the body has there
    /// (scratch).
    colours: Vec<[(u32, u8); 2]>,
    /// Striped islands' bodies: (root, coordinate along the cut axis, body).
    sorted: Vec<(u32, f32, u32)>,
    /// Per constraint: unit, phase and group id within both (see `pack`),
    /// then its global group id.
    key: Vec<u64>,
    /// Per unit and phase: its first global group id (scratch).
    offset: Vec<[u32; PHASES]>,
    /// Per global id (a group, or one colour of a boundary group): start
    /// in the reordered constraints.
    start: Vec<u32>,
    /// Output: non-empty groups' ranges, unit after unit, phase after
    /// phase.
    groups: Vec<Range<usize>>,
    /// Output: per unit, each phase's range in `groups`.
    units: Vec<[Range<usize>; PHASES]>,
    /// Output: whether the last unit holds the odd pairs.
    odd: bool,
    /// What the last `build` grouped (`Partition::unchanged`): its pairs,
    /// body count and `up`; `kept` is false when there is no such build
    /// (none yet, or `all_serial` since). `pairs_now` holds the pairs
    /// being grouped, compared with `last_pairs` (scratch; the two trade
    /// places when the grouping is made afresh).
    last_pairs: Vec<(u32, u32)>,
    pairs_now: Vec<(u32, u32)>,
    last_bodies: usize,
    last_up: Vec3,
    kept: bool,
    /// Counts the groupings made (`generation`; it wraps, being only
    /// compared for equality, so that a restored count never overflows).
    generation: u64,
}

/// The items (constraints, or batches of them) that a unit's groups
/// cover, given its phases' ranges in `groups`: a unit's groups are laid
/// out together, so they span one range.
pub(crate) fn unit_span(groups: &[Range<usize>], phases: &[Range<usize>; PHASES]) -> Range<usize> {
    let first = phases.iter().find(|r| !r.is_empty()).map(|r| r.start);
    let last = phases.iter().rev().find(|r| !r.is_empty()).map(|r| r.end);
    match (first, last) {
        (Some(a), Some(b)) => groups[a].start..groups[b - 1].end,
        _ => 0..0,
    }
}

/// Group ids a group of `phase` takes: one per colour for a boundary,
/// else one.
fn ids_per_group(phase: u32) -> u32 {
    if phase == EVEN || phase == ODD {
        COLOURS
    } else {
        1
    }
}

/// The colour of a constraint on moving bodies `pair` (0: the static
/// stand-in, which orders nothing) in the boundary group tagged `tag`, on
/// side `side` (0 even, 1 odd) of `colours` (see `Partition::colours`):
/// the smallest that neither body has there yet, or the last; both bodies
/// then have it.
fn colour(colours: &mut [[(u32, u8); 2]], side: usize, tag: u32, pair: [usize; 2]) -> u32 {
    let mut used = 0u8;
    for x in pair.into_iter().filter(|&x| x != 0) {
        let (g, m) = colours[x][side];
        if g == tag {
            used |= m;
        }
    }
    let colour = (!used).trailing_zeros().min(COLOURS - 1);
    for x in pair.into_iter().filter(|&x| x != 0) {
        let e = &mut colours[x][side];
        if e.0 != tag {
            *e = (tag, 0);
        }
        e.1 |= 1 << colour;
    }
    colour
}

/// A constraint's unit, phase and group within them, in one sortable key.
fn pack(unit: u32, phase: u32, local: u32) -> u64 {
    (unit as u64) << 34 | (phase as u64) << 32 | local as u64
}

impl Partition {
    /// Groups constraints given as `(a, b)` solver-body pairs, in order, for
    /// `bodies` solver bodies whose centres are `center(i)`; `up` is
    /// against gravity (zero without gravity). Returns false when the
    /// last grouping stands (see [`unchanged`](Self::unchanged)): the
    /// outputs, and the order [`slots`](Self::slots) gave, stay as they
    /// were, and `slots` must not be called.
    ///
    /// `links` are the step's joints as solver-body pairs: they are no
    /// constraints of the groups, but they join islands, so that a unit
    /// holds every body its joints reach (the joints are solved with their
    /// unit, `solver/joints.rs`). An island of joints alone has no unit
    /// here ([`unit_of_body`](Self::unit_of_body) says `None`).
    pub fn build(
        &mut self,
        bodies: usize,
        pairs: impl Iterator<Item = (u32, u32)> + Clone,
        links: impl Iterator<Item = (u32, u32)> + Clone,
        center: impl Fn(usize) -> Vec3,
        up: Vec3,
    ) -> bool {
        self.pairs_now.clear();
        self.pairs_now.extend(pairs.clone());
        // The links after a mark, so that the same pairs with other links
        // (or none) never compare equal.
        self.pairs_now.push((u32::MAX, u32::MAX));
        self.pairs_now.extend(links.clone());
        if self.unchanged(bodies, up) {
            return false;
        }
        std::mem::swap(&mut self.pairs_now, &mut self.last_pairs);
        (self.last_bodies, self.last_up) = (bodies, up);
        self.group(bodies, pairs, links, center, up);
        self.kept = true;
        self.generation = self.generation.wrapping_add(1);
        true
    }

    /// A number that changes whenever the outputs may have: what a
    /// placement of the groups was made for.
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// Whether the last grouping stands: the same pairs in the same order
    /// (so the same islands, units and colours), `bodies` and `up`. The
    /// stripes of a striped island are then kept as they were cut, though
    /// its bodies have moved: any cut into stripes gives groups that share
    /// no moving body. Cut afresh, a resting wall's stripes would differ
    /// from step to step where the sort is close, bricks stacked in one
    /// column having the same coordinate to within their sway; an island
    /// that moves as a whole while keeping its pairs (slides, or leans in
    /// its own plane) keeps stripes that a fresh cut might place along
    /// another axis, still valid, perhaps slower to converge. A resting
    /// scene thus keeps its grouping and the order of its constraints step
    /// after step, and skips the grouping's sort.
    fn unchanged(&self, bodies: usize, up: Vec3) -> bool {
        self.kept && bodies == self.last_bodies && up == self.last_up && self.pairs_now == self.last_pairs
    }

    /// The grouping itself (see [`build`](Self::build)).
    fn group(
        &mut self,
        bodies: usize,
        pairs: impl Iterator<Item = (u32, u32)> + Clone,
        links: impl Iterator<Item = (u32, u32)>,
        center: impl Fn(usize) -> Vec3,
        up: Vec3,
    ) {
        self.union_islands(bodies, pairs.clone(), links);
        self.gather_units(bodies);
        self.cut_stripes(bodies, center, up);
        self.assign_groups(bodies, pairs);
        self.lay_out_groups();
    }

    /// Islands over the moving bodies (kinematic ones too: the solver
    /// would write them, so they may not be shared between groups): their
    /// constraint counts at their roots, and the roots in the order their
    /// first constraint comes.
    fn union_islands(
        &mut self,
        bodies: usize,
        pairs: impl Iterator<Item = (u32, u32)> + Clone,
        links: impl Iterator<Item = (u32, u32)>,
    ) {
        self.union_find.reset(bodies);
        for (a, b) in pairs.clone().chain(links) {
            let (a, b) = (a as usize, b as usize);
            if valid(bodies, a, b) && a != 0 && b != 0 {
                self.union_find.union(a as u32, b as u32);
            }
        }
        self.island_size.clear();
        self.island_size.resize(bodies, 0);
        self.roots.clear();
        for (a, b) in pairs {
            let (a, b) = (a as usize, b as usize);
            if valid(bodies, a, b) {
                let r = root_of(&mut self.union_find, a, b);
                if self.island_size[r] == 0 {
                    self.roots.push(r as u32);
                }
                self.island_size[r] += 1;
            }
        }
    }

    /// Units, numbered in order of first appearance: each large island
    /// alone, small ones together until the open unit holds
    /// `UNIT_CONSTRAINTS`.
    fn gather_units(&mut self, bodies: usize) {
        self.unit_of.clear();
        self.unit_of.resize(bodies, NONE);
        self.unit_size.clear();
        // The unit taking small islands, and its constraints so far.
        let mut open: Option<(u32, usize)> = None;
        for &r in &self.roots {
            let size = self.island_size[r as usize] as usize;
            let unit = match open {
                Some((u, n)) if !large(size as u32) && n < UNIT_CONSTRAINTS => {
                    open = Some((u, n + size));
                    u
                }
                _ => {
                    let u = self.unit_size.len() as u32;
                    self.unit_size.push(0);
                    if !large(size as u32) {
                        open = Some((u, size));
                    }
                    u
                }
            };
            self.unit_of[r as usize] = unit;
            self.unit_size[unit as usize] += size as u32;
        }
    }

    /// Whether the island rooted at `r` is cut into stripes, and into how
    /// many constraints' worth each.
    fn stripe_size(&self, r: usize) -> Option<usize> {
        let size = self.island_size[r] as usize;
        debug_assert!(size == 0 || self.unit_of[r] != NONE, "an island with constraints has a unit");
        if large(size as u32) {
            Some(STRIPE_CONSTRAINTS)
        } else if size > SMALL_STRIPED_MIN && 2 * size >= self.unit_size[self.unit_of[r] as usize] as usize {
            Some(SMALL_STRIPE_CONSTRAINTS)
        } else {
            None
        }
    }

    /// Stripes of the striped islands: bounds, cut axis, sort, split.
    fn cut_stripes(&mut self, bodies: usize, center: impl Fn(usize) -> Vec3, up: Vec3) {
        self.stripe.clear();
        self.stripe.resize(bodies, NONE);
        self.bounds.clear();
        self.bounds.resize(bodies, (Vec3::INFINITY, Vec3::NEG_INFINITY));
        self.sorted.clear();
        for i in 1..bodies {
            let r = self.union_find.find(i as u32) as usize;
            if self.stripe_size(r).is_some() {
                let p = center(i);
                let (lo, hi) = &mut self.bounds[r];
                *lo = lo.min(p);
                *hi = hi.max(p);
            }
        }
        for i in 1..bodies {
            let r = self.union_find.find(i as u32) as usize;
            if self.stripe_size(r).is_some() {
                let axis = cut_axis(self.bounds[r], up);
                self.sorted.push((r as u32, center(i)[axis], i as u32));
            }
        }
        // Total order (the body index breaks ties and orders NaNs):
        // deterministic whatever the sort.
        self.sorted.sort_unstable_by(|x, y| x.0.cmp(&y.0).then(x.1.total_cmp(&y.1)).then(x.2.cmp(&y.2)));
        self.stripes.clear();
        self.stripes.resize(bodies, 1);
        let mut run = 0;
        while run < self.sorted.len() {
            let r = self.sorted[run].0;
            let len = self.sorted[run..].iter().take_while(|x| x.0 == r).count();
            // At least two stripes, at least two bodies per stripe; an
            // even number, so that two threads share the interior phase
            // and the even boundaries evenly.
            let per_stripe = self.stripe_size(r as usize).expect("only striped islands are sorted");
            let want = (self.island_size[r as usize] as usize).div_ceil(per_stripe).next_multiple_of(2);
            let n = want.min(len / 2).max(1);
            self.stripes[r as usize] = n as u32;
            for (j, &(_, _, i)) in self.sorted[run..run + len].iter().enumerate() {
                self.stripe[i as usize] = (j * n / len) as u32;
            }
            run += len;
        }
    }

    /// Unit, phase and group of each constraint (`key`): units numbered in
    /// order of first appearance, groups within their unit's phase
    /// likewise. Pairs that name a body twice or one out of range make a
    /// last unit of their own, solved after the others (`odd`).
    fn assign_groups(&mut self, bodies: usize, pairs: impl Iterator<Item = (u32, u32)>) {
        self.island_base.clear();
        self.island_base.resize(bodies, [NONE; 3]);
        self.unit_groups.clear();
        self.unit_groups.resize(self.unit_size.len(), [0; 3]);
        self.colours.clear();
        self.colours.resize(bodies, [(NONE, 0); 2]);
        let mut odd = false;
        self.key.clear();
        for (a, b) in pairs {
            let (a, b) = (a as usize, b as usize);
            if !valid(bodies, a, b) {
                // Numbered after every other unit, below.
                odd = true;
                self.key.push(pack(NONE >> 2, OVERFLOW, 0));
                continue;
            }
            let r = root_of(&mut self.union_find, a, b);
            let unit = self.unit_of[r];
            let (phase, id) = self.group_of(a, b, r, unit);
            self.key.push(pack(unit, phase, id));
        }
        let units = self.unit_groups.len() + odd as usize;
        self.odd = odd;
        if odd {
            self.unit_groups.push([0; 3]);
            let last = pack(units as u32 - 1, OVERFLOW, 0);
            for k in &mut self.key {
                if *k == pack(NONE >> 2, OVERFLOW, 0) {
                    *k = last;
                }
            }
        }
    }

    /// The phase of the valid constraint on bodies `a` and `b` of the
    /// island rooted at `r` in `unit`, and its group id within the unit's
    /// phase (a boundary: one id per colour), numbering the island's
    /// groups when its first constraint of the phase comes.
    fn group_of(&mut self, a: usize, b: usize, r: usize, unit: u32) -> (u32, u32) {
        let stripes = self.stripes[r];
        // The static side takes the stripe of the other.
        let sa = self.stripe[if a != 0 { a } else { b }];
        let sb = self.stripe[if b != 0 { b } else { a }];
        let (lo, hi) = (sa.min(sb), sa.max(sb));
        let (phase, local) = if sa == NONE || sb == NONE {
            (INTERIOR, 0)
        } else if lo == hi {
            (INTERIOR, lo)
        } else if hi == lo + 1 {
            (if lo % 2 == 0 { EVEN } else { ODD }, lo / 2)
        } else {
            return (OVERFLOW, 0);
        };
        let p = phase as usize;
        let base = &mut self.island_base[r][p];
        if *base == NONE {
            // Interior: one group per stripe (1 for an unstriped island);
            // boundaries: every other one.
            let n = match phase {
                INTERIOR => stripes,
                EVEN => stripes / 2,
                _ => (stripes - 1) / 2,
            } * ids_per_group(phase);
            let count = &mut self.unit_groups[unit as usize][p];
            *base = *count;
            *count += n;
        }
        let base = *base;
        if phase == INTERIOR {
            (phase, base + local)
        } else {
            let side = (phase - EVEN) as usize;
            let colour = colour(&mut self.colours, side, base + local, [a, b]);
            (phase, base + local * COLOURS + colour)
        }
    }

    /// Global group ids, unit after unit, phase after phase (one overflow
    /// group per unit), in `key`; then a stable counting sort by them
    /// (`start`) and the outputs `groups` and `units`.
    fn lay_out_groups(&mut self) {
        self.offset.clear();
        let mut total = 0u32;
        for counts in &self.unit_groups {
            let mut o = [0; PHASES];
            for p in 0..PHASES {
                o[p] = total;
                total += if p == OVERFLOW as usize { 1 } else { counts[p] };
            }
            self.offset.push(o);
        }
        let total_groups = total as usize;
        for k in &mut self.key {
            let (unit, phase, local) = ((*k >> 34) as usize, (*k >> 32) as usize & 3, *k as u32);
            *k = (self.offset[unit][phase] + local) as u64;
        }
        self.start.clear();
        self.start.resize(total_groups + 1, 0);
        for &k in &self.key {
            self.start[k as usize + 1] += 1;
        }
        for g in 0..total_groups {
            self.start[g + 1] += self.start[g];
        }
        self.groups.clear();
        self.units.clear();
        for (u, o) in self.offset.iter().enumerate() {
            let mut phases: [Range<usize>; PHASES] = std::array::from_fn(|_| 0..0);
            for p in 0..PHASES {
                let first = self.groups.len();
                let end = if p + 1 < PHASES {
                    o[p + 1] as usize
                } else {
                    self.offset.get(u + 1).map_or(total_groups, |next| next[0] as usize)
                };
                // A boundary group is `COLOURS` consecutive ids, one per
                // colour.
                let step = ids_per_group(p as u32) as usize;
                debug_assert_eq!((end - o[p] as usize) % step, 0, "a boundary's ids come by the colours");
                for g in (o[p] as usize..end).step_by(step) {
                    let r = self.start[g] as usize..self.start[g + step] as usize;
                    if !r.is_empty() {
                        self.groups.push(r);
                    }
                }
                phases[p] = first..self.groups.len();
            }
            self.units.push(phases);
        }
    }

    /// Where each item grouped last goes: `slots[i]` is the position of
    /// item `i` once the items are laid out group after group, each group
    /// in the original order (a boundary, colour after colour). (The caller writes each constraint straight
    /// into its slot, instead of building them in order and copying them
    /// all once more.) Call once per `build`.
    pub fn slots(&mut self, slots: &mut Vec<u32>) {
        slots.clear();
        // `start` is consumed as the next free slot of each group.
        for &k in &self.key {
            let next = &mut self.start[k as usize];
            slots.push(*next);
            *next += 1;
        }
    }

    /// Writes `src` (the items grouped last, in the same order) into `dst`
    /// group after group, each group in the original order, a boundary
    /// colour after colour (`slots`).
    #[cfg(test)]
    pub fn reorder<T: Copy>(&mut self, src: &[T], dst: &mut Vec<T>) {
        debug_assert_eq!(src.len(), self.key.len());
        dst.clear();
        let Some(&first) = src.first() else { return };
        dst.resize(src.len(), first);
        let mut slots = Vec::new();
        self.slots(&mut slots);
        for (item, &slot) in src.iter().zip(&slots) {
            dst[slot as usize] = *item;
        }
    }

    /// One group holding all `count` constraints in their order (for
    /// `SolverExperiments::ordered_relax`, whose point is that order).
    pub fn all_serial(&mut self, count: usize) {
        self.kept = false;
        self.generation = self.generation.wrapping_add(1);
        self.odd = false;
        self.key.clear();
        self.groups.clear();
        self.units.clear();
        if count > 0 {
            self.groups.push(0..count);
            let mut phases: [Range<usize>; PHASES] = std::array::from_fn(|_| 0..0);
            phases[OVERFLOW as usize] = 0..1;
            self.units.push(phases);
        }
    }

    /// The unit of the island of solver body `slot` (a moving body, not
    /// the static stand-in), as the last grouping made it; `None` for an
    /// island without constraints (joints alone), or when everything is
    /// one serial group (`all_serial`): then unit 0 if there is one.
    pub fn unit_of_body(&mut self, slot: u32) -> Option<u32> {
        if !self.kept {
            return (!self.units.is_empty()).then_some(0);
        }
        if slot as usize >= self.unit_of.len() {
            return None;
        }
        let r = self.union_find.find(slot);
        let u = self.unit_of[r as usize];
        (u != NONE).then_some(u)
    }

    /// The island root of solver body `slot` in the last grouping; after
    /// `all_serial`, 0 for every body (one island: its joints then share
    /// one unit, which integrates each body once).
    pub fn island_of(&mut self, slot: u32) -> u32 {
        if !self.kept {
            return 0;
        }
        if slot as usize >= self.unit_of.len() {
            return slot;
        }
        self.union_find.find(slot)
    }

    /// The groups (ranges of the reordered constraints), unit after unit,
    /// phase after phase.
    pub fn groups(&self) -> &[Range<usize>] {
        &self.groups
    }

    /// Per unit, each phase's range in [`groups`](Self::groups), in solve
    /// order.
    pub fn units(&self) -> &[[Range<usize>; PHASES]] {
        &self.units
    }

    /// Whether the last unit holds pairs that name a moving body twice or
    /// a body out of range (the world makes none): that unit may share
    /// bodies with the others, so it must run after them, alone.
    pub fn odd(&self) -> bool {
        self.odd
    }
}

/// Whether a constraint on solver bodies `a` and `b` can be grouped: both
/// in range, and not one moving body twice.
fn valid(bodies: usize, a: usize, b: usize) -> bool {
    a < bodies && b < bodies && (a != b || a == 0)
}

/// The island root of a valid constraint on `a` and `b` (the moving one's
/// when the other is the static stand-in).
fn root_of(uf: &mut UnionFind, a: usize, b: usize) -> usize {
    uf.find(if a != 0 { a } else { b } as u32) as usize
}

/// Whether an island of `size` constraints is large: a unit of its own,
/// cut into stripes of [`STRIPE_CONSTRAINTS`].
fn large(size: u32) -> bool {
    size as usize > SERIAL_ISLAND_MAX
}

/// Index of the world axis to cut an island along: the longest extent,
/// discounting the part along `up` (stripes stand upright).
fn cut_axis((lo, hi): (Vec3, Vec3), up: Vec3) -> usize {
    let extent = (hi - lo).max(Vec3::ZERO);
    let score = |k: usize| extent[k] * (1.0 - up[k].abs());
    let mut best = 0;
    for k in 1..3 {
        if score(k) > score(best) {
            best = k;
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Builds the partition of `pairs` and checks its invariants: every
    /// constraint appears once, each group keeps the original order (a
    /// boundary within each colour), the
    /// groups of phases 0–2 share no moving body, and invalid pairs are in
    /// the overflow. Returns the reordered pairs.
    fn check(
        bodies: usize,
        pairs: &[(u32, u32)],
        center: impl Fn(usize) -> Vec3,
    ) -> (Partition, Vec<(u32, u32, usize)>) {
        let mut p = Partition::default();
        p.build(bodies, pairs.iter().copied(), std::iter::empty(), center, Vec3::Y);
        let tagged: Vec<(u32, u32, usize)> = pairs.iter().enumerate().map(|(k, &(a, b))| (a, b, k)).collect();
        let mut sorted = Vec::new();
        p.reorder(&tagged, &mut sorted);
        let mut seen: Vec<usize> = sorted.iter().map(|x| x.2).collect();
        seen.sort_unstable();
        assert_eq!(seen, (0..pairs.len()).collect::<Vec<_>>(), "every constraint once");
        let covered: usize = p.groups().iter().map(|g| g.len()).sum();
        assert_eq!(covered, pairs.len());
        for w in p.groups().windows(2) {
            assert_eq!(w[0].end, w[1].start, "groups are consecutive");
        }
        // A group keeps the order; a boundary group keeps it within each of
        // its colours, so it reads as at most `COLOURS` increasing runs.
        for phases in p.units() {
            for (phase, range) in phases.iter().enumerate() {
                for g in range.clone() {
                    let runs = 1 + sorted[p.groups()[g].clone()].windows(2).filter(|w| w[0].2 > w[1].2).count();
                    let most = ids_per_group(phase as u32) as usize;
                    assert!(runs <= most, "a group of phase {phase} keeps the order ({runs} runs)");
                }
            }
        }
        // The units cover the groups in order, and share no moving body.
        let mut unit_of = vec![usize::MAX; bodies];
        let mut next_group = 0;
        for (u, phases) in p.units().iter().enumerate() {
            for range in phases {
                assert!(range.is_empty() || range.start == next_group, "units and phases in order");
                next_group = next_group.max(range.end);
                for g in range.clone() {
                    for &(a, b, _) in &sorted[p.groups()[g].clone()] {
                        // (The odd pairs are a unit of their own, run
                        // after the others: see `Partition::odd`.)
                        if a as usize >= bodies || b as usize >= bodies || (a == b && a != 0) {
                            assert!(p.odd() && u + 1 == p.units().len(), "odd pairs in the last unit");
                            continue;
                        }
                        for x in [a as usize, b as usize] {
                            if x != 0 {
                                assert!(unit_of[x] == usize::MAX || unit_of[x] == u, "body {x} in two units");
                                unit_of[x] = u;
                            }
                        }
                    }
                }
            }
            for (phase, range) in phases.iter().enumerate().take(PHASES - 1) {
                let mut owner = vec![usize::MAX; bodies];
                for g in range.clone() {
                    for &(a, b, _) in &sorted[p.groups()[g].clone()] {
                        assert!((a as usize) < bodies && (b as usize) < bodies && (a != b || a == 0));
                        for x in [a as usize, b as usize] {
                            if x != 0 {
                                assert!(
                                    owner[x] == usize::MAX || owner[x] == g,
                                    "body {x} in two groups of phase {phase}"
                                );
                                owner[x] = g;
                            }
                        }
                    }
                }
            }
        }
        assert_eq!(next_group, p.groups().len(), "every group in a unit");
        (p, sorted)
    }

    /// A running-bond wall of `cols × rows` unit bricks, bottom-up like the
    /// world's contacts: each brick touches its right neighbour and the two
    /// above it; the bottom row touches the ground (0).
    fn wall(cols: u32, rows: u32) -> (usize, Vec<(u32, u32)>, impl Fn(usize) -> Vec3) {
        let id = move |r: u32, c: u32| 1 + r * cols + c;
        let mut pairs = Vec::new();
        for r in 0..rows {
            for c in 0..cols {
                if r == 0 {
                    pairs.push((0, id(r, c)));
                }
                if c + 1 < cols {
                    pairs.push((id(r, c), id(r, c + 1)));
                }
                if r + 1 < rows {
                    pairs.push((id(r, c), id(r + 1, c)));
                    if c + 1 < cols {
                        pairs.push((id(r, c), id(r + 1, c + 1)));
                    }
                }
            }
        }
        let center = move |i: usize| {
            let k = i.saturating_sub(1) as u32;
            let (r, c) = (k / cols, k % cols);
            Vec3::new(c as f32 + 0.5 * (r % 2) as f32, r as f32, 0.0)
        };
        ((cols * rows + 1) as usize, pairs, center)
    }

    #[test]
    fn a_small_island_is_one_group_in_its_order() {
        let (n, pairs, center) = wall(6, 6);
        assert!(pairs.len() <= SMALL_STRIPED_MIN);
        let (p, sorted) = check(n, &pairs, center);
        assert_eq!(p.groups().len(), 1);
        assert!(sorted.iter().enumerate().all(|(k, x)| x.2 == k), "unchanged order");
    }

    /// The seed's 10 × 10 wall (271 constraints here), alone: its unit is
    /// all one island, so the island is cut into stripes of about
    /// `SMALL_STRIPE_CONSTRAINTS` (an even number: 271 / 32 → 9 → 10) and
    /// their boundaries. Two such walls share a unit, each exactly half of
    /// it: both are cut. Five: the first four share a unit (it takes
    /// islands until it holds `UNIT_CONSTRAINTS`), where each is a quarter
    /// and stays one group in its order; the fifth opens a unit of its
    /// own, and is cut.
    #[test]
    fn a_small_island_that_is_most_of_its_unit_is_cut_into_stripes() {
        let (n, pairs, center) = wall(10, 10);
        assert!(pairs.len() > SMALL_STRIPED_MIN && pairs.len() <= SERIAL_ISLAND_MAX);
        let (p, _) = check(n, &pairs, &center);
        assert_eq!(p.units().len(), 1);
        let stripes = pairs.len().div_ceil(SMALL_STRIPE_CONSTRAINTS).next_multiple_of(2);
        assert_eq!(stripes, 10);
        let phases = &p.units()[0];
        assert_eq!(phases[0].len(), stripes, "one interior group per stripe");
        assert!(!phases[1].is_empty() && !phases[2].is_empty(), "even and odd boundaries");

        // Walls side by side: bodies 1.. of each, offset.
        let per = n - 1;
        let walls = |count: usize| {
            let mut all = Vec::new();
            for w in 0..count {
                let shift = |x: u32| if x == 0 { 0 } else { x + (w * per) as u32 };
                all.extend(pairs.iter().map(|&(a, b)| (shift(a), shift(b))));
            }
            all
        };
        let centers = |i: usize| {
            let k = i.saturating_sub(1);
            center(1 + k % per) + Vec3::X * (20 * (k / per)) as f32
        };
        let (p, _) = check(1 + 2 * per, &walls(2), centers);
        assert_eq!(p.units().len(), 1);
        assert_eq!(p.units()[0][0].len(), 2 * stripes, "half of the unit each: both cut");
        let (p, sorted) = check(1 + 5 * per, &walls(5), centers);
        assert_eq!(p.units().len(), 2, "four walls fill a unit past 1,024; the fifth opens another");
        let first = &p.units()[0];
        assert_eq!((first[0].len(), first[1].len(), first[2].len()), (4, 0, 0), "one group per wall");
        let four = 4 * pairs.len();
        assert!(sorted[..four].iter().enumerate().all(|(k, x)| x.2 == k), "unchanged order");
        assert_eq!(p.units()[1][0].len(), stripes, "the fifth is all of its unit: cut");
    }

    #[test]
    fn a_large_island_is_cut_into_upright_stripes() {
        let (n, pairs, center) = wall(60, 30);
        let (p, sorted) = check(n, &pairs, &center);
        let stripes = pairs.len().div_ceil(STRIPE_CONSTRAINTS).next_multiple_of(2);
        assert_eq!(p.units().len(), 1, "one island, one unit");
        let phases = &p.units()[0];
        assert_eq!(phases[0].len(), stripes);
        // Stripes are cut along x (across gravity), so each holds every row.
        let g = &p.groups()[phases[0].start];
        let rows: std::collections::BTreeSet<u32> =
            sorted[g.clone()].iter().map(|x| center(x.1 as usize).y as u32).collect();
        assert_eq!(rows.len(), 30);
        assert!(phases[1].len() + phases[2].len() == stripes - 1);
        assert!(phases[3].is_empty(), "no overflow in a wall");
        // An even number of stripes: 4,391 constraints would make 5, and
        // two threads would share them 3:2.
        let (n, pairs, center) = wall(50, 30);
        assert_eq!(pairs.len().div_ceil(STRIPE_CONSTRAINTS), 5);
        let (p, _) = check(n, &pairs, &center);
        assert_eq!(p.units()[0][0].len(), 6, "stripes");
    }

    /// The longest chain of a group's constraints, each sharing a moving
    /// body with the one before it in the group's order: the batches that
    /// a group needs at least, however many lanes a batch has.
    fn chain(sorted: &[(u32, u32, usize)], bodies: usize) -> usize {
        let mut depth = vec![0usize; bodies];
        let mut longest = 0;
        for &(a, b, _) in sorted {
            let d = 1 + [a, b].iter().filter(|&&x| x != 0).map(|&x| depth[x as usize]).max().unwrap_or(0);
            for x in [a, b] {
                if x != 0 {
                    depth[x as usize] = d;
                }
            }
            longest = longest.max(d);
        }
        longest
    }

    /// A boundary between two stripes, in the bottom-up order, is one long
    /// chain (each row's constraint across the cut shares a brick with the
    /// row's next), which takes as many batches of mostly empty lanes per
    /// pass. Coloured, each boundary's chain is at most `COLOURS` long (on
    /// this 60 × 30 wall, 59 uncoloured and 2 coloured); the stripes' own
    /// chains are unchanged (they keep the bottom-up order that carries
    /// loads up a stack in one pass).
    #[test]
    fn boundaries_are_coloured_into_short_chains() {
        let (n, pairs, center) = wall(60, 30);
        let (p, sorted) = check(n, &pairs, center);
        let phases = &p.units()[0];
        let mut boundaries = 0;
        for phase in [EVEN as usize, ODD as usize] {
            for g in phases[phase].clone() {
                let group = &sorted[p.groups()[g].clone()];
                let longest = chain(group, n);
                // A running-bond wall's boundary takes two colours.
                assert!(longest <= 2, "boundary chain {longest}");
                // The chain before colouring: the same constraints in
                // their original order.
                let mut original = group.to_vec();
                original.sort_by_key(|x| x.2);
                assert!(chain(&original, n) >= 30, "a boundary crosses every row");
                eprintln!(
                    "boundary of {} constraints: chain {} (uncoloured {})",
                    group.len(),
                    longest,
                    chain(&original, n)
                );
                boundaries += 1;
            }
        }
        assert!(boundaries >= 2);
    }

    #[test]
    fn islands_stay_apart_and_odd_pairs_overflow() {
        // Two large walls, many small islands, a pair naming one body
        // twice, one out of range, and links across non-neighbour stripes.
        let (n1, mut pairs, c1) = wall(60, 30);
        let (n2, more, _) = wall(50, 30);
        let shift = n1 as u32 - 1;
        pairs.extend(more.iter().map(|&(a, b)| (if a == 0 { 0 } else { a + shift }, b + shift)));
        let mut n = n1 + n2 - 1;
        for k in 0..50 {
            pairs.push((0, n as u32 + k));
        }
        n += 50;
        pairs.push((5, 5));
        pairs.push((3, n as u32 + 7));
        pairs.push((1, 60)); // first and last brick of the bottom row
        let center = move |i: usize| if i < n1 { c1(i) } else { Vec3::new(200.0 + i as f32, 0.0, 0.0) };
        let (p, sorted) = check(n, &pairs, center);
        let overflow =
            |u: &[Range<usize>; PHASES]| u[3].clone().flat_map(|g| sorted[p.groups()[g].clone()].to_vec()).collect();
        // The odd pairs are a last unit of their own.
        let odd: Vec<_> = overflow(p.units().last().unwrap());
        assert_eq!(odd.len(), 2);
        assert!(odd.iter().any(|x| *x == (5, 5, pairs.len() - 3)));
        assert!(odd.iter().any(|x| x.2 == pairs.len() - 2));
        // The link across the first wall: its unit's overflow.
        let first: Vec<_> = overflow(&p.units()[0]);
        assert!(first.iter().any(|x| x.2 == pairs.len() - 1));
        // Two walls, then the 50 single-constraint islands in one unit,
        // then the odd pairs.
        assert_eq!(p.units().len(), 4);
    }

    #[test]
    fn small_islands_share_units_of_about_unit_constraints() {
        // 300 separate 10-constraint islands (towers of 10 on the ground).
        let mut pairs = Vec::new();
        for t in 0..300u32 {
            let base = 1 + 10 * t;
            pairs.push((0, base));
            for k in 0..9 {
                pairs.push((base + k, base + k + 1));
            }
        }
        let (p, sorted) = check(3001, &pairs, |i| Vec3::new(i as f32, 0.0, 0.0));
        // Islands join a unit until it holds 1,024 constraints or more.
        let per_unit = UNIT_CONSTRAINTS.div_ceil(10);
        assert_eq!(p.units().len(), 300usize.div_ceil(per_unit));
        for (u, phases) in p.units().iter().enumerate() {
            let n: usize = phases[0].clone().map(|g| p.groups()[g].len()).sum();
            assert_eq!(n, if u + 1 < p.units().len() { 10 * per_unit } else { 3000 - 10 * per_unit * u });
        }
        assert!(sorted.iter().enumerate().all(|(k, x)| x.2 == k), "small islands keep their order");
    }

    #[test]
    fn nothing_to_group() {
        let (p, sorted) = check(1, &[], |_| Vec3::ZERO);
        assert!(p.groups().is_empty() && sorted.is_empty());
        let mut p = Partition::default();
        p.all_serial(5);
        assert_eq!(p.groups().len(), 1);
        assert_eq!(p.groups()[0], 0..5);
        assert_eq!(p.units().len(), 1);
        assert_eq!(p.units()[0][PHASES - 1], 0..1);
    }

    /// A grouping stands while its pairs, body count and `up` do, however
    /// the bodies move (`build` returns false, the groups, units and order
    /// stay those of the first build), and a change of any of the three
    /// groups afresh: what a new partition gives.
    #[test]
    fn a_grouping_stands_while_its_pairs_do() {
        let (n, pairs, center) = wall(60, 30);
        let tagged: Vec<(u32, u32, usize)> = pairs.iter().enumerate().map(|(k, &(a, b))| (a, b, k)).collect();
        let fresh = |pairs: &[(u32, u32)], tagged: &[(u32, u32, usize)], center: &dyn Fn(usize) -> Vec3, up: Vec3| {
            let mut p = Partition::default();
            assert!(p.build(n, pairs.iter().copied(), std::iter::empty(), center, up));
            let mut order = Vec::new();
            p.reorder(tagged, &mut order);
            (p.groups().to_vec(), p.units().to_vec(), order)
        };
        let mut kept = Partition::default();
        assert!(kept.build(n, pairs.iter().copied(), std::iter::empty(), &center, Vec3::Y));
        let mut order = Vec::new();
        kept.reorder(&tagged, &mut order);
        let first = (kept.groups().to_vec(), kept.units().to_vec(), order.clone());
        assert_eq!(first, fresh(&pairs, &tagged, &center, Vec3::Y));
        // Most of a brick of sway: the stripes would be cut elsewhere.
        let swayed = |i: usize| center(i) + Vec3::X * (0.9 * ((i * 7919 % 101) as f32 / 50.0 - 1.0));
        assert_ne!(first.2, fresh(&pairs, &tagged, &swayed, Vec3::Y).2, "the sway moves the cut");
        assert!(!kept.build(n, pairs.iter().copied(), std::iter::empty(), swayed, Vec3::Y), "same pairs: kept");
        assert_eq!((kept.groups().to_vec(), kept.units().to_vec()), (first.0.clone(), first.1.clone()));
        // One pair fewer, another `up`, another body count: afresh.
        let up = Vec3::new(0.0, 1.0, 1e-3).normalize();
        // One change at a time from the grouping before: the first pair
        // skipped, then `up` turned, then one body more.
        let changes = [(1, Vec3::Y, n), (1, up, n), (1, up, n + 1)];
        for (skip, up, bodies) in changes {
            let (pairs_now, tagged_now) = (&pairs[skip..], &tagged[skip..]);
            assert!(
                kept.build(bodies, pairs_now.iter().copied(), std::iter::empty(), &center, up),
                "a change regroups"
            );
            kept.reorder(tagged_now, &mut order);
            let mut p = Partition::default();
            assert!(p.build(bodies, pairs_now.iter().copied(), std::iter::empty(), &center, up));
            let mut want = Vec::new();
            p.reorder(tagged_now, &mut want);
            assert_eq!((kept.groups(), kept.units(), &order), (p.groups(), p.units(), &want));
        }
    }
}

// What a standing grouping hands the solver (its islands, units and
// groups) and what tells whether it stands; the rest is the grouping's
// own scratch, rebuilt by the next grouping.
crate::snapshot::codec::persist!(Partition {
    union_find, unit_of, groups, units, odd, last_pairs, last_bodies, last_up, kept, generation,
} scratch {
    island_size, island_base, unit_groups, unit_size, roots, bounds, stripes, stripe, colours, sorted, key, offset,
    start, pairs_now,
});

impl Partition {
    /// Checks what a restored partition hands the solver while it stands
    /// (its pairs unchanged): the groups tile the constraints of its last
    /// pairs in order, the units' phases tile the groups, `slots` (the
    /// solver's slot of each constraint) is a permutation of them, each
    /// body's unit exists, and the islands' union–find ends at roots.
    pub(crate) fn check_restored(&self, slots: &[u32]) -> Result<(), String> {
        if !self.kept {
            return Ok(());
        }
        // The pairs, a mark, the links (`build`).
        let Some(count) = self.last_pairs.iter().position(|&p| p == (u32::MAX, u32::MAX)) else {
            return Err("a standing partition without the mark after its pairs".into());
        };
        let mut next = 0;
        for g in &self.groups {
            if g.start != next || g.end > count {
                return Err(format!("partition group {g:?} of {count} constraints"));
            }
            next = g.end;
        }
        if next != count {
            return Err(format!("partition groups end at {next} of {count} constraints"));
        }
        let mut next = 0;
        for phases in &self.units {
            for r in phases.iter().filter(|r| !r.is_empty()) {
                if r.start != next || r.end > self.groups.len() {
                    return Err(format!("partition unit phases {r:?} of {} groups", self.groups.len()));
                }
                next = r.end;
            }
        }
        if next != self.groups.len() {
            return Err("partition units do not cover the groups".into());
        }
        let mut seen = vec![false; count];
        if slots.len() != count
            || !slots.iter().all(|&s| (s as usize) < count && !std::mem::replace(&mut seen[s as usize], true))
        {
            return Err("the constraints' kept slots are not a permutation".into());
        }
        if self.unit_of.iter().any(|&u| u != NONE && u as usize >= self.units.len()) {
            return Err("partition unit of a body out of range".into());
        }
        self.union_find.check_restored(self.unit_of.len())?;
        self.check_disjoint(slots, count)
    }

    /// What the threads rely on (`solver/schedule.rs`): the groups of a
    /// unit's phase share no moving body, nor do two units, and each
    /// moving body of a unit's constraints and joints is that unit's (its
    /// island's). Solver body 0 is the static stand-in; the world makes
    /// no odd grouping.
    fn check_disjoint(&self, slots: &[u32], count: usize) -> Result<(), String> {
        use std::collections::HashMap;
        if self.odd {
            return Err("a partition with an odd unit".into());
        }
        let mut order = vec![0u32; count];
        for (i, &slot) in slots.iter().enumerate() {
            order[slot as usize] = i as u32;
        }
        let mut uf = self.union_find.clone();
        let mut unit_of = |body: u32| -> Option<u32> {
            let r = uf.find(body);
            self.unit_of.get(r as usize).copied().filter(|&u| u != NONE)
        };
        let in_range = |b: u32| (b as usize) < self.unit_of.len();
        // body → (unit, phase, group) of the first group that moves it.
        let mut owner: HashMap<u32, (usize, usize, usize)> = HashMap::new();
        for (u, phases) in self.units.iter().enumerate() {
            for (p, range) in phases.iter().enumerate() {
                for g in range.clone() {
                    for slot in self.groups[g].clone() {
                        let (a, b) = self.last_pairs[order[slot] as usize];
                        for body in [a, b].into_iter().filter(|&x| x != 0) {
                            if !in_range(body) || unit_of(body) != Some(u as u32) {
                                return Err(format!("partition unit {u}: body {body} of another island"));
                            }
                            match owner.get(&body) {
                                Some(&(u2, p2, g2)) if u2 == u && p2 == p && g2 != g => {
                                    return Err(format!("partition groups {g2} and {g} share body {body}"))
                                }
                                Some(_) => {}
                                None => {
                                    owner.insert(body, (u, p, g));
                                }
                            }
                        }
                    }
                }
            }
        }
        for &(a, b) in &self.last_pairs[count + 1..] {
            let movers = [a, b].into_iter().filter(|&x| x != 0);
            if movers.clone().any(|x| !in_range(x)) {
                return Err(format!("partition link {a}–{b} out of range"));
            }
            if a != 0 && b != 0 && unit_of(a) != unit_of(b) {
                return Err(format!("partition link {a}–{b} across units"));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
impl Partition {
    /// Each kept field's bytes, by name (tests).
    pub(crate) fn snapshot_parts(&self) -> Vec<(&'static str, Vec<u8>)> {
        use crate::snapshot::codec::saved as part;
        vec![
            part("p.union_find", &self.union_find),
            part("p.unit_of", &self.unit_of),
            part("p.groups", &self.groups),
            part("p.units", &self.units),
            part("p.last_pairs", &self.last_pairs),
        ]
    }
}

#[cfg(test)]
impl Partition {
    /// Tests: sets the groupings' count, to forge it.
    pub(crate) fn set_generation(&mut self, generation: u64) {
        self.generation = generation;
    }

    /// Tests: the pairs the last grouping was made for, to forge them.
    pub(crate) fn last_pairs_mut(&mut self) -> &mut Vec<(u32, u32)> {
        &mut self.last_pairs
    }

    /// Tests: forges a standing grouping whose groups share moving
    /// bodies (every constraint its own group, all in the first phase of
    /// one unit). Returns whether there was a standing grouping.
    pub(crate) fn forge_singletons(&mut self) -> bool {
        if !self.kept {
            return false;
        }
        let count = self.groups.last().map_or(0, |g| g.end);
        self.groups = (0..count).map(|i| i..i + 1).collect();
        let mut phases: [Range<usize>; PHASES] = std::array::from_fn(|_| count..count);
        phases[0] = 0..count;
        self.units = vec![phases];
        self.unit_of.iter_mut().filter(|u| **u != NONE).for_each(|u| *u = 0);
        true
    }
}
