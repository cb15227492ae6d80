//! The seed's 15-axis test, its first-contact points, and the least-overlap
//! query, checked against an independent brute force and hand-built cases.

mod common;

use common::{close, Rng};
use crumble::collision::sat::{
    eberly_contact_point, sat_query, sat_query_within, seed_sigma, separating_axis, AxisKind, AxisSeparation, Obb,
    SeedAxis, MIN_EDGE_AXIS_LENGTH_SQUARED, PARALLEL_EPSILON,
};
use crumble::glam::{DVec3, EulerRot};
use crumble::{Cuboid, Pose, Quat, Vec3};

// ---------------------------------------------------------------------------
// Brute force
// ---------------------------------------------------------------------------

/// One candidate axis of the brute force.
#[derive(Clone, Copy, Debug)]
struct BfAxis {
    /// Separation of the corner projections along the unit axis (f64).
    sep: f64,
    /// Length of the unnormalised axis (1 for faces, |Ai × Bj| for edges).
    len: f64,
}

fn corners64(o: &Obb) -> [DVec3; 8] {
    let c = o.center.as_dvec3();
    let ax = o.axes.map(|a| a.as_dvec3());
    let h = o.half_extents.as_dvec3();
    std::array::from_fn(|k| {
        let s = |bit: usize, e: f64| if k & (1 << bit) != 0 { e } else { -e };
        c + ax[0] * s(0, h.x) + ax[1] * s(1, h.y) + ax[2] * s(2, h.z)
    })
}

/// Projects all 8 corners of both boxes on each of the 15 candidate axes
/// (face normals and normalised edge cross products, in table order), in
/// f64. Degenerate crosses (parallel edges) are `None`. This shares no code
/// with the crate's query: it never uses `c_ij`, extents or centre distance.
fn brute_force(a: &Obb, b: &Obb) -> [Option<BfAxis>; 15] {
    let ca = corners64(a);
    let cb = corners64(b);
    let aa = a.axes.map(|x| x.as_dvec3());
    let ba = b.axes.map(|x| x.as_dvec3());
    std::array::from_fn(|row| {
        let raw = match row {
            0..=2 => aa[row],
            3..=5 => ba[row - 3],
            _ => aa[(row - 6) / 3].cross(ba[(row - 6) % 3]),
        };
        let len = raw.length();
        if row >= 6 && len * len < MIN_EDGE_AXIS_LENGTH_SQUARED as f64 {
            return None;
        }
        let l = raw / len;
        let (mut amin, mut amax) = (f64::INFINITY, f64::NEG_INFINITY);
        for p in &ca {
            let t = p.dot(l);
            amin = amin.min(t);
            amax = amax.max(t);
        }
        let (mut bmin, mut bmax) = (f64::INFINITY, f64::NEG_INFINITY);
        for p in &cb {
            let t = p.dot(l);
            bmin = bmin.min(t);
            bmax = bmax.max(t);
        }
        Some(BfAxis { sep: (bmin - amax).max(amin - bmax), len })
    })
}

fn random_obb(rng: &mut Rng, center: Vec3) -> Obb {
    // Full sizes 0.01–10 m per extent, log-uniform.
    let h =
        Vec3::new(rng.log_range(0.005, 5.0) as f32, rng.log_range(0.005, 5.0) as f32, rng.log_range(0.005, 5.0) as f32);
    let pose = Pose::new(center, rng.rotation());
    Obb::from_cuboid(&Cuboid::new(h).unwrap(), &pose)
}

fn best_of(bf: &[Option<BfAxis>; 15]) -> (usize, f64) {
    let mut best = (usize::MAX, f64::NEG_INFINITY);
    for (row, x) in bf.iter().enumerate() {
        if let Some(x) = x {
            if x.sep > best.1 {
                best = (row, x.sep);
            }
        }
    }
    best
}

