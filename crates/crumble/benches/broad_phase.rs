//! Broad-phase scaling: cost of one incremental update (every proxy nudged,
//! a tenth of them leaving their fat boxes) for walls of 1k to 16k bricks.
//! Linear growth in n shows as a flat time per 1,000 proxies.
//!
//! Run: `cargo bench -p crumble-physics --bench broad_phase`

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use crumble::broad_phase::BroadPhase;
use crumble::{Aabb, Vec3};

fn wall(n: usize) -> Vec<Aabb> {
    let per_row = (n as f32).sqrt() as usize;
    (0..n)
        .map(|i| {
            let (x, y) = ((i % per_row) as f32, (i / per_row) as f32);
            let c = Vec3::new(x * 0.215, y * 0.065 + 0.0325, 0.0);
            Aabb::from_center_half_extents(c, Vec3::new(0.1075, 0.0325, 0.05125))
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("broad_phase_update");
    for n in [1_000usize, 4_000, 16_000] {
        let boxes = wall(n);
        let mut bp = BroadPhase::new(0.02);
        let ids: Vec<_> = boxes.iter().enumerate().map(|(i, b)| bp.insert(*b, i as u32)).collect();
        bp.update_pairs();
        let mut t = 0u32;
        group.throughput(Throughput::Elements(n as u64));
        group.bench_with_input(BenchmarkId::from_parameter(n), &n, |bench, _| {
            bench.iter(|| {
                t = t.wrapping_add(1);
                for (k, (id, b)) in ids.iter().zip(&boxes).enumerate() {
                    // Every tenth proxy jumps out of its fat box and back.
                    let jump = if (k as u32 + t).is_multiple_of(10) { 0.05 * (t % 2) as f32 } else { 0.0 };
                    let off = Vec3::new(jump, 0.0, 0.0);
                    bp.update(*id, Aabb::new(b.min + off, b.max + off));
                }
                bp.update_pairs();
                bp.pair_count()
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
