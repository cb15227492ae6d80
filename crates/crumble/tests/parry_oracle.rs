//! parry3d as an independent oracle for the box collision code: static
//! overlap, penetration depth, normal and point of the box–box manifold,
//! and time of impact of translating boxes and of a sphere against a box.
//!
//! Every comparison runs on at least 100,000 random pairs from a fixed
//! seed, prints its counts (`cargo test --test parry_oracle -- --nocapture`)
//! and asserts that there is no disagreement outside the stated tolerance.
//! Cases that have no single right answer (exactly touching, contact
//! points of parallel faces, grazing sweeps) are skipped and counted.
//!
//! Tolerances are relative to the boxes' size where they compare lengths:
//! both libraries work in f32, whose rounding of a coordinate of magnitude
//! `s` is about `6e-8 s`, and the quantities compared (a depth, a gap) are
//! differences of such coordinates accumulated over a dozen operations, so
//! a fixed absolute tolerance would be too tight for large boxes and
//! meaningless for small ones.

mod common;

use common::Rng;
use crumble::collision::box_box::{self, FACE_ABS_TOL, FACE_REL_TOL};
use crumble::collision::sat::{sat_query, AxisKind, Obb};
use crumble::collision::toi::{obb_time_of_impact, sphere_box_time_of_impact};
use crumble::glam::DVec3;
use crumble::{Cuboid, Pose, Quat, Vec3};
use parry3d::math as pm;
use parry3d::query as pq;
use parry3d::shape as ps;

const PAIRS: usize = 100_000;

// parry 0.31 uses glam 0.33 (through glamx), crumble glam 0.30: convert
// through plain arrays.
fn pv(v: Vec3) -> pm::Vector {
    pm::Vector::from_array(v.to_array())
}
fn cv(v: pm::Vector) -> Vec3 {
    Vec3::from_array(v.to_array())
}
fn ppose(p: &Pose) -> pm::Pose {
    pm::Pose::from_parts(pv(p.position), pm::Rotation::from_array(p.rotation.to_array()))
}
fn pcuboid(c: &Cuboid) -> ps::Cuboid {
    ps::Cuboid::new(pv(c.half_extents()))
}

struct Pair {
    ca: Cuboid,
    pa: Pose,
    cb: Cuboid,
    pb: Pose,
    /// Largest half extent of the two boxes.
    size: f32,
}

impl Pair {
    fn obbs(&self) -> (Obb, Obb) {
        (Obb::from_cuboid(&self.ca, &self.pa), Obb::from_cuboid(&self.cb, &self.pb))
    }
}

fn random_cuboid(rng: &mut Rng) -> Cuboid {
    let mut h = || rng.log_range(0.05, 1.0) as f32;
    Cuboid::new(Vec3::new(h(), h(), h())).unwrap()
}

