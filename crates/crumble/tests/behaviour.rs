//! Body and material settings against the formulas that document them:
//! rolling resistance, linear and angular damping, gravity scale, and
//! colliders offset from their body's origin. Each test says where its
//! expected number comes from, what the engine measured, and its limit
//! (about twice the measured error, or the f32 rounding where that is
//! all there is).

use crumble::glam::Mat3;
use crumble::scenes::{add_ball, add_ground};
use crumble::{BodyBuilder, BodyHandle, ColliderBuilder, Material, Pose, Quat, Vec3, World, WorldSettings};

const DT: f32 = 1.0 / 60.0;
const G: f32 = 9.81;

fn settings() -> WorldSettings {
    WorldSettings { sleep_enabled: false, ..WorldSettings::default() }
}

fn weightless() -> WorldSettings {
    WorldSettings { gravity: Vec3::ZERO, ..settings() }
}

/// Substeps per step and the substep `h` at the default settings.
fn substeps() -> (u32, f64) {
    let n = WorldSettings::default().substeps;
    (n, DT as f64 / n as f64)
}

/// A ball of radius `r` rolling along +x at `v0` without slipping (spin
/// about -z of `v0 / r`), just touching ground of material `ground`.
fn rolling_ball(r: f32, v0: f32, ground: Material, ball: Material) -> (World, BodyHandle) {
    let mut w = World::new(settings()).unwrap();
    add_ground(&mut w, 0.0, ground).unwrap();
    let b = add_ball(&mut w, r, Vec3::new(0.0, r, 0.0), Vec3::new(v0, 0.0, 0.0), ball, false).unwrap();
    w.set_angular_velocity(b, Vec3::new(0.0, 0.0, -v0 / r)).unwrap();
    (w, b)
}

/// Least-squares slope of `y` over `t`.
fn slope(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    let (mt, my) = (points.iter().map(|p| p.0).sum::<f64>() / n, points.iter().map(|p| p.1).sum::<f64>() / n);
    let cov: f64 = points.iter().map(|p| (p.0 - mt) * (p.1 - my)).sum();
    let var: f64 = points.iter().map(|p| (p.0 - mt) * (p.0 - mt)).sum();
    cov / var
}