/// Extra slack of the seed's `|c_ij| + ε` guard on a row, in units of
/// separation along the unit axis (see `PARALLEL_EPSILON`).
fn seed_slack(a: &Obb, b: &Obb, row: usize, len: f64) -> f64 {
    let ha = a.half_extents.as_dvec3().to_array();
    let hb = b.half_extents.as_dvec3().to_array();
    let e = PARALLEL_EPSILON as f64;
    let s = match SeedAxis::from_row(row).unwrap().kind() {
        AxisKind::FaceA(_) => e * (hb[0] + hb[1] + hb[2]),
        AxisKind::FaceB(_) => e * (ha[0] + ha[1] + ha[2]),
        AxisKind::Edge(i, j) => {
            let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
            let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
            e * (ha[i1] + ha[i2] + hb[j1] + hb[j2])
        }
    };
    s / len
}

#[test]
fn sat_matches_brute_force_on_random_pairs() {
    const N: usize = 200_000;
    let mut rng = Rng::new(0x5eed_b0c5_0001);

    let mut overlap_both = 0usize;
    let mut separated_both = 0usize;
    let mut verdict_in_band = 0usize;
    let mut verdict_bad = 0usize;
    let mut depth_bad = 0usize;
    let mut axis_tie = 0usize;
    let mut axis_bad = 0usize;
    let mut seed_in_band = 0usize;
    let mut seed_bad = 0usize;
    let mut seed_order_bad = 0usize;
    let mut max_rel_err = 0.0f64;
    let mut max_abs_err = 0.0f64;
    let mut near_touching = 0usize;

    for n in 0..N {
        let ca = Vec3::new(rng.range(-5.0, 5.0) as f32, rng.range(-5.0, 5.0) as f32, rng.range(-5.0, 5.0) as f32);
        let a = random_obb(&mut rng, ca);
        let mut b = random_obb(&mut rng, Vec3::ZERO);
        let reach = (a.half_extents.length() + b.half_extents.length()) as f64;
        let dir = rng.unit_vector();
        b.center = ca + dir * (rng.range(0.0, 1.2) * reach) as f32;
        if n % 3 == 0 {
            // Slide B along the brute-force best axis to nearly touching,
            // so that the band around touching is well populated.
            let bf = brute_force(&a, &b);
            let (row, sep) = best_of(&bf);
            let raw = match row {
                0..=2 => a.axes[row],
                3..=5 => b.axes[row - 3],
                _ => a.axes[(row - 6) / 3].cross(b.axes[(row - 6) % 3]),
            }
            .normalize();
            let toward = if raw.dot(b.center - a.center) >= 0.0 { raw } else { -raw };
            let jitter = rng.range(-1e-3, 1e-3) * reach;
            b.center -= toward * (sep + jitter) as f32;
        }

        let bf = brute_force(&a, &b);
        let (bf_row, bf_best) = best_of(&bf);
        let scale = (b.center - a.center).length() as f64
            + (a.half_extents.element_sum() + b.half_extents.element_sum()) as f64;
        // f32 band: positions are up to ~25 m from the origin and extents
        // up to 5 m, so one f32 rounding of a projected coordinate is ~1e-6
        // of the scale and a separation sums a dozen of them; an absolute
        // 1e-5 m band is below f32 resolution for the large boxes, hence
        // the size-relative part.
        let band = 1e-5f64.max(4e-6 * scale);

        let q = sat_query(&a, &b);
        let best = q.best();
        let sat_sep = best.separation as f64;
        let sat_overlap = sat_sep <= 0.0;
        let bf_overlap = bf_best <= 0.0;
        if sat_overlap != bf_overlap {
            if bf_best.abs() <= band {
                verdict_in_band += 1;
            } else {
                verdict_bad += 1;
                eprintln!("verdict: sat {sat_sep} bf {bf_best} a {a:?} b {b:?}");
            }
        }
        if sat_overlap && bf_overlap {
            overlap_both += 1;
        } else if !sat_overlap && !bf_overlap {
            separated_both += 1;
        }
        // Least overlap / largest separation: value, then axis.
        let err = (sat_sep - bf_best).abs();
        max_rel_err = max_rel_err.max(err / scale);
        max_abs_err = max_abs_err.max(err);
        if bf_best.abs() <= 1e-3 * scale {
            near_touching += 1;
        }
        if err > 1e-4 * bf_best.abs() + band {
            depth_bad += 1;
            eprintln!("depth: sat {sat_sep} bf {bf_best} row {bf_row} vs {:?}", best.axis);
        }
        let row = best.axis.row();
        if row != bf_row {
            match bf[row] {
                Some(x) if bf_best - x.sep <= band => axis_tie += 1,
                _ => {
                    axis_bad += 1;
                    eprintln!("axis: sat {:?} {sat_sep}, bf row {bf_row} {bf_best}", best.axis);
                }
            }
        }
        // The query's normal points from A to B.
        assert!(best.normal.dot(b.center - a.center) >= -1e-6 * scale as f32);
        assert!((best.normal.length() - 1.0).abs() < 1e-4);

        // The seed test: verdict, and that its row is the first in table
        // order that separates (up to the band and the ε guard).
        let tol = |r: usize| match bf[r] {
            Some(x) => (band + seed_slack(&a, &b, r, x.len)) / x.len.max(1e-3),
            None => f64::INFINITY,
        };
        match separating_axis(&a, &b) {
            None => {
                let violated = (0..15).any(|r| bf[r].is_some_and(|x| x.sep > tol(r)));
                if violated {
                    seed_bad += 1;
                    eprintln!("seed says overlap, bf best {bf_best} at {bf_row}");
                } else if !bf_overlap {
                    seed_in_band += 1;
                }
            }
            Some(axis) => {
                let r = axis.row();
                match bf[r] {
                    Some(x) if x.sep > -band / x.len.max(1e-3) => {}
                    _ => {
                        seed_bad += 1;
                        eprintln!("seed says {axis:?} separates, bf {:?}", bf[r]);
                    }
                }
                if (0..r).any(|e| bf[e].is_some_and(|x| x.sep > tol(e))) {
                    seed_order_bad += 1;
                    eprintln!("seed picked {axis:?}, an earlier row separates clearly");
                }
                if bf_overlap && bf_best.abs() <= band {
                    seed_in_band += 1;
                }
            }
        }
    }

    println!(
        "sat vs brute force, {N} pairs: overlap {overlap_both}, separated {separated_both}, \
         verdict disagreements in band {verdict_in_band} / outside {verdict_bad}, \
         depth outside tolerance {depth_bad}, axis ties {axis_tie} / axis wrong {axis_bad}, \
         max |error| {max_abs_err:.3e} m, max |error|/scale {max_rel_err:.3e}, \
         pairs within 1e-3·scale of touching {near_touching}"
    );
    println!(
        "seed test vs brute force: in band {seed_in_band}, wrong verdict {seed_bad}, \
         not first in table order {seed_order_bad}"
    );
    assert!(overlap_both > N / 5 && separated_both > N / 5);
    assert_eq!(verdict_bad, 0);
    assert_eq!(depth_bad, 0);
    assert_eq!(axis_bad, 0);
    assert_eq!(seed_bad, 0);
    assert_eq!(seed_order_bad, 0);
}