/// A random pair with B's centre on the ray from A's centre along a random
/// direction, at the distance where they touch plus `gap(min half
/// extent)`. Two in five pairs are fully random orientations (vertex–face
/// and edge–edge contacts), two in five share one axis direction (B is A
/// turned about one of A's axes: parallel edges, edge–face and face–face
/// contacts) and one in five have the same orientation (face–face).
fn random_pair(rng: &mut Rng, gap: impl Fn(&mut Rng, f32) -> f32) -> Pair {
    let ca = random_cuboid(rng);
    let cb = random_cuboid(rng);
    let qa = rng.rotation();
    let mode = rng.next_u64() % 5;
    let qb = match mode {
        0 | 1 => rng.rotation(),
        2 | 3 => {
            let k = (rng.next_u64() % 3) as usize;
            let mut axis = Vec3::ZERO;
            axis[k] = 1.0;
            (qa * Quat::from_axis_angle(axis, rng.range(0.0, std::f64::consts::TAU) as f32)).normalize()
        }
        _ => qa,
    };
    let pa = Pose::new(rng.unit_vector() * rng.range(0.0, 3.0) as f32, qa);
    let u = rng.unit_vector();
    // Bisection on the overlap verdict: along a ray from A's centre the
    // boxes overlap up to one distance (the ray leaves the convex Minkowski
    // difference once) and are apart beyond it.
    let apart = |s: f32| {
        let pb = Pose::new(pa.position + u * s, qb);
        sat_query(&Obb::from_cuboid(&ca, &pa), &Obb::from_cuboid(&cb, &pb)).is_separated()
    };
    let (mut lo, mut hi) = (0.0f32, ca.half_extents().length() + cb.half_extents().length() + 1e-3);
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        if apart(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let min_he = ca.half_extents().min_element().min(cb.half_extents().min_element());
    let s = hi + gap(rng, min_he);
    let pb = Pose::new(pa.position + u * s, qb);
    let size = ca.half_extents().max_element().max(cb.half_extents().max_element());
    Pair { ca, pa, cb, pb, size }
}

#[test]
fn static_overlap_verdict_agrees_with_parry() {
    let mut rng = Rng::new(0x0b5e_55ed_0001);
    let (mut checked, mut near, mut overlapping, mut disagree) = (0, 0, 0, 0);
    for _ in 0..PAIRS {
        let p = random_pair(&mut rng, |r, m| r.range(-0.3, 0.3) as f32 * m);
        let (oa, ob) = p.obbs();
        let sep = sat_query(&oa, &ob).best().separation;
        // Within 1e-5 m of touching the verdict is rounding: skip. (The SAT
        // separation is the exact gap or depth for a face axis and a lower
        // bound on the gap otherwise, so |sep| > 1e-5 is a clear case.)
        if sep.abs() <= 1e-5 {
            near += 1;
            continue;
        }
        checked += 1;
        let ours = sep <= 0.0;
        overlapping += ours as usize;
        let theirs =
            pq::intersection_test(&ppose(&p.pa), &pcuboid(&p.ca), &ppose(&p.pb), &pcuboid(&p.cb)).unwrap().intersecting;
        if ours != theirs {
            disagree += 1;
            if disagree <= 5 {
                eprintln!("overlap disagreement: ours {ours}, parry {theirs}, sep {sep}");
            }
        }
    }
    eprintln!(
        "static overlap: {checked} checked ({overlapping} overlapping), {near} within 1e-5 m of touching skipped, \
         {disagree} disagreements"
    );
    assert_eq!(disagree, 0);
}

// ---------------------------------------------------------------------------
// Exact referee (f64, brute force), to say who is right when we disagree
// ---------------------------------------------------------------------------

/// For each of the 15 candidate axes (skipping parallel edge pairs), the
/// gap between the boxes' corner projections on the unit axis (negative:
/// overlap) and the unit axis oriented from A toward B, in f64, from the
/// eight corners alone. The largest gap is the exact signed distance along
/// the best axis: the boxes are apart iff it is positive, and when they
/// overlap its negative is the penetration depth (the minimum translation
/// distance of two boxes is along one of these axes, the face normals of
/// their Minkowski difference).
fn exact_axes(a: &Obb, b: &Obb, da: DVec3, db: DVec3) -> Vec<(f64, DVec3)> {
    let corners = |o: &Obb, d: DVec3| o.corners().map(|c| c.as_dvec3() + d);
    let (ca, cb) = (corners(a, da), corners(b, db));
    let (aa, ba) = (a.axes.map(|x| x.as_dvec3()), b.axes.map(|x| x.as_dvec3()));
    let mut dirs: Vec<DVec3> = aa.iter().chain(ba.iter()).copied().collect();
    for x in aa {
        for y in ba {
            let l = x.cross(y);
            if l.length_squared() > 1e-6 {
                dirs.push(l.normalize());
            }
        }
    }
    dirs.into_iter()
        .map(|l| {
            let pa = ca.map(|c| c.dot(l));
            let pb = cb.map(|c| c.dot(l));
            let (amin, amax) =
                (pa.iter().copied().fold(f64::MAX, f64::min), pa.iter().copied().fold(f64::MIN, f64::max));
            let (bmin, bmax) =
                (pb.iter().copied().fold(f64::MAX, f64::min), pb.iter().copied().fold(f64::MIN, f64::max));
            if bmin - amax >= amin - bmax {
                (bmin - amax, l)
            } else {
                (amin - bmax, -l)
            }
        })
        .collect()
}

fn exact_separation(a: &Obb, b: &Obb, da: DVec3, db: DVec3) -> f64 {
    exact_axes(a, b, da, db).iter().map(|x| x.0).fold(f64::MIN, f64::max)
}

/// For a gap that is positive at 0 and convex in `t` (true of both gaps
/// used here: along each fixed axis the boxes' gap is the larger of two
/// linear functions of `t`, and the largest over axes of convex functions
/// is convex; a point's distance to a convex set along a line is convex):
/// its minimum over `[0, 1]` by ternary search, then the first zero by
/// bisection on `[0, argmin]`, all in f64. Returns the first contact (if
/// the minimum is `<= 0`) and the minimum gap.
fn exact_first_contact(gap: impl Fn(f64) -> f64) -> (Option<f64>, f64) {
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    for _ in 0..100 {
        let (m1, m2) = (lo + (hi - lo) / 3.0, hi - (hi - lo) / 3.0);
        if gap(m1) < gap(m2) {
            hi = m2;
        } else {
            lo = m1;
        }
    }
    let t_min = 0.5 * (lo + hi);
    let g_min = gap(t_min).min(gap(1.0));
    if g_min > 0.0 {
        return (None, g_min);
    }
    let t_end = if gap(t_min) <= 0.0 { t_min } else { 1.0 };
    let (mut lo, mut hi) = (0.0f64, t_end);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if gap(mid) <= 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    (Some(hi), g_min)
}

/// Which features touch, for the counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Config {
    FaceFace,
    VertexFace,
    EdgeEdge,
}