/// Rolling resistance (`Material::rolling_resistance`, c): a ball rolling
/// on flat ground feels a torque of at most `c · N · r` against its roll
/// (`docs/pipeline.md`, "Friction at the patch centre"). Rolling without
/// slipping, `m a = F` and `I α = F r - c m g r` (signs along the roll)
/// with `a = α r` and `I = 2/5 m r²` give a deceleration of
/// `c g / (1 + 2/5) = 5/7 c g`, whatever the radius and density (as
/// `Material::rolling_resistance` documents). With c = 0.05: 0.35036 m/s².
/// The speed is fitted from 0.25 s to 1.25 s.
///
/// The ball rolls about its contact point, which lies inside it by about
/// half the contact's penetration: v / (ω r) = ρ below 1 (limit: within 2%
/// of 1). Rolling on the radius ρ r with the resisting torque still
/// `c N r`, the same equations give `c g / ρ / (1 + 2/5ρ²)`, above 5/7 c g
/// (0.28% at ρ = 0.9935). Limit: from 0.2% below 5/7 c g to 0.2% above
/// that, with ρ the smallest measured. Measured: 0.35107 m/s² (r 0.1 m,
/// steel, ρ 0.9932–0.9937: 0.20% above 5/7 c g) and 0.35070 m/s² (r 0.25 m,
/// 1000 kg/m³), 0.10% above. Without rolling resistance the same ball, once its
/// first steps have matched its spin to that radius, keeps its speed:
/// measured 1.1e-6 m/s change over the second (f32 at 2 m/s is 2.4e-7 m/s
/// apart; limit 3e-6 m/s).
#[test]
fn a_rolling_ball_slows_at_five_sevenths_c_g() {
    let c = 0.05f32;
    let expected = 5.0 / 7.0 * (c * G) as f64;
    let ground = Material::new(2000.0, 0.6, 0.0).with_rolling_resistance(c);
    for (r, density) in [(0.1f32, 7800.0), (0.25, 1000.0)] {
        let (mut w, b) = rolling_ball(r, 2.0, ground, Material::new(density, 0.6, 0.0));
        let (mut speeds, mut ratio) = (Vec::new(), (f32::INFINITY, 0.0f32));
        for step in 1..=75 {
            w.step(DT).unwrap();
            if step >= 15 {
                let body = w.body(b).unwrap();
                let (v, spin) = (body.linear_velocity().x, body.angular_velocity().z);
                speeds.push((step as f64 * DT as f64, v as f64));
                let rolling = v / (-spin * r);
                ratio = (ratio.0.min(rolling), ratio.1.max(rolling));
            }
        }
        let decel = -slope(&speeds);
        eprintln!(
            "rolling, r {r} m, {density} kg/m3: deceleration {decel:.5} m/s2 (5/7 c g = {expected:.5}), \
             v / (w r) {:.5} to {:.5}",
            ratio.0, ratio.1
        );
        let rho = ratio.0 as f64;
        let inner = (c * G) as f64 / rho / (1.0 + 0.4 / (rho * rho));
        assert!(
            decel > expected * 0.998 && decel < inner.max(expected) * 1.002,
            "deceleration {decel} m/s², expected {expected} to {inner}"
        );
        assert!(ratio.0 > 0.98 && ratio.1 < 1.02, "not rolling: v / (ω r) from {} to {}", ratio.0, ratio.1);
    }
    // Without rolling resistance the same ball keeps its speed.
    let (mut w, b) = rolling_ball(0.1, 2.0, Material::new(2000.0, 0.6, 0.0), Material::new(7800.0, 0.6, 0.0));
    for _ in 0..15 {
        w.step(DT).unwrap();
    }
    let v0 = w.body(b).unwrap().linear_velocity().x;
    for _ in 0..60 {
        w.step(DT).unwrap();
    }
    let v = w.body(b).unwrap().linear_velocity().x;
    eprintln!("rolling without resistance: {v0:.7} m/s at 0.25 s, {v:.7} m/s at 1.25 s");
    assert!((v - v0).abs() < 3e-6, "speed {v0} m/s, then {v} m/s");
}

/// A rolling ball comes to rest where the constant deceleration a = 5/7 c g
/// puts it: after `v0 / a` and `v0² / (2 a)`. With c = 0.1 and v0 = 1.5
/// m/s: 2.1407 s and 1.6055 m. Measured: speed ≤ 1 mm/s first at the end
/// of 2.1500 s (steps are 1/60 s: 0.0093 s late, limit 0.02 s) at 1.6003
/// m (0.32% short; limit 0.7%), and at rest at 4 s (5e-21 m/s; limit
/// 1e-6 m/s, as twice nothing is no limit).
#[test]
fn a_rolling_ball_stops_where_the_deceleration_says() {
    let (c, v0, r) = (0.1f32, 1.5f32, 0.1f32);
    let a = 5.0 / 7.0 * c * G;
    let (t_stop, x_stop) = (v0 / a, v0 * v0 / (2.0 * a));
    let ground = Material::new(2000.0, 0.6, 0.0).with_rolling_resistance(c);
    let (mut w, b) = rolling_ball(r, v0, ground, Material::new(7800.0, 0.6, 0.0));
    let mut stopped_at = None;
    for step in 1..=240 {
        w.step(DT).unwrap();
        if stopped_at.is_none() && w.body(b).unwrap().linear_velocity().x <= 1e-3 {
            stopped_at = Some(step as f32 * DT);
        }
    }
    let body = w.body(b).unwrap();
    let (t, x) = (stopped_at.expect("the ball never stopped"), body.position().x);
    let (v, spin) = (body.linear_velocity().length(), body.angular_velocity().length());
    eprintln!(
        "rolling ball stopped after {t:.4} s (v0/a = {t_stop:.4}) at x = {x:.5} m (v0^2/2a = {x_stop:.5}); \
         at 4 s: {v:.2e} m/s, {spin:.2e} rad/s"
    );
    assert!((t - t_stop).abs() < 0.02, "stopped after {t} s, expected {t_stop}");
    assert!((x - x_stop).abs() < 0.007 * x_stop, "stopped at {x} m, expected {x_stop}");
    assert!(v < 1e-6 && spin * r < 1e-6, "moving on: {v} m/s, {spin} rad/s");
}

