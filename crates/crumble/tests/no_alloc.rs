//! Issue 6: no allocation on the per-step hot path in steady state. A
//! counting global allocator (this test binary only) counts every
//! allocation and reallocation made while a warmed-up scene steps.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use crumble::scenes::{add_ball, add_ground, add_wall, WallSpec, BRICK, STEEL};
use crumble::{Vec3, World, WorldSettings};

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `alloc`/`realloc` above, i.e. from System.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        // SAFETY: as for `dealloc`.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

const DT: f32 = 1.0 / 60.0;

/// Allocations made by `steps` steps of `world`.
fn allocations(world: &mut World, steps: usize) -> usize {
    let before = ALLOCATIONS.load(Ordering::Relaxed);
    for _ in 0..steps {
        world.step(DT).unwrap();
    }
    ALLOCATIONS.load(Ordering::Relaxed) - before
}

// One test function: the counter is global, and the harness runs test
// functions on parallel threads whose allocations it would also count.
#[test]
fn steady_state_steps_do_not_allocate() {
    a_resting_wall_steps_without_allocating();
    a_wall_falling_asleep_and_sleeping_steps_without_allocating();
    several_walls_in_several_units_step_without_allocating();
}

fn a_resting_wall_steps_without_allocating() {
    let mut world = World::new(WorldSettings { sleep_enabled: false, ..WorldSettings::default() }).unwrap();
    add_ground(&mut world, 0.0, BRICK).unwrap();
    add_wall(&mut world, &WallSpec::default()).unwrap();
    // Warm-up: every buffer reaches its steady size.
    let warm = allocations(&mut world, 30);
    assert!(warm > 0, "the counter counts (the first steps size the buffers)");
    assert_eq!(allocations(&mut world, 60), 0, "60 steps of the resting 10 x 10 wall");
}

fn a_wall_falling_asleep_and_sleeping_steps_without_allocating() {
    let mut world = World::new(WorldSettings::default()).unwrap();
    add_ground(&mut world, 0.0, BRICK).unwrap();
    add_wall(&mut world, &WallSpec::default()).unwrap();
    allocations(&mut world, 150);
    assert_eq!(allocations(&mut world, 60), 0, "60 steps of the sleeping wall");
    // A ball hits it: contacts appear and the wall wakes, which may allocate
    // while buffers grow; once the debris rests again, nothing allocates.
    add_ball(&mut world, 0.15, Vec3::new(0.0, 0.33, 1.0), Vec3::new(0.0, 0.0, -15.0), STEEL, true).unwrap();
    allocations(&mut world, 600);
    assert_eq!(allocations(&mut world, 60), 0, "60 steps after the debris settled");
}

/// Six 10 x 10 walls 2 m apart: six islands of ~285 constraints, solved in
/// two units (small islands share a unit until it holds ~1,000). On the
/// calling thread: with threads, the step enters rayon's pool once, and
/// rayon's job queue allocates a block of its own every 63 such entries
/// (measured: one allocation every ~60 steps, on a pool of two, owned or
/// global); that is rayon's, amortised, and not on our path.
fn several_walls_in_several_units_step_without_allocating() {
    let mut world = World::new(WorldSettings { sleep_enabled: false, threads: 1, ..WorldSettings::default() }).unwrap();
    add_ground(&mut world, 0.0, BRICK).unwrap();
    for k in 0..6 {
        let spec = WallSpec { origin: Vec3::new(0.0, 0.0, 2.0 * k as f32), ..WallSpec::default() };
        add_wall(&mut world, &spec).unwrap();
    }
    allocations(&mut world, 30);
    assert_eq!(world.profile().solver_units, 2, "two units");
    assert_eq!(allocations(&mut world, 60), 0, "60 steps of six resting walls in two units");
}