/// Depth and normal: ours against the exact referee (must agree), parry
/// against both (counted; a disagreement with parry is an error of ours
/// only when ours is also off the referee).
///
/// The normal is compared only where it is unique: the best axis must beat
/// every axis of a different direction by more than the tolerance;
/// otherwise two directions give the same depth and either is right.
#[test]
fn penetration_depth_normal_and_point_agree_with_parry() {
    let mut rng = Rng::new(0x0b5e_55ed_0002);
    // Per config: compared, disagreements with parry, of them ours right.
    let mut counts = [[0usize; 3]; 3];
    let (mut bias, mut tie, mut ours_wrong, mut parry_raw, mut parry_wrong_ours_right) = (0, 0, 0, 0, 0);
    let (mut points, mut point_disagree, mut non_unique, mut no_contact) = (0, 0, 0, 0);
    for _ in 0..PAIRS {
        // Shallow overlaps (what the solver sees): up to 5% of the smallest
        // half extent, at least 1e-4 of it.
        let p = random_pair(&mut rng, |r, m| -(r.range(1e-4, 0.05) as f32) * m);
        let (oa, ob) = p.obbs();
        let q = sat_query(&oa, &ob);
        let best = q.best();
        let m = box_box::manifold(&p.ca, &p.pa, &p.cb, &p.pb, 0.0);
        let theirs = pq::contact(&ppose(&p.pa), &pcuboid(&p.ca), &ppose(&p.pb), &pcuboid(&p.cb), 0.0).unwrap();
        let (Some(c), false) = (theirs, m.is_empty()) else {
            no_contact += 1;
            continue;
        };
        let (t_depth, t_normal) = (c.dist, cv(c.normal1));
        let tol = 1e-4 * p.size;

        // The exact answer and whether its normal is unique.
        let axes = exact_axes(&oa, &ob, DVec3::ZERO, DVec3::ZERO);
        let (x_sep, x_n) = axes.iter().copied().fold((f64::MIN, DVec3::ZERO), |b, x| if x.0 > b.0 { x } else { b });
        let runner_up = axes.iter().filter(|x| (x.1 - x_n).length() > 1e-4).map(|x| x.0).fold(f64::MIN, f64::max);
        let normal_unique = x_sep - runner_up > tol as f64;
        let (x_sep, x_n) = (x_sep as f32, x_n.as_vec3());

        // The manifold keeps a face of A over a face of B, and a face over
        // an edge, unless the other is better by FACE_REL_TOL relative plus
        // FACE_ABS_TOL (box_box's documented bias, for stable stacking); in
        // those cases its normal is not the least-overlap one by design, and
        // such pairs are counted, not compared.
        let clearly = |c: f32, i: f32| c > i + FACE_REL_TOL * i.abs() + FACE_ABS_TOL;
        let face = if clearly(q.face_b.separation, q.face_a.separation) { q.face_b } else { q.face_a };
        let chosen = match q.edge {
            Some(e) if clearly(e.separation, face.separation) => e,
            _ => face,
        };
        if chosen.axis != best.axis && (chosen.separation - best.separation).abs() > tol {
            bias += 1;
            continue;
        }
        let deepest = *m.points().iter().min_by(|x, y| x.separation.total_cmp(&y.separation)).unwrap();
        let config = match chosen.axis.kind() {
            AxisKind::Edge(..) => Config::EdgeEdge,
            k => {
                let other = if matches!(k, AxisKind::FaceA(_)) { &ob } else { &oa };
                let parallel = other.axes.iter().any(|x| x.dot(m.normal).abs() > 1.0 - 1e-6);
                if parallel {
                    Config::FaceFace
                } else {
                    Config::VertexFace
                }
            }
        };
        let ci = config as usize;
        counts[ci][0] += 1;
        if !normal_unique {
            tie += 1;
        }
        let normal_ok = |n: Vec3| !normal_unique || (n - x_n).length() <= 1e-4;
        let ours_ok = (deepest.separation - x_sep).abs() <= tol && normal_ok(m.normal);
        let parry_ok = (t_depth - x_sep).abs() <= tol && normal_ok(t_normal);
        let agree =
            (deepest.separation - t_depth).abs() <= tol && (!normal_unique || (m.normal - t_normal).length() <= 1e-4);
        if !ours_ok {
            ours_wrong += 1;
            if ours_wrong <= 5 {
                eprintln!("{config:?}: ours {} {} vs exact {x_sep} {x_n}", deepest.separation, m.normal);
            }
        }
        if !agree {
            parry_raw += 1;
            counts[ci][1] += 1;
            if ours_ok && !parry_ok {
                parry_wrong_ours_right += 1;
                counts[ci][2] += 1;
            }
            continue;
        }

        // The point, where it is unique: not face–face, and for a face axis
        // only when one vertex of the incident box is deepest by more than
        // the tolerance (otherwise an edge or face of it touches and each
        // library may pick a different end).
        let unique = normal_unique
            && match config {
                Config::FaceFace => false,
                Config::EdgeEdge => true,
                Config::VertexFace => {
                    let inc = if matches!(chosen.axis.kind(), AxisKind::FaceA(_)) { &ob } else { &oa };
                    let dir = if matches!(chosen.axis.kind(), AxisKind::FaceA(_)) { -m.normal } else { m.normal };
                    let mut d: Vec<f32> = inc.corners().iter().map(|c| c.dot(dir)).collect();
                    d.sort_by(|x, y| y.total_cmp(x));
                    d[0] - d[1] > tol
                }
            };
        if !unique {
            non_unique += 1;
            continue;
        }
        points += 1;
        let t_point = (cv(c.point1) + cv(c.point2)) * 0.5;
        if (deepest.point - t_point).length() > 1e-3 {
            point_disagree += 1;
            if point_disagree <= 5 {
                eprintln!("{config:?} point: ours {} parry {t_point}", deepest.point);
            }
        }
    }
    for (name, c) in [("face-face", counts[0]), ("vertex-face", counts[1]), ("edge-edge", counts[2])] {
        eprintln!(
            "contact {name}: {} compared, {} depth/normal differ from parry (1e-4 x size), {} of them with ours \
             exact and parry not",
            c[0], c[1], c[2]
        );
    }
    eprintln!(
        "contact: {parry_raw} differ from parry, {parry_wrong_ours_right} with ours exact and parry not; ours off \
         the exact f64 SAT: {ours_wrong}; normal not unique (depth only): {tie}; manifold face bias (not \
         compared): {bias}; points compared: {points}, point disagreements (1e-3 m): {point_disagree}, \
         non-unique points skipped: {non_unique}; no contact from one side: {no_contact}"
    );
    assert_eq!(ours_wrong, 0);
    assert_eq!(parry_raw - parry_wrong_ours_right, 0, "disagreements with parry not explained by parry's error");
    assert_eq!(point_disagree, 0);
    assert_eq!(no_contact, 0);
}