/// Linear and angular damping (`BodyBuilder::linear_damping`: `v ← v /
/// (1 + h c)` each substep of h; angular alike): after n substeps from v0,
/// with no gravity, `v = v0 (1 + h c)^-n`, and the position is the sum of
/// the substeps' `h v`. That is the implicit Euler step of `v' = -c v`,
/// whose exact `v0 e^(-c t)` it approaches as h → 0; the ratio of the two
/// is `1 + c² h t / 2` to first order.
///
/// Over 1 s (360 substeps), c = 2/s linear and 3/s angular, measured
/// against the step's formula: v within 1.7e-5 relative, ω within 3.7e-6,
/// x within 7.7e-6 m. f32 rounds the factor `1 / (1 + h c)` the same way
/// every substep (v's error is 0.4 ulp a substep, always the same sign),
/// so the limit is one ulp (2⁻²³ relative) a substep: 4.3e-5 over 360,
/// and for x that times its 1.3 m travel plus half an ulp of x (7.7e-8 m
/// near 1 m) a substep, 8.4e-5 m.
/// Against e^(-c t): 0.832% and 1.876% above, the first-order terms being
/// 0.833% and 1.875%: off them by 0.12% and 0.04% of themselves (the next
/// order, -c³h²t/3, is -0.13% and -0.08% of them, plus f32 rounding);
/// limit 0.3% of them.
#[test]
fn damping_decays_as_its_documented_step() {
    let (c_lin, c_ang) = (2.0f64, 3.0f64);
    let (v0, w0) = (3.0f64, 5.0f64);
    let mut w = World::new(weightless()).unwrap();
    let body = w
        .insert_body(
            BodyBuilder::dynamic()
                .linear_velocity(Vec3::new(v0 as f32, 0.0, 0.0))
                .angular_velocity(Vec3::new(0.0, w0 as f32, 0.0))
                .linear_damping(c_lin as f32)
                .angular_damping(c_ang as f32),
        )
        .unwrap();
    // A ball: its inertia is isotropic, so the gyroscopic step leaves ω alone.
    w.insert_collider(ColliderBuilder::ball(0.2).unwrap(), body).unwrap();
    let (per_step, h) = substeps();
    let (mut x, mut n) = (0.0f64, 0i32);
    let (mut err_v, mut err_w, mut err_x) = (0.0f64, 0.0f64, 0.0f64);
    for _ in 0..60 {
        w.step(DT).unwrap();
        for _ in 0..per_step {
            n += 1;
            x += h * v0 * (1.0 + h * c_lin).powi(-n);
        }
        let b = w.body(body).unwrap();
        err_v = err_v.max((b.linear_velocity().x as f64 / (v0 * (1.0 + h * c_lin).powi(-n)) - 1.0).abs());
        err_w = err_w.max((b.angular_velocity().y as f64 / (w0 * (1.0 + h * c_ang).powi(-n)) - 1.0).abs());
        err_x = err_x.max((b.position().x as f64 - x).abs());
    }
    let b = w.body(body).unwrap();
    let t = 1.0f64;
    let above_lin = b.linear_velocity().x as f64 / (v0 * (-c_lin * t).exp()) - 1.0;
    let above_ang = b.angular_velocity().y as f64 / (w0 * (-c_ang * t).exp()) - 1.0;
    let (first_lin, first_ang) = (c_lin * c_lin * h * t / 2.0, c_ang * c_ang * h * t / 2.0);
    eprintln!(
        "damping, against the step's formula: v {err_v:.2e} relative, w {err_w:.2e}, x {err_x:.2e} m; against \
         e^-ct after 1 s: v {:.3}% above (c2ht/2 {:.3}%), w {:.3}% above ({:.3}%)",
        above_lin * 100.0,
        first_lin * 100.0,
        above_ang * 100.0,
        first_ang * 100.0
    );
    let ulps = n as f64 * f64::from(f32::EPSILON);
    assert!(err_v < ulps, "v off the step's formula by {err_v} (relative; limit {ulps})");
    assert!(err_w < ulps, "ω off the step's formula by {err_w} (relative; limit {ulps})");
    let limit_x = ulps * x + n as f64 * 0.5 * f64::from(f32::EPSILON) * x.max(1.0);
    assert!(err_x < limit_x, "x off the sum of the steps by {err_x} m (limit {limit_x} m)");
    assert!((above_lin - first_lin).abs() < 0.003 * first_lin, "linear: {above_lin} above e^-ct, not {first_lin}");
    assert!((above_ang - first_ang).abs() < 0.003 * first_ang, "angular: {above_ang} above e^-ct, not {first_ang}");
    // Nothing else moved.
    assert!(b.position().y == 0.0 && b.position().z == 0.0, "{:?}", b.position());
}