// ---------------------------------------------------------------------------
// Hand-built cases: each of the 15 rows fires first
// ---------------------------------------------------------------------------

fn obb(center: Vec3, rotation: Quat, half: Vec3) -> Obb {
    Obb::from_cuboid(&Cuboid::new(half).unwrap(), &Pose::new(center, rotation))
}

fn generic_rotation() -> Quat {
    Quat::from_euler(EulerRot::XYZ, 0.3, 0.5, 0.7)
}

/// B's support point (a vertex, or the midpoint of an edge or face when
/// `dir` is perpendicular to an axis) relative to its centre, found by
/// projecting corners: the mean of the corners within `1e-6` of the maximum.
fn support_offset(o: &Obb, dir: Vec3) -> Vec3 {
    let cs = o.corners();
    let m = cs.iter().map(|c| c.dot(dir)).fold(f32::NEG_INFINITY, f32::max);
    let mut sum = Vec3::ZERO;
    let mut n = 0.0;
    for c in cs {
        if c.dot(dir) >= m - 1e-5 {
            sum += c;
            n += 1.0;
        }
    }
    sum / n - o.center
}

/// A: axis-aligned at the origin. B: rotated generically, with the vertex
/// of B nearest A placed at the centre of A's face `side·Ai`, then pushed
/// out by `gap` along that normal. Returns (A, B, contact point at gap 0).
fn face_a_case(i: usize, side: f32, gap: f32) -> (Obb, Obb, Vec3) {
    let a = obb(Vec3::ZERO, Quat::IDENTITY, Vec3::new(1.0, 1.2, 0.8));
    let mut b = obb(Vec3::ZERO, generic_rotation(), Vec3::new(0.5, 0.4, 0.3));
    let n = a.axes[i] * side;
    let touch = n * a.half_extents[i];
    b.center = touch - support_offset(&b, -n) + n * gap;
    (a, b, touch)
}