/// Tallies of a time-of-impact comparison.
#[derive(Default, Debug)]
struct TallyToi {
    hits: usize,
    misses: usize,
    worst: f32,
    /// Largest |ours − exact| over referee-checked hits that are not grazing.
    worst_exact: f64,
    grazing: usize,
    parry_raw: usize,
    parry_wrong_ours_right: usize,
    both_right: usize,
    ours_wrong: usize,
}

impl TallyToi {
    /// `ours`, `parry`: times or misses; `exact`: the referee's first
    /// contact and least gap over `[0, 1]`; `gap(t)`: the exact signed gap
    /// at `t`; `tol`: a distance.
    ///
    /// A time is right when within 1e-4 of the exact one (T = 1), or when
    /// the exact gap at it is within `tol` (a grazing sweep, whose contact
    /// time is ill-conditioned: a tiny approach speed along the normal
    /// turns a rounding-sized distance into a large time). A miss is right
    /// when the referee misses, or the sweep never overlaps by more than
    /// `tol` (grazing) or only touches within 1e-4 of T.
    fn add(
        &mut self,
        ours: Option<f32>,
        parry: Option<f32>,
        (exact, min_gap): (Option<f64>, f64),
        gap: &dyn Fn(f64) -> f64,
        tol: f64,
    ) {
        let right = |t: Option<f32>| match (t, exact) {
            (Some(t), Some(x)) => (t as f64 - x).abs() <= 1e-4 || gap(t as f64).abs() <= tol,
            (Some(t), None) => gap(t as f64).abs() <= tol,
            (None, Some(x)) => x > 1.0 - 1e-4 || min_gap > -tol,
            (None, None) => true,
        };
        let ours_ok = right(ours);
        if let (Some(t), Some(x)) = (ours, exact) {
            if min_gap < -tol {
                self.worst_exact = self.worst_exact.max((t as f64 - x).abs());
            }
        }
        if !ours_ok {
            self.ours_wrong += 1;
            if self.ours_wrong <= 5 {
                eprintln!("TOI: ours {ours:?} vs exact {exact:?} (parry {parry:?})");
            }
        }
        let agree = match (ours, parry) {
            (Some(a), Some(b)) => (a - b).abs() <= 1e-4,
            (None, None) => true,
            _ => false,
        };
        if agree {
            if let (Some(a), Some(b)) = (ours, parry) {
                self.worst = self.worst.max((a - b).abs());
            }
            if ours.is_some() {
                self.hits += 1;
            } else {
                self.misses += 1;
            }
            return;
        }
        if exact.is_none_or(|x| x > 1.0 - 1e-4) && min_gap > -tol {
            self.grazing += 1;
            return;
        }
        self.parry_raw += 1;
        match (ours_ok, right(parry)) {
            (true, false) => self.parry_wrong_ours_right += 1,
            (true, true) => self.both_right += 1,
            // Already counted in ours_wrong.
            _ => {}
        }
    }

