//! A body's mass, centre of mass and inertia from its colliders, and the
//! range of them the solver simulates.
//!
//! The sums and the inverse are taken in f64 and rounded once to f32. In
//! f32, a 1 mm ball of density 1000 has principal moments near 5e-14
//! kg·m², whose product (the determinant an inverse divides by) is below
//! f32's smallest normal number: its inverse inertia was infinite and the
//! body went non-finite at its first step. f64 has room for every body of
//! the range below, and each inverse moment is then the correctly rounded
//! reciprocal.
//!
//! A dynamic body must lie within [`MIN_MASS`]…[`MAX_MASS`] and its
//! principal moments within [`MIN_INERTIA`]…[`MAX_INERTIA`]; anything
//! outside is refused when its collider is attached
//! ([`crate::WorldError::MassOutOfRange`]) rather than simulated wrongly.

use crate::math::{Mat3, Pose, Vec3};
use crate::shape::Shape;
use glam::{DMat3, DQuat, DVec3};

/// Lightest dynamic body, kg. A 0.5 mm grain of foam (density 1) weighs
/// 1.3e-10 kg; the bound leaves a factor 1e5 below it. Lighter bodies have
/// inverse masses above 1e15, where the solver's sums of inverse mass and
/// lever-arm terms lose the heavier partner's share entirely.
pub const MIN_MASS: f32 = 1e-15;
/// Heaviest dynamic body, kg. A 1 km block of density 20,000 weighs 2e13
/// kg; impulses m·v and energies m·v² of heavier bodies at the speed cap
/// come within a few orders of f32's largest number (3.4e38).
pub const MAX_MASS: f32 = 1e20;
/// Smallest principal moment of inertia, kg·m². A 0.5 mm foam grain has
/// 1.6e-18; 1e-25 keeps the inverse (1e25) and its product with a lever
/// arm's square well inside f32.
pub const MIN_INERTIA: f32 = 1e-25;
/// Largest principal moment of inertia, kg·m². A 1 km block of density
/// 20,000 has 3.3e18; 1e30 bounds angular momenta I·ω at the rotation cap.
pub const MAX_INERTIA: f32 = 1e30;

/// Why a body's mass cannot be simulated.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum MassError {
    /// The mass is outside [`MIN_MASS`]…[`MAX_MASS`] (or not finite).
    #[error("mass {mass:e} kg is outside the simulated range [{MIN_MASS:e}, {MAX_MASS:e}] kg")]
    Mass {
        /// The body's mass, kg.
        mass: f64,
    },
    /// A principal moment is outside [`MIN_INERTIA`]…[`MAX_INERTIA`].
    #[error(
        "moment of inertia {moment:e} kg·m² is outside the simulated range [{MIN_INERTIA:e}, {MAX_INERTIA:e}] kg·m²"
    )]
    Inertia {
        /// The smallest or the largest principal moment (whichever is out), kg·m².
        moment: f64,
    },
}

/// Checks that a dynamic body made of one collider of `shape` and
/// `density` could be simulated, as attaching it would: for callers that
/// create the body later (a scene's projectiles, launched mid-run) and
/// want the refusal up front.
pub fn check_shape(shape: &Shape, density: f32) -> Result<(), MassError> {
    body_mass([(shape, density, &Pose::IDENTITY)]).map(|_| ())
}

/// Mass data of a dynamic body, in its own frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct MassData {
    pub mass: f32,
    pub inv_mass: f32,
    pub local_com: Vec3,
    /// Inertia about the centre of mass.
    pub inertia: Mat3,
    pub inv_inertia: Mat3,
}

/// One collider's share: its shape, density and pose in the body frame.
pub(crate) type Part<'a> = (&'a Shape, f32, &'a Pose);