/// A: small, axis-aligned at the origin. B: large, rotated generically, with
/// the centre of its face `−side·Bj` on A's vertex extreme along `side·Bj`,
/// pushed out by `gap`. Returns (A, B, contact point at gap 0).
fn face_b_case(j: usize, side: f32, gap: f32) -> (Obb, Obb, Vec3) {
    let a = obb(Vec3::ZERO, Quat::IDENTITY, Vec3::new(0.5, 0.4, 0.3));
    let mut b = obb(Vec3::ZERO, generic_rotation(), Vec3::new(3.0, 2.5, 2.0));
    let n = b.axes[j] * side;
    let vertex = support_offset(&a, n);
    b.center = vertex + n * (b.half_extents[j] + gap);
    (a, b, vertex)
}

/// A: axis-aligned; B rotated generically. A's edge parallel to Ai that is
/// extreme along `side·L` (`L = Ai × Bj`) touches B's edge parallel to Bj
/// that is extreme along `−side·L`, at parameter `ta` along A's edge and
/// `tb` along B's (fractions of the half extents), then B is pushed out by
/// `gap` along `side·L`. Returns (A, B, contact point at gap 0).
fn edge_case(i: usize, j: usize, side: f32, ta: f32, tb: f32, gap: f32) -> (Obb, Obb, Vec3) {
    let a = obb(Vec3::ZERO, Quat::IDENTITY, Vec3::new(1.0, 1.2, 0.8));
    let mut b = obb(Vec3::ZERO, generic_rotation(), Vec3::new(0.7, 0.9, 1.1));
    let l = a.axes[i].cross(b.axes[j]).normalize() * side;
    let p = support_offset(&a, l) + a.axes[i] * (ta * a.half_extents[i]);
    let q = support_offset(&b, -l) + b.axes[j] * (tb * b.half_extents[j]);
    b.center = p - q + l * gap;
    (a, b, p)
}

#[test]
fn each_axis_fires_first_in_a_hand_built_case() {
    let gap = 1e-3;
    let mut cases: Vec<(String, Obb, Obb, SeedAxis)> = Vec::new();
    for i in 0..3 {
        for side in [1.0, -1.0] {
            let (a, b, _) = face_a_case(i, side, gap);
            let name = format!("vertex of B just off face {}A{i}", if side > 0.0 { "+" } else { "-" });
            cases.push((name, a, b, SeedAxis::face_a(i)));
        }
    }
    for j in 0..3 {
        for side in [1.0, -1.0] {
            let (a, b, _) = face_b_case(j, side, gap);
            let name = format!("vertex of A just off face {}B{j}", if side > 0.0 { "-" } else { "+" });
            cases.push((name, a, b, SeedAxis::face_b(j)));
        }
    }
    for i in 0..3 {
        for j in 0..3 {
            for side in [1.0, -1.0] {
                let (a, b, _) = edge_case(i, j, side, 0.2, -0.3, gap);
                let name = format!("edge A{i} just off edge B{j}, side {side}");
                cases.push((name, a, b, SeedAxis::edge(i, j)));
            }
        }
    }
    // A literal case: A (unit half extents) turned 45° about z, so its
    // corner reaches x = √2; B axis-aligned at x = 2.5 reaches back to 1.5.
    // A's own faces see overlap (|A0·D| = 1.77 < 1 + √2), B0 separates.
    cases.push((
        "diamond A beside axis-aligned B".into(),
        obb(Vec3::ZERO, Quat::from_rotation_z(std::f32::consts::FRAC_PI_4), Vec3::ONE),
        obb(Vec3::new(2.5, 0.0, 0.0), Quat::IDENTITY, Vec3::ONE),
        SeedAxis::B0,
    ));

    let mut seen = [false; 15];
    for (name, a, b, want) in &cases {
        let got = separating_axis(a, b);
        assert_eq!(got, Some(*want), "case '{name}'");
        // The least-overlap query agrees that the pair is separated.
        assert!(sat_query(a, b).is_separated(), "case '{name}'");
        seen[want.row()] = true;
    }
    assert!(seen.iter().all(|&s| s), "every row covered");

    // Touching exactly (gap 0, then slightly overlapping): no row fires.
    for i in 0..3 {
        let (a, b, _) = face_a_case(i, 1.0, -1e-4);
        assert_eq!(separating_axis(&a, &b), None);
        let (a, b, _) = face_b_case(i, 1.0, -1e-4);
        assert_eq!(separating_axis(&a, &b), None);
        for j in 0..3 {
            let (a, b, _) = edge_case(i, j, 1.0, 0.2, -0.3, -1e-4);
            assert_eq!(separating_axis(&a, &b), None, "edge {i} {j}");
        }
    }
}

