//! Tests of the incremental broad phase against independent references:
//! brute force on small random scenes, sweep-and-prune on large ones.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::collections::BTreeSet;

use crumble::broad_phase::{BroadPhase, ProxyId, MAX_IMBALANCE};
use crumble::{Aabb, Vec3};

// ----- allocation counting (per thread, so parallel tests don't interfere) ---

struct CountingAlloc;

thread_local! {
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

fn count_allocation() {
    let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
}

unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count_allocation();
        System.alloc(layout)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout)
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count_allocation();
        System.alloc_zeroed(layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count_allocation();
        System.realloc(ptr, layout, new_size)
    }
}

#[global_allocator]
static GLOBAL: CountingAlloc = CountingAlloc;

fn allocations() -> u64 {
    ALLOCATIONS.with(|c| c.get())
}

// ----- helpers ----------------------------------------------------------------

/// xorshift64*: tiny, seeded, good enough to scatter boxes.
struct Rng(u64);

impl Rng {
    fn new(seed: u64) -> Self {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.unit()
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
    fn vec(&mut self, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
}

/// The worst-case height of a tree with `n` leaves in which sibling subtrees
/// differ in height by at most `MAX_IMBALANCE`: the tallest `h` whose
/// sparsest such tree, with `L(h) = L(h - 1) + L(h - 1 - MAX_IMBALANCE)`
/// leaves, still fits in `n`.
fn worst_case_height(n: usize) -> u32 {
    let t = MAX_IMBALANCE as usize;
    let mut fewest = vec![1usize];
    loop {
        let h = fewest.len();
        let next = fewest[h - 1] + fewest[(h - 1).saturating_sub(t)];
        if next > n {
            return (h - 1) as u32;
        }
        fewest.push(next);
    }
}

/// The bound the brief asks of a healthy tree: `2 · log2 n + 2`.
fn shallow_bound(n: usize) -> u32 {
    2 * (n.max(2) as f64).log2().ceil() as u32 + 2
}

/// What the test keeps about a live proxy.
#[derive(Clone, Copy)]
struct Body {
    id: ProxyId,
    user: u32,
    tight: Aabb,
    is_static: bool,
}

/// The pair set implied by the fat boxes in the tree, by brute force.
fn brute_force_pairs(bp: &BroadPhase, bodies: &[Body]) -> BTreeSet<(u32, u32)> {
    let mut out = BTreeSet::new();
    for (i, a) in bodies.iter().enumerate() {
        let fa = bp.fat_aabb(a.id);
        for b in &bodies[i + 1..] {
            if a.is_static && b.is_static {
                continue;
            }
            if fa.overlaps(&bp.fat_aabb(b.id)) {
                out.insert((a.user.min(b.user), a.user.max(b.user)));
            }
        }
    }
    out
}

/// Number of overlapping pairs among `boxes` (not static–static), by a
/// sweep along x: O(n log n + overlaps along x).
fn sweep_pair_count(boxes: &[(Aabb, bool)]) -> usize {
    let mut order: Vec<usize> = (0..boxes.len()).collect();
    order.sort_by(|&a, &b| boxes[a].0.min.x.total_cmp(&boxes[b].0.min.x));
    let mut count = 0;
    for (k, &i) in order.iter().enumerate() {
        let (a, sa) = boxes[i];
        for &j in &order[k + 1..] {
            let (b, sb) = boxes[j];
            if b.min.x > a.max.x {
                break;
            }
            if !(sa && sb) && a.overlaps(&b) {
                count += 1;
            }
        }
    }
    count
}

/// Applies one `update_pairs` worth of events to `model`, checking that they
/// are well formed: sorted, smaller id first, lost pairs known, new unknown.
fn apply_events(bp: &BroadPhase, model: &mut BTreeSet<(u32, u32)>) {
    for list in [bp.lost_pairs(), bp.new_pairs()] {
        assert!(list.windows(2).all(|w| w[0] < w[1]), "events not sorted");
        assert!(list.iter().all(|&(a, b)| a < b), "event not ordered");
    }
    for p in bp.lost_pairs() {
        assert!(model.remove(p), "lost pair {p:?} was not known");
    }
    for &p in bp.new_pairs() {
        assert!(model.insert(p), "new pair {p:?} was already known");
    }
}

fn sorted_pairs(bp: &BroadPhase) -> Vec<(u32, u32)> {
    let mut v: Vec<_> = bp.pairs().collect();
    v.sort_unstable();
    v
}

fn random_box(rng: &mut Rng, world: f32) -> Aabb {
    let c = rng.vec(0.0, world);
    let h = rng.vec(0.05, 0.5);
    Aabb::from_center_half_extents(c, h)
}

fn translate(b: Aabb, d: Vec3) -> Aabb {
    Aabb::new(b.min + d, b.max + d)
}

// ----- tests ------------------------------------------------------------------

#[test]
fn events_reproduce_brute_force_pair_set_over_random_steps() {
    for seed in 1..=4u64 {
        let mut rng = Rng::new(seed);
        let world = 8.0;
        let mut bp = BroadPhase::new(0.1);
        let mut bodies: Vec<Body> = Vec::new();
        let mut next_user = 0u32;
        for _ in 0..300 {
            let tight = random_box(&mut rng, world);
            let is_static = rng.unit() < 0.15;
            let id = if is_static { bp.insert_static(tight, next_user) } else { bp.insert(tight, next_user) };
            bodies.push(Body { id, user: next_user, tight, is_static });
            next_user += 1;
        }

        let mut model = BTreeSet::new();
        for step in 0..150 {
            // Move about a fifth of the bodies: mostly small steps, a few
            // teleports, some with a displacement hint, rare static moves.
            for b in bodies.iter_mut() {
                if b.is_static && rng.unit() > 0.01 {
                    continue;
                }
                if rng.unit() > 0.2 {
                    continue;
                }
                let d = if rng.unit() < 0.05 { rng.vec(-world * 0.5, world * 0.5) } else { rng.vec(-0.15, 0.15) };
                b.tight = translate(b.tight, d);
                let moved = if rng.unit() < 0.3 {
                    bp.update_with_displacement(b.id, b.tight, d)
                } else {
                    bp.update(b.id, b.tight)
                };
                // The fat box must hold the tight box afterwards, either way.
                assert!(bp.fat_aabb(b.id).contains(&b.tight));
                let _ = moved;
            }
            // Remove and insert a few.
            for _ in 0..rng.below(4) {
                if bodies.is_empty() {
                    break;
                }
                let k = rng.below(bodies.len());
                let gone = bodies.swap_remove(k);
                bp.remove(gone.id);
            }
            for _ in 0..rng.below(4) {
                let tight = random_box(&mut rng, world);
                let id = bp.insert(tight, next_user);
                bodies.push(Body { id, user: next_user, tight, is_static: false });
                next_user += 1;
            }

            bp.update_pairs();
            apply_events(&bp, &mut model);
            bp.validate();

            let expected = brute_force_pairs(&bp, &bodies);
            assert_eq!(model, expected, "seed {seed} step {step}: events drifted");
            let listed = sorted_pairs(&bp);
            assert!(listed.iter().copied().eq(expected.iter().copied()));
            assert_eq!(bp.pair_count(), expected.len());
            assert_eq!(bp.len(), bodies.len());
            assert!(bp.height() <= worst_case_height(bodies.len()));
            assert!(bp.height() <= shallow_bound(bodies.len()));

            // Conservative: every pair of touching tight boxes is known.
            for (i, a) in bodies.iter().enumerate() {
                for b in &bodies[i + 1..] {
                    if !(a.is_static && b.is_static) && a.tight.overlaps(&b.tight) {
                        let key = (a.user.min(b.user), a.user.max(b.user));
                        assert!(model.contains(&key), "touching pair {key:?} missing");
                    }
                }
            }
        }
    }
}

/// A crowd: 80 boxes over one small region, each overlapping most of the
/// others, so that each moved proxy has far more known partners than the
/// few a brick in a wall has (`update_pairs` sorts such lists and searches
/// them by halves). Half of them move a little each step, some far; the
/// events must still give the brute-force pair set.
#[test]
fn a_crowd_of_overlapping_boxes_keeps_the_brute_force_pair_set() {
    let mut rng = Rng::new(7);
    let mut bp = BroadPhase::new(0.05);
    let mut bodies: Vec<Body> = Vec::new();
    for user in 0..80u32 {
        let tight = translate(Aabb::new(Vec3::splat(-0.5), Vec3::splat(0.5)), rng.vec(-0.3, 0.3));
        let is_static = user % 10 == 0;
        let id = if is_static { bp.insert_static(tight, user) } else { bp.insert(tight, user) };
        bodies.push(Body { id, user, tight, is_static });
    }
    let mut model = BTreeSet::new();
    let mut most = 0;
    for step in 0..40 {
        for b in bodies.iter_mut().filter(|b| !b.is_static) {
            if rng.unit() < 0.5 {
                let d = if rng.unit() < 0.1 { rng.vec(-1.5, 1.5) } else { rng.vec(-0.1, 0.1) };
                b.tight = translate(b.tight, d);
                bp.update(b.id, b.tight);
            }
        }
        bp.update_pairs();
        apply_events(&bp, &mut model);
        bp.validate();
        let expected = brute_force_pairs(&bp, &bodies);
        assert_eq!(model, expected, "step {step}: events drifted");
        assert_eq!(bp.pair_count(), expected.len());
        let mut partners = vec![0usize; bodies.len()];
        for &(a, b) in &expected {
            partners[a as usize] += 1;
            partners[b as usize] += 1;
        }
        most = most.max(partners.into_iter().max().unwrap_or(0));
    }
    // The lists were long: far past the sixteen read through.
    assert!(most > 40, "at most {most} partners");
}

/// A 100 × 100 wall of bricks in running bond, each brick touching its
/// neighbours, plus the reference count from a sweep over the fat boxes.
#[test]
fn ten_thousand_brick_wall_matches_sweep_reference() {
    let (nx, ny) = (100usize, 100usize);
    let half = Vec3::new(0.1, 0.05, 0.1);
    let mut bp = BroadPhase::new(0.02);
    let mut bricks = Vec::with_capacity(nx * ny);
    for j in 0..ny {
        let shift = if j % 2 == 1 { half.x } else { 0.0 };
        for i in 0..nx {
            let c = Vec3::new(i as f32 * 2.0 * half.x + shift, half.y + j as f32 * 2.0 * half.y, 0.0);
            let tight = Aabb::from_center_half_extents(c, half);
            // The bottom row stands on the ground: make it static, which must
            // drop the pairs between bottom-row neighbours.
            let id = if j == 0 {
                bp.insert_static(tight, bricks.len() as u32)
            } else {
                bp.insert(tight, bricks.len() as u32)
            };
            bricks.push((id, tight, j == 0));
        }
    }
    let n = bricks.len();
    assert_eq!(bp.len(), n);
    let bound = shallow_bound(n);

    let mut model = BTreeSet::new();
    let mut rng = Rng::new(7);
    for step in 0..6 {
        if step > 0 {
            // Nudge a quarter of the bricks; some leave their fat boxes.
            for (id, tight, is_static) in bricks.iter_mut() {
                if *is_static || rng.unit() > 0.25 {
                    continue;
                }
                *tight = translate(*tight, rng.vec(-0.04, 0.04));
                bp.update(*id, *tight);
            }
        }
        bp.update_pairs();
        apply_events(&bp, &mut model);

        let fat: Vec<(Aabb, bool)> = bricks.iter().map(|&(id, _, s)| (bp.fat_aabb(id), s)).collect();
        let reference = sweep_pair_count(&fat);
        assert_eq!(bp.pair_count(), reference, "step {step}");
        assert_eq!(model.len(), reference, "step {step}");
        assert!(bp.height() <= bound, "height {} > {bound} at step {step}", bp.height());
        assert!(bp.height() <= worst_case_height(n));
    }
    // In the untouched wall every brick touches up to 6 others (2 beside, 2
    // above, 2 below); sanity-check the order of magnitude.
    assert!(model.len() > 2 * n && model.len() < 6 * n);
    bp.validate();
}

#[test]
fn ten_thousand_random_boxes_match_sweep_reference() {
    let mut rng = Rng::new(99);
    let n = 10_000;
    let world = 60.0;
    let mut bp = BroadPhase::new(0.05);
    let mut boxes: Vec<(ProxyId, Aabb)> = (0..n)
        .map(|u| {
            let tight = random_box(&mut rng, world);
            (bp.insert(tight, u as u32), tight)
        })
        .collect();
    let bound = shallow_bound(n);
    for step in 0..5 {
        if step > 0 {
            for (id, tight) in boxes.iter_mut() {
                *tight = translate(*tight, rng.vec(-0.2, 0.2));
                bp.update(*id, *tight);
            }
        }
        bp.update_pairs();
        let fat: Vec<(Aabb, bool)> = boxes.iter().map(|&(id, _)| (bp.fat_aabb(id), false)).collect();
        assert_eq!(bp.pair_count(), sweep_pair_count(&fat), "step {step}");
        assert!(bp.height() <= bound, "height {} > {bound}", bp.height());
    }
    bp.validate();
}

/// Where the `u`-th box of a scene goes.
type Placement = Box<dyn Fn(usize) -> Vec3>;

#[test]
fn adversarial_insertion_orders_keep_the_tree_shallow() {
    let n = 20_000usize;
    let half = Vec3::splat(0.4);
    let scenes: [(&str, Placement); 4] = [
        ("sorted line", Box::new(|u| Vec3::new(u as f32, 0.0, 0.0))),
        ("same box", Box::new(|_| Vec3::ZERO)),
        ("raster grid", Box::new(|u| Vec3::new((u % 141) as f32, (u / 141) as f32, 0.0))),
        (
            "spiral out",
            Box::new(|u| {
                let a = u as f32 * 0.1;
                Vec3::new(a.cos(), a.sin(), 0.0) * (u as f32).sqrt()
            }),
        ),
    ];
    for (name, at) in scenes.iter() {
        let mut bp = BroadPhase::new(0.0);
        let ids: Vec<ProxyId> =
            (0..n).map(|u| bp.insert(Aabb::from_center_half_extents(at(u), half), u as u32)).collect();
        assert!(bp.height() <= shallow_bound(n), "{name}: height {} > {}", bp.height(), shallow_bound(n));
        bp.validate();
        // Remove every other proxy, in order: the tree must stay shallow.
        for id in ids.iter().step_by(2) {
            bp.remove(*id);
        }
        assert!(bp.height() <= shallow_bound(bp.len()), "{name} after removal");
        bp.validate();
    }
}

#[test]
fn removing_a_proxy_reports_its_pairs_as_lost() {
    let mut bp = BroadPhase::new(0.0);
    let unit = |x: f32| Aabb::from_center_half_extents(Vec3::new(x, 0.0, 0.0), Vec3::splat(0.5));
    let a = bp.insert(unit(0.0), 10);
    let _b = bp.insert(unit(0.9), 11);
    let _c = bp.insert(unit(-0.9), 12);
    let _far = bp.insert(unit(50.0), 13);
    bp.update_pairs();
    assert_eq!(bp.new_pairs(), &[(10, 11), (10, 12)]);
    assert!(bp.lost_pairs().is_empty());

    bp.remove(a);
    assert_eq!(bp.pair_count(), 0);
    // Reported at the next update, not before.
    assert_eq!(bp.new_pairs(), &[(10, 11), (10, 12)]);
    bp.update_pairs();
    assert_eq!(bp.lost_pairs(), &[(10, 11), (10, 12)]);
    assert!(bp.new_pairs().is_empty());
    assert_eq!(bp.len(), 3);
    bp.validate();

    // The next update reports nothing again.
    bp.update_pairs();
    assert!(bp.lost_pairs().is_empty() && bp.new_pairs().is_empty());

    // Insert and remove before any update: no events at all.
    let d = bp.insert(unit(0.9), 14);
    bp.remove(d);
    bp.update_pairs();
    assert!(bp.lost_pairs().is_empty() && bp.new_pairs().is_empty());
    bp.validate();
}

#[test]
fn separating_proxies_lose_their_pair() {
    let mut bp = BroadPhase::new(0.1);
    let at = |x: f32| Aabb::from_center_half_extents(Vec3::new(x, 0.0, 0.0), Vec3::splat(0.5));
    let a = bp.insert(at(0.0), 1);
    bp.insert(at(1.0), 2);
    bp.update_pairs();
    assert_eq!(bp.new_pairs(), &[(1, 2)]);
    // Small motion inside the fat box: nothing moves, nothing changes.
    assert!(!bp.update(a, at(-0.05)));
    bp.update_pairs();
    assert!(bp.new_pairs().is_empty() && bp.lost_pairs().is_empty());
    // Far away: re-inserted and the pair is lost.
    assert!(bp.update(a, at(-5.0)));
    bp.update_pairs();
    assert_eq!(bp.lost_pairs(), &[(1, 2)]);
    assert_eq!(bp.pairs().count(), 0);
}

#[test]
fn static_static_pairs_are_never_reported() {
    let mut rng = Rng::new(3);
    let mut bp = BroadPhase::new(0.05);
    // Overlapping static slabs and a few dynamic boxes among them.
    let mut statics = Vec::new();
    for u in 0..50u32 {
        let b = Aabb::from_center_half_extents(Vec3::new(u as f32 * 0.5, 0.0, 0.0), Vec3::new(0.6, 0.2, 1.0));
        statics.push((bp.insert_static(b, u), b));
    }
    let mut dynamics = Vec::new();
    for u in 50..80u32 {
        let b = Aabb::from_center_half_extents(
            Vec3::new(rng.range(0.0, 25.0), rng.range(-0.5, 0.5), 0.0),
            Vec3::splat(0.2),
        );
        dynamics.push((bp.insert(b, u), b));
    }
    let is_static = |u: u32| u < 50;
    let mut model = BTreeSet::new();
    for step in 0..40 {
        // Move statics too (a static body can be placed by the user).
        for (id, b) in statics.iter_mut().chain(dynamics.iter_mut()) {
            if rng.unit() < 0.3 {
                *b = translate(*b, rng.vec(-0.3, 0.3));
                bp.update(*id, *b);
            }
        }
        bp.update_pairs();
        apply_events(&bp, &mut model);
        for &(a, b) in bp.new_pairs() {
            assert!(!(is_static(a) && is_static(b)), "step {step}: {a}-{b}");
        }
        assert!(bp.pairs().all(|(a, b)| !(is_static(a) && is_static(b))));
        assert!(model.iter().any(|&(a, b)| is_static(a) != is_static(b)));
        bp.validate();
    }
}

#[test]
fn filter_excludes_unwanted_pairs() {
    // Users 2k and 2k+1 are two colliders of body k and must not pair.
    let body = |u: u32| u / 2;
    let mut bp = BroadPhase::new(0.0);
    for u in 0..6u32 {
        let x = (u / 2) as f32 * 0.8;
        bp.insert(Aabb::from_center_half_extents(Vec3::new(x, 0.0, 0.0), Vec3::splat(0.5)), u);
    }
    bp.update_pairs_filtered(|a, b| {
        assert!(a <= b);
        body(a) != body(b)
    });
    assert!(bp.pairs().all(|(a, b)| body(a) != body(b)));
    // Bodies 0-1 and 1-2 overlap (4 collider pairs each); 0-2 do not.
    assert_eq!(bp.pair_count(), 8);
    assert_eq!(bp.new_pairs(), &[(0, 2), (0, 3), (1, 2), (1, 3), (2, 4), (2, 5), (3, 4), (3, 5)]);
}

/// A proxy's own margin (`insert_with_margin`, `update_with_margin`)
/// decides how far it may move before re-insertion, and a narrower margin
/// shrinks a box that has become too fat for it.
#[test]
fn a_proxy_margin_sets_how_far_it_moves_before_reinsertion() {
    let mut bp = BroadPhase::new(0.02);
    let at = |x: f32| Aabb::from_center_half_extents(Vec3::new(x, 0.0, 0.0), Vec3::splat(0.5));
    let wide = bp.insert_with_margin(at(0.0), 1, 0.1);
    let narrow = bp.insert(at(5.0), 2);
    // Fat boxes: half extent 0.5 plus each proxy's margin.
    assert_eq!(bp.fat_aabb(wide).max.x, 0.6);
    assert_eq!(bp.fat_aabb(narrow).max.x, 5.52);
    // 5 cm: inside the 10 cm margin, outside the 2 cm one.
    assert!(!bp.update_with_margin(wide, at(0.05), 0.1));
    assert!(bp.update(narrow, at(5.05)));
    // Widening the margin alone re-inserts nothing; the new margin applies
    // at the next re-insertion.
    assert!(!bp.update_with_margin(narrow, at(5.05), 0.1));
    assert!(bp.update_with_margin(narrow, at(5.2), 0.1));
    assert!((bp.fat_aabb(narrow).max.x - 5.8).abs() < 1e-6, "{:?}", bp.fat_aabb(narrow));
    // Narrowing it to 2 cm: the 10 cm box is 0.16 too long on each axis,
    // more than four margins (0.08), so it is rebuilt with the new margin.
    assert!(bp.update_with_margin(narrow, at(5.2), 0.02));
    assert!((bp.fat_aabb(narrow).max.x - 5.72).abs() < 1e-6, "{:?}", bp.fat_aabb(narrow));
    // A plain `update` keeps the proxy's own margin, whether given at
    // insertion or by the last `update_with_margin`: moved out of their
    // boxes, both come back 0.1 fat, not 0.02.
    assert!(bp.update(wide, at(0.3)));
    assert!((bp.fat_aabb(wide).max.x - 0.9).abs() < 1e-6, "{:?}", bp.fat_aabb(wide));
    assert!(!bp.update_with_margin(narrow, at(5.2), 0.1));
    assert!(bp.update(narrow, at(6.0)));
    assert!((bp.fat_aabb(narrow).max.x - 6.6).abs() < 1e-6, "{:?}", bp.fat_aabb(narrow));
    // And its oversize test is its own: a box stretched 0.3 along x by a
    // displacement is kept while the excess (0.3) is within four of its
    // margins (0.4), and rebuilt past that.
    assert!(bp.update_with_displacement(wide, at(0.0), Vec3::new(0.3, 0.0, 0.0)));
    assert!(!bp.update(wide, at(0.0)), "0.3 too long, within 4 × 0.1");
    assert!(bp.update_with_margin(wide, at(0.0), 0.05), "0.3 too long, past 4 × 0.05");
    bp.validate();
}

#[test]
fn identical_runs_give_identical_pair_lists() {
    fn run() -> Vec<[Vec<(u32, u32)>; 3]> {
        let mut rng = Rng::new(12345);
        let mut bp = BroadPhase::new(0.05);
        let mut bodies: Vec<(ProxyId, Aabb)> = Vec::new();
        for u in 0..400u32 {
            let b = random_box(&mut rng, 10.0);
            bodies.push((bp.insert(b, u), b));
        }
        let mut log = Vec::new();
        for step in 0..30u32 {
            for (id, b) in bodies.iter_mut() {
                if rng.unit() < 0.3 {
                    *b = translate(*b, rng.vec(-0.2, 0.2));
                    bp.update(*id, *b);
                }
            }
            if step % 5 == 0 {
                let k = rng.below(bodies.len());
                let (id, _) = bodies.swap_remove(k);
                bp.remove(id);
                let b = random_box(&mut rng, 10.0);
                bodies.push((bp.insert(b, 1000 + step), b));
            }
            bp.update_pairs();
            // `pairs()` unsorted on purpose: its order must repeat too.
            log.push([bp.new_pairs().to_vec(), bp.lost_pairs().to_vec(), bp.pairs().collect()]);
        }
        log
    }
    let first = run();
    assert!(first.iter().any(|[n, l, _]| !n.is_empty() && !l.is_empty()));
    assert_eq!(first, run());
}

#[test]
fn query_visits_overlapping_proxies_and_stops_early() {
    let mut bp = BroadPhase::new(0.0);
    for u in 0..100u32 {
        let c = Vec3::new((u % 10) as f32, (u / 10) as f32, 0.0);
        bp.insert(Aabb::from_center_half_extents(c, Vec3::splat(0.25)), u);
    }
    let region = Aabb::new(Vec3::new(-0.5, -0.5, -1.0), Vec3::new(2.5, 1.5, 1.0));
    let mut hits = Vec::new();
    bp.query(&region, |u| {
        hits.push(u);
        true
    });
    hits.sort_unstable();
    assert_eq!(hits, vec![0, 1, 2, 10, 11, 12]);

    let mut seen = 0;
    bp.query(&region, |_| {
        seen += 1;
        seen < 2
    });
    assert_eq!(seen, 2);

    let empty = BroadPhase::new(0.1);
    empty.query(&region, |_| panic!("empty tree has no proxies"));
}

#[test]
fn update_reinserts_only_when_leaving_the_fat_box() {
    let mut bp = BroadPhase::new(0.1);
    let b = Aabb::from_center_half_extents(Vec3::ZERO, Vec3::splat(0.5));
    let id = bp.insert(b, 0);
    assert_eq!(bp.fat_aabb(id), b.expanded(0.1));
    assert_eq!(bp.user(id), 0);
    assert!(!bp.is_static(id));
    assert!(!bp.update(id, translate(b, Vec3::new(0.09, 0.0, 0.0))));
    assert!(bp.update(id, translate(b, Vec3::new(0.11, 0.0, 0.0))));
    let moved = translate(b, Vec3::new(0.11, 0.0, 0.0));
    assert_eq!(bp.fat_aabb(id), moved.expanded(0.1));

    // A displacement stretches the fat box towards the motion only.
    let d = Vec3::new(1.0, -0.5, 0.0);
    let far = translate(b, Vec3::new(3.0, 0.0, 0.0));
    assert!(bp.update_with_displacement(id, far, d));
    let fat = bp.fat_aabb(id);
    let plain = far.expanded(0.1);
    assert_eq!(fat.max.x, plain.max.x + 1.0);
    assert_eq!(fat.min.x, plain.min.x);
    assert_eq!(fat.min.y, plain.min.y - 0.5);
    assert_eq!(fat.max.y, plain.max.y);
    // Moving along inside the stretched box with the same hint costs nothing...
    let along = translate(far, Vec3::new(0.8, -0.3, 0.0));
    assert!(!bp.update_with_displacement(id, along, d));
    assert_eq!(bp.fat_aabb(id), fat);
    // ...but once the body stops, the oversized box is refreshed even though
    // it still holds the body.
    let stopped = translate(far, Vec3::new(0.8, -0.3, 0.0));
    assert!(fat.contains(&stopped));
    assert!(bp.update(id, stopped));
    assert_eq!(bp.fat_aabb(id), stopped.expanded(0.1));
}

#[test]
fn small_trees_and_empty_tree() {
    let mut bp = BroadPhase::new(0.05);
    assert!(bp.is_empty());
    assert_eq!(bp.len(), 0);
    assert_eq!(bp.height(), 0);
    bp.update_pairs();
    assert!(bp.new_pairs().is_empty());
    let b = Aabb::from_center_half_extents(Vec3::ZERO, Vec3::splat(0.5));
    let a = bp.insert(b, 0);
    assert_eq!(bp.height(), 0);
    let c = bp.insert(b, 1);
    assert_eq!(bp.height(), 1);
    bp.update_pairs();
    assert_eq!(bp.new_pairs(), &[(0, 1)]);
    bp.remove(a);
    bp.remove(c);
    assert!(bp.is_empty());
    bp.update_pairs();
    assert_eq!(bp.lost_pairs(), &[(0, 1)]);
    bp.validate();
}

#[test]
fn a_proxy_never_pairs_with_itself_and_duplicate_users_still_pair() {
    let b = Aabb::from_center_half_extents(Vec3::ZERO, Vec3::splat(0.5));
    // One proxy alone overlaps only itself, which is never a pair.
    let mut bp = BroadPhase::new(0.0);
    bp.insert(b, 7);
    bp.update_pairs();
    assert!(bp.new_pairs().is_empty());
    // Two proxies with the same user id (two colliders of one body) are two
    // proxies: their pair is reported as (7, 7) unless filtered out.
    bp.insert(b, 7);
    bp.update_pairs();
    assert_eq!(bp.new_pairs(), &[(7, 7)]);

    let mut filtered = BroadPhase::new(0.0);
    filtered.insert(b, 7);
    filtered.insert(b, 7);
    filtered.update_pairs_filtered(|a, b| a != b);
    assert!(filtered.new_pairs().is_empty());
    assert_eq!(filtered.pair_count(), 0);
}

#[test]
fn steady_state_steps_do_not_allocate() {
    let mut rng = Rng::new(5);
    let mut bp = BroadPhase::new(0.02);
    let mut bodies: Vec<(ProxyId, Aabb)> = (0..2000u32)
        .map(|u| {
            let b = random_box(&mut rng, 20.0);
            (bp.insert(b, u), b)
        })
        .collect();
    bp.update_pairs();
    // Every body oscillates by more than the margin, so every step re-inserts
    // all of them and loses and regains pairs. After one full period the
    // buffers have reached their high-water marks.
    let offsets: Vec<Vec3> = (0..bodies.len()).map(|_| rng.vec(-0.3, 0.3)).collect();
    let mut step = |bp: &mut BroadPhase, sign: f32| {
        for ((id, b), d) in bodies.iter_mut().zip(&offsets) {
            *b = translate(*b, *d * sign);
            bp.update(*id, *b);
        }
        bp.update_pairs();
    };
    for _ in 0..3 {
        step(&mut bp, 1.0);
        step(&mut bp, -1.0);
    }
    let before = allocations();
    let mut events = 0;
    for _ in 0..3 {
        step(&mut bp, 1.0);
        events += bp.new_pairs().len() + bp.lost_pairs().len();
        step(&mut bp, -1.0);
        events += bp.new_pairs().len() + bp.lost_pairs().len();
    }
    assert_eq!(allocations() - before, 0, "steady-state steps allocated");
    assert!(events > 0, "the test should exercise pair churn");
}

/// The tree's quality under motion. Re-inserting a proxy walks up only
/// while the ancestors' boxes or heights change (the surface-area
/// rotations above are skipped, as they shape the tree but never decide
/// the pairs), so nothing repairs the upper levels of a tree whose leaves
/// drift a little at a time. Measured here: 3,000 boxes in a 30 m cube,
/// each step a tenth of them moved up to 5 cm (re-inserted when they leave
/// their 2 cm margin), 2,000 steps: the sum of the internal nodes' areas
/// (what a query pays) against a tree built afresh from the same boxes.
#[test]
fn drifting_boxes_keep_the_tree_about_as_good_as_a_fresh_one() {
    let mut rng = Rng::new(0xb0a7_7ee5);
    let margin = 0.02;
    let mut bp = BroadPhase::new(margin);
    let mut boxes: Vec<Aabb> = (0..3000).map(|_| random_box(&mut rng, 30.0)).collect();
    let ids: Vec<ProxyId> = boxes.iter().enumerate().map(|(k, b)| bp.insert(*b, k as u32)).collect();
    bp.update_pairs();
    let fresh_area = |bp: &BroadPhase| {
        let mut fresh = BroadPhase::new(margin);
        for (k, &id) in ids.iter().enumerate() {
            fresh.insert(bp.fat_aabb(id).expanded(-margin), k as u32);
        }
        fresh.internal_area()
    };
    let start = bp.internal_area() / fresh_area(&bp);
    let mut worst: f32 = 0.0;
    for step in 0..2000 {
        for _ in 0..300 {
            let k = rng.below(boxes.len());
            let d = rng.vec(-0.05, 0.05);
            boxes[k] = translate(boxes[k], d);
            bp.update(ids[k], boxes[k]);
        }
        bp.update_pairs();
        if step % 500 == 499 {
            bp.validate();
            let ratio = bp.internal_area() / fresh_area(&bp);
            eprintln!("step {step}: internal area {ratio:.3} x a fresh tree's");
            worst = worst.max(ratio);
        }
    }
    eprintln!("at the start {start:.3}, worst {worst:.3}");
    // Measured: 1.00 at the start (the same insertions), then 0.80, 0.85,
    // 0.80, 0.71 (the rotations make a moved tree better than one built by
    // insertion alone); walking to the root every time gave 0.81, 0.86,
    // 0.82, 0.71, in twice the time. No worse than a fresh tree:
    assert!(worst < 1.0, "the tree degraded to {worst:.2} x a fresh one");
}

/// `query_fixed` answers exactly what `query` answers of the static and
/// kinematic proxies, in the same order, while proxies of all three kinds
/// move, leave and arrive (the tree's flags that let it skip subtrees of
/// dynamic proxies stay true through every insertion, removal and
/// rotation: `validate` checks them too). Reference: `query`, filtered.
#[test]
fn query_fixed_finds_exactly_the_static_and_kinematic_proxies() {
    #[derive(Clone, Copy, PartialEq)]
    enum Kind {
        Static,
        Kinematic,
        Dynamic,
    }
    for seed in 1..=3u64 {
        let mut rng = Rng::new(seed);
        let world = 8.0;
        let mut bp = BroadPhase::new(0.1);
        let mut proxies: Vec<(ProxyId, u32, Aabb, Kind)> = Vec::new();
        let mut kind_of: Vec<Kind> = Vec::new();
        let insert = |bp: &mut BroadPhase, rng: &mut Rng, kind_of: &mut Vec<Kind>| {
            let tight = random_box(rng, world);
            let user = kind_of.len() as u32;
            let r = rng.unit();
            let (kind, id) = if r < 0.1 {
                (Kind::Static, bp.insert_static(tight, user))
            } else if r < 0.2 {
                (Kind::Kinematic, bp.insert_kinematic(tight, user, 0.1))
            } else {
                (Kind::Dynamic, bp.insert(tight, user))
            };
            kind_of.push(kind);
            (id, user, tight, kind)
        };
        for _ in 0..300 {
            proxies.push(insert(&mut bp, &mut rng, &mut kind_of));
        }
        let mut fixed_seen = 0;
        for step in 0..80 {
            for p in proxies.iter_mut().filter(|p| p.3 != Kind::Static) {
                if rng.unit() < 0.3 {
                    p.2 = translate(p.2, rng.vec(-0.3, 0.3));
                    bp.update(p.0, p.2);
                }
            }
            for _ in 0..rng.below(5) {
                let gone = proxies.swap_remove(rng.below(proxies.len()));
                bp.remove(gone.0);
            }
            for _ in 0..rng.below(5) {
                proxies.push(insert(&mut bp, &mut rng, &mut kind_of));
            }
            bp.update_pairs();
            bp.validate();
            for _ in 0..20 {
                let region = Aabb::from_center_half_extents(rng.vec(0.0, world), rng.vec(0.2, 2.0));
                let mut all = Vec::new();
                bp.query(&region, |u| {
                    all.push(u);
                    true
                });
                all.retain(|&u| kind_of[u as usize] != Kind::Dynamic);
                let mut fixed = Vec::new();
                bp.query_fixed(&region, |u| {
                    fixed.push(u);
                    true
                });
                assert_eq!(fixed, all, "seed {seed} step {step}");
                fixed_seen += fixed.len();
            }
        }
        assert!(fixed_seen > 100, "seed {seed}: the queries met only {fixed_seen} fixed proxies");
    }
}