    fn report(&self, name: &str) {
        eprintln!(
            "{name}: {} hits and {} misses agree with parry (worst |dt| of agreeing hits {:.1e}, T = 1); {} grazing \
             skipped; {} differ from parry by more than 1e-4: {} with ours exact and parry not, {} with both within \
             tolerance of the exact time; ours off the exact f64 referee: {} (worst |ours - exact| of \
             non-grazing hits {:.1e})",
            self.hits,
            self.misses,
            self.worst,
            self.grazing,
            self.parry_raw,
            self.parry_wrong_ours_right,
            self.both_right,
            self.ours_wrong,
            self.worst_exact
        );
        assert_eq!(self.ours_wrong, 0, "{name}: ours off the exact referee");
        assert_eq!(
            self.parry_raw - self.parry_wrong_ours_right - self.both_right,
            0,
            "{name}: disagreements with parry where ours is wrong"
        );
    }
}

#[test]
fn box_time_of_impact_agrees_with_parry() {
    let mut rng = Rng::new(0x0b5e_55ed_0003);
    let mut tally = TallyToi::default();
    for _ in 0..PAIRS {
        let p = random_pair(&mut rng, |r, m| r.range(0.01, 2.0) as f32 * m.max(0.2));
        let (oa, ob) = p.obbs();
        let va = rng.unit_vector() * rng.range(0.0, 1.0) as f32;
        let aim = (oa.center - ob.center) + rng.unit_vector() * (rng.range(0.0, 1.5) as f32 * p.size);
        let vb = va + aim.normalize() * rng.range(0.5, 6.0) as f32;
        let ours = obb_time_of_impact(&oa, va, &ob, vb, 1.0);
        let theirs = pq::cast_shapes(
            &ppose(&p.pa),
            pv(va),
            &pcuboid(&p.ca),
            &ppose(&p.pb),
            pv(vb),
            &pcuboid(&p.cb),
            pq::ShapeCastOptions::with_max_time_of_impact(1.0),
        )
        .unwrap();
        let (ours, theirs) = (ours.map(|h| h.time), theirs.map(|h| h.time_of_impact));
        let agree = match (ours, theirs) {
            (Some(a), Some(b)) => (a - b).abs() <= 1e-4,
            (None, None) => true,
            _ => false,
        };
        let gap = |t: f64| exact_separation(&oa, &ob, va.as_dvec3() * t, vb.as_dvec3() * t);
        // The referee is costly: run it on every disagreement and on one
        // pair in 16 of the rest.
        if agree && rng.next_u64() & 15 != 0 {
            tally.add(ours, theirs, (ours.map(f64::from), 0.0), &|_| 0.0, 0.0);
            continue;
        }
        let exact = exact_first_contact(gap);
        tally.add(ours, theirs, exact, &gap, 1e-5 * p.size as f64);
    }
    tally.report("box TOI");
}