#[test]
fn seed_axis_rows_and_kinds_follow_the_table() {
    let names = [
        "A0", "A1", "A2", "B0", "B1", "B2", "A0xB0", "A0xB1", "A0xB2", "A1xB0", "A1xB1", "A1xB2", "A2xB0", "A2xB1",
        "A2xB2",
    ];
    for (row, axis) in SeedAxis::ALL.iter().enumerate() {
        assert_eq!(axis.row(), row);
        assert_eq!(SeedAxis::from_row(row), Some(*axis));
        assert_eq!(format!("{axis:?}"), names[row]);
    }
    assert_eq!(SeedAxis::from_row(15), None);
    assert_eq!(SeedAxis::A2xB2.kind(), AxisKind::Edge(2, 2));
    assert_eq!(SeedAxis::B1.kind(), AxisKind::FaceB(1));
}

// ---------------------------------------------------------------------------
// Appendix B: the unique contact point
// ---------------------------------------------------------------------------

#[test]
fn eberly_point_face_vertex_cases() {
    for i in 0..3 {
        for side in [1.0, -1.0] {
            let (a, b, touch) = face_a_case(i, side, 0.0);
            let axis = SeedAxis::face_a(i);
            let sigma = seed_sigma(&a, &b, axis);
            assert_eq!(sigma, side);
            let p = eberly_contact_point(&a, &b, axis, sigma);
            assert!(close(p, touch, 1e-5), "A{i} side {side}: {p} vs {touch}");
        }
    }
    for j in 0..3 {
        for side in [1.0, -1.0] {
            let (a, b, vertex) = face_b_case(j, side, 0.0);
            let axis = SeedAxis::face_b(j);
            let sigma = seed_sigma(&a, &b, axis);
            assert_eq!(sigma, side);
            let p = eberly_contact_point(&a, &b, axis, sigma);
            assert!(close(p, vertex, 1e-5), "B{j} side {side}: {p} vs {vertex}");
        }
    }
    // A literal case for the Sign(0) = 0 rule: B resting face-on on A's top
    // face has no unique vertex; the row gives the centre of B's bottom face.
    let a = obb(Vec3::ZERO, Quat::IDENTITY, Vec3::ONE);
    let b = obb(Vec3::new(0.3, 2.0, -0.2), Quat::IDENTITY, Vec3::ONE);
    let p = eberly_contact_point(&a, &b, SeedAxis::A1, 1.0);
    assert!(close(p, Vec3::new(0.3, 1.0, -0.2), 1e-6), "{p}");
}

#[test]
fn eberly_point_all_nine_edge_edge_rows() {
    for i in 0..3 {
        for j in 0..3 {
            for side in [1.0, -1.0] {
                for (ta, tb) in [(0.0, 0.0), (0.4, -0.6), (-0.7, 0.5)] {
                    let (a, b, p) = edge_case(i, j, side, ta, tb, 0.0);
                    let axis = SeedAxis::edge(i, j);
                    let sigma = seed_sigma(&a, &b, axis);
                    assert_eq!(sigma, side, "A{i}xB{j}");
                    let got = eberly_contact_point(&a, &b, axis, sigma);
                    assert!(close(got, p, 1e-5), "A{i}xB{j} side {side} t ({ta}, {tb}): {got} vs {p}");
                }
            }
        }
    }
    // Exactly parallel edges have no unique point; the row must still give
    // a finite point (A's edge midpoint) rather than dividing by zero.
    let a = obb(Vec3::ZERO, Quat::IDENTITY, Vec3::ONE);
    let b = obb(Vec3::new(2.0, 2.0, 0.5), Quat::IDENTITY, Vec3::ONE);
    let p = eberly_contact_point(&a, &b, SeedAxis::A2xB2, 1.0);
    assert!(p.is_finite(), "{p}");
}