/// Gravity scale (`BodyBuilder::gravity_scale`, k): free fall at k g. The
/// integrator is semi-implicit Euler per substep (`tests/dynamics.rs`), so
/// after n substeps of h from rest `v = -k g n h` and `y = y0 - k g h²
/// n(n+1)/2`: the exact `y0 - k g t²/2` less `k g h t / 2`, the method's
/// first-order error (20.4 mm at k = 1 after 1 s). Bodies of scales 0,
/// 0.5, 1, 2 and -1 fall side by side from 50 m.
///
/// Measured against the closed form, every step for 1 s: y within 1.0e-5
/// m (f32 near 50 m is 3.8e-6 m apart), v within 4.5e-5 m/s (2.3e-6 of
/// 19.6 m/s at k = 2); the difference from the exact fall is `k g h t / 2`
/// within 8.3e-6 m. Limits: each substep's `v += k g h` and `y += v h`
/// round by at most half an ulp of the result, so v's error is at most
/// the sum of half an ulp of each substep's v, and y's that of y plus v's
/// error times the time (both summed over the 360 substeps in the test:
/// 1.6e-4 m/s and 7.4e-4 m at k = 2). The difference from the exact fall
/// is the closed form at t = 1 s written otherwise (`h² n(n+1)/2 = t²/2 +
/// h t/2`), so its limit is y's. A first-order error of the method (an
/// explicit Euler step's `y0 − k g h² n(n−1)/2`) would be off by `k g h t`,
/// 54 mm at k = 2.
#[test]
fn gravity_scale_scales_the_fall() {
    let mut w = World::new(settings()).unwrap();
    let scales = [0.0f64, 0.5, 1.0, 2.0, -1.0];
    let y0 = 50.0f64;
    let bodies: Vec<BodyHandle> = (0..scales.len())
        .map(|i| {
            let at = Vec3::new(i as f32 * 3.0, y0 as f32, 0.0);
            let b = w.insert_body(BodyBuilder::dynamic().position(at).gravity_scale(scales[i] as f32)).unwrap();
            w.insert_collider(ColliderBuilder::cuboid(0.5, 0.5, 0.5).unwrap(), b).unwrap();
            b
        })
        .collect();
    let (per_step, h) = substeps();
    let g = G as f64;
    let (mut err_y, mut err_v) = (0.0f64, 0.0f64);
    // Half an ulp of `x` as an f32, summed over the substeps for each scale.
    let half_ulp = |x: f64| {
        let x = (x as f32).abs();
        0.5 * f64::from(x.next_up() - x)
    };
    let (mut limit_v, mut limit_y) = (vec![0.0f64; scales.len()], vec![0.0f64; scales.len()]);
    for n in 1..=(60 * per_step) {
        let n = n as f64;
        for (i, &k) in scales.iter().enumerate() {
            limit_v[i] += half_ulp(k * g * n * h);
            limit_y[i] += half_ulp(y0 - k * g * h * h * n * (n + 1.0) / 2.0) + h * limit_v[i];
        }
    }
    let limit_v = limit_v.iter().copied().fold(0.0, f64::max);
    let limit_y = limit_y.iter().copied().fold(0.0, f64::max);
    for step in 1..=60 {
        w.step(DT).unwrap();
        let n = (step * per_step) as f64;
        for (&k, &b) in scales.iter().zip(&bodies) {
            let body = w.body(b).unwrap();
            err_y = err_y.max((body.position().y as f64 - (y0 - k * g * h * h * n * (n + 1.0) / 2.0)).abs());
            err_v = err_v.max((body.linear_velocity().y as f64 + k * g * n * h).abs());
        }
    }
    let mut err_exact = 0.0f64;
    for (&k, &b) in scales.iter().zip(&bodies) {
        let (t, y) = (1.0f64, w.body(b).unwrap().position().y as f64);
        let exact = y0 - k * g * t * t / 2.0;
        err_exact = err_exact.max(((exact - y) - k * g * h * t / 2.0).abs());
        eprintln!("gravity scale {k}: y after 1 s {y:.5} m, {:.5} m below the exact {exact:.5}", exact - y);
    }
    eprintln!(
        "gravity scale: y within {err_y:.2e} m (limit {limit_y:.2e}), v within {err_v:.2e} m/s (limit {limit_v:.2e}); \
         k g h t/2 within {err_exact:.2e} m"
    );
    assert!(err_y < limit_y, "y off the closed form by {err_y} m");
    assert!(err_v < limit_v, "v off the closed form by {err_v} m/s");
    assert!(err_exact < limit_y, "the fall differs from the exact one by k g h t/2 ± {err_exact} m");
}