/// The mass data of a body made of `parts`; `Ok(None)` when no part has
/// mass (no colliders, or only a half-space).
pub(crate) fn body_mass<'a>(parts: impl IntoIterator<Item = Part<'a>>) -> Result<Option<MassData>, MassError> {
    // (mass, centre, inertia about its own centre in the body frame).
    let mut shares: Vec<(f64, DVec3, DMat3)> = Vec::new();
    for (shape, density, pose) in parts {
        let Some((mass, principal)) = shape.mass_and_moments(f64::from(density)) else {
            continue;
        };
        let q = pose.rotation;
        let r = DMat3::from_quat(DQuat::from_xyzw(q.x.into(), q.y.into(), q.z.into(), q.w.into()).normalize());
        shares.push((mass, pose.position.as_dvec3(), r * DMat3::from_diagonal(principal) * r.transpose()));
    }
    if shares.is_empty() {
        return Ok(None);
    }
    let mass: f64 = shares.iter().map(|s| s.0).sum();
    let com = shares.iter().map(|s| s.0 * s.1).sum::<DVec3>() / mass;
    // Parallel axis theorem: I = Σ (I_c + m_c (|d|² E − d dᵀ)), d = x_c − com.
    let mut inertia = DMat3::ZERO;
    for (m, x, i) in shares {
        let d = x - com;
        let outer = DMat3::from_cols(d * d.x, d * d.y, d * d.z);
        inertia += i + (DMat3::from_diagonal(DVec3::splat(d.length_squared())) - outer) * m;
    }
    if !(mass.is_finite() && (f64::from(MIN_MASS)..=f64::from(MAX_MASS)).contains(&mass)) {
        return Err(MassError::Mass { mass });
    }
    // The trace bounds the principal moments of a symmetric positive
    // tensor: λ_max ≤ tr I ≤ 3 λ_max, and likewise tr I⁻¹ for 1/λ_min.
    let inv_inertia = inertia.inverse();
    let trace = |m: &DMat3| m.x_axis.x + m.y_axis.y + m.z_axis.z;
    let largest = trace(&inertia);
    let smallest = 1.0 / trace(&inv_inertia);
    if !(largest.is_finite() && largest <= 3.0 * f64::from(MAX_INERTIA)) {
        return Err(MassError::Inertia { moment: largest });
    }
    if !(smallest.is_finite() && smallest >= f64::from(MIN_INERTIA) / 3.0) {
        return Err(MassError::Inertia { moment: smallest });
    }
    Ok(Some(MassData {
        mass: mass as f32,
        inv_mass: (1.0 / mass) as f32,
        local_com: com.as_vec3(),
        inertia: inertia.as_mat3(),
        inv_inertia: inv_inertia.as_mat3(),
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Quat;

    fn one(shape: &Shape, density: f32) -> Result<Option<MassData>, MassError> {
        body_mass([(shape, density, &Pose::IDENTITY)])
    }

    /// A 1 mm sand grain: the f32 determinant of its inertia underflows,
    /// the f64 inverse is the reciprocal of I = 2 m r² / 5.
    #[test]
    fn a_one_millimetre_ball_has_a_finite_inverse_inertia() {
        let r = 0.0005f32;
        let m = one(&Shape::ball(r).unwrap(), 1000.0).unwrap().unwrap();
        let r64 = f64::from(r);
        let expected = 0.4 * (1000.0 * 4.0 / 3.0 * std::f64::consts::PI * r64.powi(3)) * r64.powi(2);
        // Rounded once from f64: within one f32 ulp (6e-8 relative).
        let got = f64::from(m.inv_inertia.x_axis.x);
        assert!((got * expected - 1.0).abs() < 1.2e-7, "1/I = {got}, I = {expected}");
        assert!(m.inv_inertia.is_finite());
    }

    /// The range's corners of issue 46: 0.5 mm to 1 km, densities 1 to 20,000.
    #[test]
    fn grains_to_boulders_are_in_range() {
        for size in [0.0005f32, 1000.0] {
            for density in [1.0f32, 20_000.0] {
                let h = 0.5 * size;
                for shape in [Shape::cuboid(Vec3::splat(h)).unwrap(), Shape::ball(h).unwrap()] {
                    let m = one(&shape, density).unwrap().unwrap();
                    assert!(m.inv_mass.is_normal() && m.inv_inertia.is_finite(), "{size} m at {density}: {m:?}");
                }
            }
        }
    }

    #[test]
    fn out_of_range_masses_are_refused() {
        assert!(matches!(one(&Shape::ball(1e-20).unwrap(), 1000.0), Err(MassError::Mass { .. })));
        assert!(matches!(one(&Shape::cuboid(Vec3::splat(500.0)).unwrap(), 1e30), Err(MassError::Mass { .. })));
        // Mass in range (8e-10 kg), inertia not (5e-34 kg·m² about the rod's
        // axis): a rod 2e-12 m thick and 20 km long.
        let rod = Shape::cuboid(Vec3::new(1e-12, 1e-12, 1e4)).unwrap();
        assert!(matches!(one(&rod, 1e10), Err(MassError::Inertia { .. })), "{:?}", one(&rod, 1e10));
    }

    /// Two offset parts: the parallel axis theorem against the analytic
    /// inertia of one box twice as long.
    #[test]
    fn two_halves_weigh_as_the_whole() {
        let half = Shape::cuboid(Vec3::splat(0.5)).unwrap();
        let whole = Shape::cuboid(Vec3::new(1.0, 0.5, 0.5)).unwrap();
        let left = Pose::new(Vec3::new(-0.5, 0.0, 0.0), Quat::IDENTITY);
        let right = Pose::new(Vec3::new(0.5, 0.0, 0.0), Quat::IDENTITY);
        let two = body_mass([(&half, 3.0, &left), (&half, 3.0, &right)]).unwrap().unwrap();
        let one = one(&whole, 3.0).unwrap().unwrap();
        assert_eq!(two.mass, one.mass);
        assert!((two.local_com).length() < 1e-7);
        assert!((two.inertia - one.inertia).abs_diff_eq(Mat3::ZERO, 1e-5 * one.inertia.x_axis.x));
    }
}