/// `sat_query_within` (the narrow phase's query, which stops after the face
/// axes of a pair apart by more than the margin) against the full query on
/// random pairs, near and far, at margins from 0 to 0.5 m: `None` exactly
/// when the full query's best separation exceeds the margin by a face
/// axis, and otherwise the same answer bit for bit (so the manifolds, and
/// the simulation, are unchanged). The far pairs take the early exit
/// (measured: most of them), so both paths are exercised.
#[test]
fn the_query_within_a_margin_is_the_full_query_or_a_separation_beyond_it() {
    let bits = |x: &AxisSeparation| (x.axis, x.separation.to_bits(), x.normal.to_array().map(f32::to_bits));
    let mut rng = Rng::new(0x5eed_b0c5_0007);
    let (mut early, mut full) = (0usize, 0usize);
    for k in 0..100_000 {
        let a = random_obb(&mut rng, Vec3::ZERO);
        let reach = if k % 2 == 0 { 1.0 } else { 12.0 };
        let c = rng.unit_vector() * rng.range(0.0, reach) as f32;
        let b = random_obb(&mut rng, c);
        let margin = [0.0, 0.02, 0.5][k % 3];
        let q = sat_query(&a, &b);
        match sat_query_within(&a, &b, margin) {
            None => {
                early += 1;
                assert!(
                    q.face_a.separation > margin || q.face_b.separation > margin,
                    "pair {k}: no face axis beyond {margin}: {q:?}"
                );
                assert!(q.best().separation > margin, "pair {k}: best within the margin: {q:?}");
            }
            Some(w) => {
                full += 1;
                assert!(q.face_a.separation <= margin && q.face_b.separation <= margin, "pair {k}: {q:?}");
                assert_eq!(bits(&w.face_a), bits(&q.face_a), "pair {k}");
                assert_eq!(bits(&w.face_b), bits(&q.face_b), "pair {k}");
                assert_eq!(w.edge.as_ref().map(bits), q.edge.as_ref().map(bits), "pair {k}");
            }
        }
    }
    eprintln!("early exits {early}, full queries {full}");
    assert!(early > 20_000 && full > 20_000, "both paths: {early} early, {full} full");

    // Exact cases: unit cubes 1 m apart along x of A (face of A), then
    // along y of a B turned 45° about z (so that B's face, not A's, is
    // the best). "Beyond" is strict: at a margin equal to the separation
    // the full query runs; a NaN margin never stops it.
    let cube = |c: Vec3, q: Quat| Obb::from_cuboid(&Cuboid::new(Vec3::splat(0.5)).unwrap(), &Pose::new(c, q));
    let a = cube(Vec3::ZERO, Quat::IDENTITY);
    let b = cube(Vec3::new(2.0, 0.0, 0.0), Quat::IDENTITY);
    assert_eq!(sat_query(&a, &b).face_a.separation, 1.0);
    assert!(sat_query_within(&a, &b, 1.0).is_some());
    assert!(sat_query_within(&a, &b, f32::NAN).is_some());
    assert!(sat_query_within(&a, &b, 0.999).is_none());
    let turned = cube(Vec3::new(0.0, 3.0, 0.0), Quat::from_rotation_z(std::f32::consts::FRAC_PI_4));
    let q = sat_query(&turned, &a);
    assert!(q.face_b.separation > q.face_a.separation, "B's face is the best: {q:?}");
    let beyond_b_only = 0.5 * (q.face_a.separation + q.face_b.separation);
    assert!(q.face_a.separation <= beyond_b_only, "{q:?}");
    assert!(sat_query_within(&turned, &a, beyond_b_only).is_none(), "stops at B's faces");
}