#[test]
fn sphere_box_time_of_impact_agrees_with_parry() {
    let mut rng = Rng::new(0x0b5e_55ed_0004);
    let mut tally = TallyToi::default();
    for _ in 0..PAIRS {
        let cuboid = random_cuboid(&mut rng);
        let pose = Pose::new(rng.unit_vector() * rng.range(0.0, 3.0) as f32, rng.rotation());
        let r = rng.log_range(0.02, 1.0) as f32;
        let size = cuboid.half_extents().max_element().max(r);
        let centre =
            pose.position + rng.unit_vector() * (cuboid.half_extents().length() + r + rng.range(0.01, 2.0) as f32);
        let aim = pose.position - centre + rng.unit_vector() * (rng.range(0.0, 1.5) as f32 * size);
        let v = aim.normalize() * rng.range(0.5, 6.0) as f32;
        let ours = sphere_box_time_of_impact(centre, r, v, &cuboid, &pose, 1.0);
        let theirs = pq::cast_shapes(
            &ppose(&Pose::from_translation(centre)),
            pv(v),
            &ps::Ball::new(r),
            &ppose(&pose),
            pm::Vector::ZERO,
            &pcuboid(&cuboid),
            pq::ShapeCastOptions::with_max_time_of_impact(1.0),
        )
        .unwrap();
        // Exact gap in f64: distance from the centre to the box minus r,
        // in the box frame.
        let (c0, v0) = (pose.inverse_transform_point(centre).as_dvec3(), pose.inverse_transform_vector(v).as_dvec3());
        let h = cuboid.half_extents().as_dvec3();
        let gap = |t: f64| {
            let c = c0 + v0 * t;
            (c - c.clamp(-h, h)).length() - r as f64
        };
        let exact = exact_first_contact(gap);
        tally.add(ours.map(|h| h.time), theirs.map(|h| h.time_of_impact), exact, &gap, 1e-5 * size as f64);
    }
    tally.report("sphere-box TOI");
}