/// A box's inertia about its centre: m (b² + c²) / 12 and so on, for full
/// sizes a, b, c.
fn box_inertia(m: f32, size: Vec3) -> Mat3 {
    let s = size * size;
    Mat3::from_diagonal(Vec3::new(s.y + s.z, s.x + s.z, s.x + s.y) * (m / 12.0))
}

/// Parallel axis theorem: inertia `i` about a part's own centre, taken
/// about a point `d` away: `i + m (|d|² E - d dᵀ)`.
fn shifted(i: Mat3, m: f32, d: Vec3) -> Mat3 {
    i + (Mat3::from_diagonal(Vec3::splat(d.length_squared())) - Mat3::from_cols(d * d.x, d * d.y, d * d.z)) * m
}

/// A body of two colliders away from its origin, of other densities: a
/// box turned 90° about z and a ball, the body itself turned and moved.
/// Its mass is the sum; its centre of mass the mass-weighted mean of the
/// parts' centres; its inertia about that centre the parts' own (box
/// m (b² + c²)/12 turned with it; ball 2/5 m r²) moved by the parallel
/// axis theorem. All computed here from those textbook formulas in f32.
/// Measured: the mass exact, the centre 2.5e-7 m off, the inertia within
/// 8e-8 of its largest entry: f32 rounding (one unit in the last place is
/// 1.2e-7 relative, 2.4e-7 m at 3 m). Limits: 5e-7 relative, 5e-7 m and
/// 5e-7, four such units.
#[test]
fn offset_colliders_give_the_parallel_axis_inertia() {
    let mut w = World::new(weightless()).unwrap();
    let origin = Pose::new(Vec3::new(1.0, 2.0, 3.0), Quat::from_rotation_y(0.3));
    let body = w.insert_body(BodyBuilder::dynamic().pose(origin)).unwrap();
    let (box_size, box_at, box_density) = (Vec3::new(0.6, 0.2, 0.3), Vec3::new(0.5, 0.1, -0.2), 2000.0);
    let box_turn = Quat::from_rotation_z(std::f32::consts::FRAC_PI_2);
    let (r, ball_at, ball_density) = (0.15f32, Vec3::new(-0.4, 0.0, 0.3), 7800.0);
    let half = box_size / 2.0;
    let cuboid = ColliderBuilder::cuboid(half.x, half.y, half.z).unwrap();
    w.insert_collider(cuboid.local_pose(Pose::new(box_at, box_turn)).density(box_density), body).unwrap();
    let ball = ColliderBuilder::ball(r).unwrap();
    w.insert_collider(ball.local_pose(Pose::new(ball_at, Quat::IDENTITY)).density(ball_density), body).unwrap();

    let m_box = box_density * box_size.x * box_size.y * box_size.z;
    let m_ball = ball_density * 4.0 / 3.0 * std::f32::consts::PI * r * r * r;
    let mass = m_box + m_ball;
    let com_local = (m_box * box_at + m_ball * ball_at) / mass;
    let turn = Mat3::from_quat(box_turn);
    let i_box = turn * box_inertia(m_box, box_size) * turn.transpose();
    let i_ball = Mat3::from_diagonal(Vec3::splat(0.4 * m_ball * r * r));
    let inertia_local = shifted(i_box, m_box, box_at - com_local) + shifted(i_ball, m_ball, ball_at - com_local);
    let basis = Mat3::from_quat(origin.rotation);
    let inertia = basis * inertia_local * basis.transpose();

    let b = w.body(body).unwrap();
    let err_mass = (b.mass() - mass).abs() / mass;
    let err_com = (b.center_of_mass() - origin.transform_point(com_local)).length();
    let largest = inertia.to_cols_array().iter().fold(0.0f32, |m, x| m.max(x.abs()));
    let err_inertia =
        (b.world_inertia() - inertia).to_cols_array().iter().fold(0.0f32, |m, x| m.max(x.abs())) / largest;
    eprintln!(
        "offset colliders: mass {} kg ({err_mass:.1e} relative), centre {:?} ({err_com:.1e} m), inertia \
         {err_inertia:.1e} of its largest entry",
        b.mass(),
        b.center_of_mass()
    );
    assert!(err_mass < 5e-7, "mass {} kg, expected {mass}", b.mass());
    assert!(err_com < 5e-7, "centre of mass {:?}", b.center_of_mass());
    assert!(err_inertia < 5e-7, "inertia\n{}\nexpected\n{inertia}", b.world_inertia());
}

