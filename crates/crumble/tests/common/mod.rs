//! Shared helpers for the collision tests: a seeded RNG (SplitMix64, no
//! dependencies) and random boxes; seeded random scenes and their checks
//! ([`random_scene`]).
#![allow(dead_code)]

pub mod random_scene;

use crumble::{Quat, Vec3};

/// SplitMix64 (Steele, Lea & Flood): a tiny, well-mixed 64-bit generator.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// Log-uniform in [lo, hi).
    pub fn log_range(&mut self, lo: f64, hi: f64) -> f64 {
        (lo.ln() + (hi.ln() - lo.ln()) * self.unit()).exp()
    }

    /// A uniformly distributed unit vector.
    pub fn unit_vector(&mut self) -> Vec3 {
        let z = self.range(-1.0, 1.0);
        let phi = self.range(0.0, std::f64::consts::TAU);
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32)
    }

    /// A uniformly distributed rotation (Shoemake's method).
    pub fn rotation(&mut self) -> Quat {
        let u1 = self.unit();
        let u2 = self.range(0.0, std::f64::consts::TAU);
        let u3 = self.range(0.0, std::f64::consts::TAU);
        let a = (1.0 - u1).sqrt();
        let b = u1.sqrt();
        Quat::from_xyzw((a * u2.sin()) as f32, (a * u2.cos()) as f32, (b * u3.sin()) as f32, (b * u3.cos()) as f32)
            .normalize()
    }
}

/// Approximate equality of vectors.
pub fn close(a: Vec3, b: Vec3, tol: f32) -> bool {
    (a - b).length() <= tol
}