/// Spun with no gravity, a body whose only collider is offset 1 m from
/// its origin turns about its centre of mass, which stays put (the body's
/// linear velocity is its centre's, `Body::linear_velocity`). After a
/// quarter turn about z the origin is where the turn about the centre
/// puts it: (1, 4, 0), from (0, 5, 0) around (1, 5, 0). Measured: the
/// centre 0 m from its start (limit 1e-6 m), the origin 5.0e-6 m from
/// (1, 4, 0) (limit 1e-5 m).
#[test]
fn an_offset_body_turns_about_its_centre_of_mass() {
    let mut w = World::new(weightless()).unwrap();
    let body = w.insert_body(BodyBuilder::dynamic().position(Vec3::new(0.0, 5.0, 0.0))).unwrap();
    let ball = ColliderBuilder::ball(0.2).unwrap().local_pose(Pose::new(Vec3::X, Quat::IDENTITY));
    w.insert_collider(ball, body).unwrap();
    // A quarter turn a second, for a second.
    w.set_angular_velocity(body, Vec3::new(0.0, 0.0, std::f32::consts::FRAC_PI_2)).unwrap();
    let com = w.body(body).unwrap().center_of_mass();
    assert_eq!(com, Vec3::new(1.0, 5.0, 0.0));
    for _ in 0..60 {
        w.step(DT).unwrap();
    }
    let b = w.body(body).unwrap();
    let want = Vec3::new(1.0, 4.0, 0.0);
    let (moved, off) = ((b.center_of_mass() - com).length(), (b.position() - want).length());
    eprintln!("offset body after a quarter turn: centre moved {moved:.1e} m, origin {off:.1e} m from {want:?}");
    assert!(moved < 1e-6, "the centre moved to {:?}", b.center_of_mass());
    assert!(off < 1e-5, "origin at {:?}, expected {want:?}", b.position());
}

/// A body of a cube foot (0.2 m, on the ground) and an arm lying on it (a
/// 0.6 × 0.1 × 0.2 m box, 8,000 kg/m³: 96 kg against the foot's 8 kg),
/// both colliders offset from the body's origin. Where the arm puts the
/// centre of mass over the foot (x = 0.0669 m, inside its ±0.1 m) the body
/// stands: measured 1.0e-6 m moved and 0° turned in 3 s (limits: the
/// default `linear_slop`, 1e-5 m, the overlap split impulse leaves alone,
/// and 1e-4°). Where it puts it past the foot's edge (x = 0.2215 m) the body
/// tips over towards the arm until the arm's lower end (0.44 m out from
/// the edge, 0.2 m up) meets the ground: a turn of atan(0.2 / 0.44) =
/// 24.444° about -z. Measured 0.00075° short (limit 0.002°; a millimetre
/// of penetration at the arm's end would tilt it by 0.13°).
#[test]
fn an_offset_centre_of_mass_stands_over_its_foot_and_tips_past_it() {
    let run = |arm_x: f32| -> (f32, f32, f32) {
        let mut w = World::new(settings()).unwrap();
        let m = Material::new(1000.0, 0.8, 0.0);
        add_ground(&mut w, 0.0, m).unwrap();
        let body = w.insert_body(BodyBuilder::dynamic().position(Vec3::new(0.0, 0.3, 0.0))).unwrap();
        let foot = ColliderBuilder::cuboid(0.1, 0.1, 0.1).unwrap().material(m);
        w.insert_collider(foot.local_pose(Pose::new(Vec3::new(0.0, -0.2, 0.0), Quat::IDENTITY)), body).unwrap();
        let arm = ColliderBuilder::cuboid(0.3, 0.05, 0.1).unwrap().material(Material { density: 8000.0, ..m });
        w.insert_collider(arm.local_pose(Pose::new(Vec3::new(arm_x, -0.05, 0.0), Quat::IDENTITY)), body).unwrap();
        let com_x = w.body(body).unwrap().center_of_mass().x;
        let start = w.body(body).unwrap().pose();
        for _ in 0..180 {
            w.step(DT).unwrap();
        }
        let p = w.body(body).unwrap().pose();
        let (axis, angle) = (p.rotation * start.rotation.inverse()).to_axis_angle();
        let turn = axis.z * angle.to_degrees();
        let moved = (p.position - start.position).length();
        eprintln!(
            "arm at x = {arm_x}: centre x {com_x:.7} m; in 3 s moved {:.3e} mm, turned {turn:.6} deg about z",
            moved * 1e3
        );
        (com_x, moved, turn)
    };
    let (com_x, moved, turn) = run(0.0725);
    assert!((com_x - 96.0 * 0.0725 / 104.0).abs() < 1e-6, "centre of mass x {com_x}");
    let slop = WorldSettings::default().linear_slop;
    assert!(moved < slop && turn.abs() < 1e-4, "stands: moved {moved} m, turned {turn}°");
    let (com_x, _, turn) = run(0.24);
    assert!((com_x - 96.0 * 0.24 / 104.0).abs() < 1e-6, "centre of mass x {com_x}");
    let resting = -(0.2f32.atan2(0.44)).to_degrees();
    eprintln!("tipped {:.6} deg from the resting angle", turn - resting);
    assert!((turn - resting).abs() < 0.002, "tipped onto the arm's end: turned {turn}°, expected {resting}°");
}
