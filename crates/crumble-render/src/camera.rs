//! The camera: a perspective view from an eye point towards a target, its
//! matrices, projection of world points to pixels, and automatic framing.

use glam::{Mat4, Vec2, Vec3, Vec4Swizzles};

use crate::RenderError;

/// Default vertical field of view, degrees.
pub const DEFAULT_FOV_DEG: f32 = 45.0;

/// Direction from the scene's centre towards an automatically placed camera:
/// from the front (+z), a little to the right (+x) and above (+y).
pub const AUTO_VIEW_DIRECTION: Vec3 = Vec3::new(0.55, 0.42, 1.0);

/// An axis-aligned box in world space, metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    /// Smallest corner.
    pub min: Vec3,
    /// Largest corner.
    pub max: Vec3,
}

impl Bounds {
    /// The box spanning `min` to `max` (corners given in any order).
    pub fn new(a: Vec3, b: Vec3) -> Self {
        Self { min: a.min(b), max: a.max(b) }
    }

    /// The smallest box holding every point, `None` for no points.
    pub fn from_points(points: impl IntoIterator<Item = Vec3>) -> Option<Self> {
        let mut it = points.into_iter();
        let first = it.next()?;
        Some(it.fold(Self { min: first, max: first }, |b, p| Self { min: b.min.min(p), max: b.max.max(p) }))
    }

    /// This box grown to hold `other` too.
    pub fn union(self, other: Bounds) -> Bounds {
        Bounds { min: self.min.min(other.min), max: self.max.max(other.max) }
    }

    /// Centre point.
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Half the diagonal: the radius of the sphere through the corners.
    pub fn radius(&self) -> f32 {
        (self.max - self.min).length() * 0.5
    }

    /// The eight corners.
    pub fn corners(&self) -> [Vec3; 8] {
        let (a, b) = (self.min, self.max);
        [
            Vec3::new(a.x, a.y, a.z),
            Vec3::new(b.x, a.y, a.z),
            Vec3::new(a.x, b.y, a.z),
            Vec3::new(b.x, b.y, a.z),
            Vec3::new(a.x, a.y, b.z),
            Vec3::new(b.x, a.y, b.z),
            Vec3::new(a.x, b.y, b.z),
            Vec3::new(b.x, b.y, b.z),
        ]
    }

    /// Whether both corners are finite numbers.
    pub fn is_finite(&self) -> bool {
        self.min.is_finite() && self.max.is_finite()
    }
}

/// A perspective camera. World units are metres, y is up.
///
/// The projection has its far plane at infinity and maps depth in reverse
/// (1 at `near`, 0 at infinity), which keeps depth precise over the whole
/// range without a far plane to choose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Camera position.
    pub eye: Vec3,
    /// Point at the centre of the image.
    pub target: Vec3,
    /// Vertical field of view, degrees (0 to 180, exclusive).
    pub fov_y_deg: f32,
    /// Distance of the near clipping plane, metres (> 0).
    pub near: f32,
}

impl Camera {
    /// A camera at `eye` looking at `target`, with a near plane at 1 % of
    /// their distance (at least 1 mm).
    pub fn look_at(eye: Vec3, target: Vec3, fov_y_deg: f32) -> Self {
        let near = (eye.distance(target) * 0.01).max(1e-3);
        Self { eye, target, fov_y_deg, near }
    }

    /// A camera that shows all of `bounds` in an image of width / height
    /// `aspect`: [`Camera::framing_points`] of its eight corners.
    pub fn framing(bounds: &Bounds, aspect: f32, fov_y_deg: f32, direction: Vec3) -> Self {
        Self::framing_points(bounds.corners(), aspect, fov_y_deg, direction)
    }

    /// The closest camera looking along −`direction` (`direction` points
    /// from the scene towards the camera; [`AUTO_VIEW_DIRECTION`] when zero
    /// or not finite) that has every point inside an image of width /
    /// height `aspect`, with a margin of about 8 % on each side, and the
    /// points' extent centred in the image. A camera with no points looks at
    /// the origin from 5 m.
    ///
    /// With right, up and forward axes r, u, f and the eye at
    /// `e = a r + b u − d f`, a point p is inside when
    /// `|p·r − a| ≤ tx (p·f + d)` and `|p·u − b| ≤ ty (p·f + d)` (tx, ty the
    /// tangents of the half angles): each is a pair of linear inequalities,
    /// so the smallest d and the centred a, b follow in closed form.
    pub fn framing_points(
        points: impl IntoIterator<Item = Vec3>,
        aspect: f32,
        fov_y_deg: f32,
        direction: Vec3,
    ) -> Self {
        let dir = direction.try_normalize().unwrap_or(AUTO_VIEW_DIRECTION.normalize());
        let fov_y_deg = if fov_y_deg.is_finite() { fov_y_deg.clamp(1.0, 170.0) } else { DEFAULT_FOV_DEG };
        let aspect = if aspect.is_finite() && aspect > 0.0 { aspect } else { 1.0 };
        let margin = 0.84;
        let ty = (fov_y_deg.to_radians() * 0.5).tan() * margin;
        let tx = ty * aspect;
        let (r, u, f) = basis(-dir);
        // Largest of  p·r − tx p·f,  −p·r − tx p·f,  and the same for u.
        let mut m = [f32::NEG_INFINITY; 4];
        let pts: Vec<Vec3> = points.into_iter().filter(|p| p.is_finite()).collect();
        for p in &pts {
            let (pr, pu, pf) = (p.dot(r), p.dot(u), p.dot(f));
            m[0] = m[0].max(pr - tx * pf);
            m[1] = m[1].max(-pr - tx * pf);
            m[2] = m[2].max(pu - ty * pf);
            m[3] = m[3].max(-pu - ty * pf);
        }
        if pts.is_empty() {
            return Self::look_at(dir * 5.0, Vec3::ZERO, fov_y_deg);
        }
        let d = ((m[0] + m[1]) / (2.0 * tx)).max((m[2] + m[3]) / (2.0 * ty));
        if !d.is_finite() {
            return Self::look_at(dir * 5.0, Vec3::ZERO, fov_y_deg);
        }
        // Within the feasible offsets, the one that centres the image extent:
        // (max + min) of (p·axis − c) / (p·f + d) falls as c grows.
        let centre = |axis: Vec3, lo: f32, hi: f32| {
            let (mut lo, mut hi) = (lo.min(hi), hi.max(lo));
            for _ in 0..40 {
                let c = 0.5 * (lo + hi);
                let (mut min, mut max) = (f32::MAX, f32::MIN);
                for p in &pts {
                    let x = (p.dot(axis) - c) / (p.dot(f) + d).max(1e-6);
                    min = min.min(x);
                    max = max.max(x);
                }
                if min + max > 0.0 {
                    lo = c;
                } else {
                    hi = c;
                }
            }
            0.5 * (lo + hi)
        };
        let a = centre(r, m[0] - tx * d, tx * d - m[1]);
        let b = centre(u, m[2] - ty * d, ty * d - m[3]);
        let eye = r * a + u * b - f * d;
        let mean_depth = pts.iter().map(|p| p.dot(f) as f64).sum::<f64>() / pts.len() as f64;
        let distance = (mean_depth as f32 + d).max(0.1);
        Self::look_at(eye, eye + f * distance, fov_y_deg)
    }

    /// Checks that the camera can be used: finite numbers, `eye` apart from
    /// `target`, a field of view in (0, 180) degrees and a positive `near`.
    pub fn validate(&self) -> Result<(), RenderError> {
        let bad = |msg: String| Err(RenderError::InvalidCamera(msg));
        if !self.eye.is_finite() || !self.target.is_finite() {
            return bad(format!("eye {} and target {} must be finite", self.eye, self.target));
        }
        if self.eye.distance(self.target) < 1e-6 {
            return bad(format!("eye and target are the same point {}", self.eye));
        }
        if !(self.fov_y_deg > 0.0 && self.fov_y_deg < 180.0) {
            return bad(format!("field of view must be between 0 and 180 degrees, got {}", self.fov_y_deg));
        }
        if !(self.near.is_finite() && self.near > 0.0) {
            return bad(format!("near plane must be positive, got {}", self.near));
        }
        Ok(())
    }

    /// World to view space (right-handed, looking down −z).
    pub fn view(&self) -> Mat4 {
        let (_, up, _) = basis(self.target - self.eye);
        Mat4::look_at_rh(self.eye, self.target, up)
    }

    /// View to clip space for an image of width / height `aspect`
    /// (reversed depth, infinite far plane).
    pub fn projection(&self, aspect: f32) -> Mat4 {
        Mat4::perspective_infinite_reverse_rh(self.fov_y_deg.to_radians(), aspect, self.near)
    }

    /// World to clip space, exactly as the renderer uses it.
    pub fn view_projection(&self, aspect: f32) -> Mat4 {
        self.projection(aspect) * self.view()
    }

    /// Pixel position of world point `p` in a `width` × `height` image:
    /// x to the right, y down, `(0, 0)` the top-left corner of the top-left
    /// pixel (so pixel `(i, j)` covers `[i, i+1) × [j, j+1)`). `None` when
    /// the point is behind the camera or closer than the near plane.
    pub fn project(&self, p: Vec3, width: u32, height: u32) -> Option<Vec2> {
        let clip = self.view_projection(width as f32 / height as f32) * p.extend(1.0);
        if clip.w <= self.near * 0.5 || clip.z > clip.w {
            return None;
        }
        let ndc = clip.xy() / clip.w;
        Some(Vec2::new((ndc.x * 0.5 + 0.5) * width as f32, (0.5 - ndc.y * 0.5) * height as f32))
    }
}

/// Right, up and forward unit vectors of a camera looking along `forward`,
/// with +y as up unless the view is (nearly) vertical, then −z or +z.
pub(crate) fn basis(forward: Vec3) -> (Vec3, Vec3, Vec3) {
    let f = forward.try_normalize().unwrap_or(Vec3::NEG_Z);
    let world_up = if f.y.abs() > 0.999 { Vec3::new(0.0, 0.0, -f.y.signum()) } else { Vec3::Y };
    let right = f.cross(world_up).normalize();
    let up = right.cross(f);
    (right, up, f)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_target_projects_to_the_image_centre() {
        let cam = Camera::look_at(Vec3::new(3.0, 2.0, 5.0), Vec3::new(0.0, 0.5, 0.0), 45.0);
        let p = cam.project(cam.target, 640, 360).unwrap();
        assert!((p - Vec2::new(320.0, 180.0)).length() < 1e-3, "{p}");
        let above = cam.project(cam.target + Vec3::Y * 0.1, 640, 360).unwrap();
        assert!(above.y < 180.0, "up is up: {above}");
        assert!(cam.project(cam.eye - (cam.target - cam.eye), 640, 360).is_none(), "behind the camera");
    }

    #[test]
    fn framing_keeps_every_corner_in_view() {
        let b = Bounds::new(Vec3::new(-8.6, 0.0, -0.05), Vec3::new(8.6, 2.6, 4.3));
        for aspect in [16.0 / 9.0, 1.0, 0.5] {
            let cam = Camera::framing(&b, aspect, 45.0, AUTO_VIEW_DIRECTION);
            let (mut lo, mut hi) = (Vec2::splat(f32::MAX), Vec2::splat(f32::MIN));
            cam.validate().unwrap();
            let (w, h) = ((400.0 * aspect) as u32, 400);
            for c in b.corners() {
                let p = cam.project(c, w, h).unwrap();
                assert!(p.x >= 0.0 && p.x <= w as f32 && p.y >= 0.0 && p.y <= h as f32, "{c} -> {p}");
                (lo, hi) = (lo.min(p), hi.max(p));
            }
            // Fills the image along one axis (with the 8 % margins) and is centred on both.
            let fill = ((hi.x - lo.x) / w as f32).max((hi.y - lo.y) / h as f32);
            assert!(fill > 0.8 && fill < 0.86, "fill {fill}, aspect {aspect}");
            let mid = (lo + hi) * 0.5;
            let off = (mid - Vec2::new(w as f32, h as f32) * 0.5).abs() / h as f32;
            assert!(off.x < 0.005 && off.y < 0.005, "{mid}");
        }
    }

    #[test]
    fn a_vertical_view_has_a_valid_basis() {
        let cam = Camera::look_at(Vec3::new(0.0, 10.0, 0.0), Vec3::ZERO, 45.0);
        assert!(cam.view().is_finite());
        let p = cam.project(Vec3::ZERO, 100, 100).unwrap();
        assert!((p - Vec2::new(50.0, 50.0)).length() < 1e-3);
    }

    #[test]
    fn bad_cameras_are_refused() {
        assert!(Camera::look_at(Vec3::ONE, Vec3::ONE, 45.0).validate().is_err());
        assert!(Camera::look_at(Vec3::ZERO, Vec3::ONE, 180.0).validate().is_err());
        assert!(Camera::look_at(Vec3::new(f32::NAN, 0.0, 0.0), Vec3::ONE, 45.0).validate().is_err());
    }
}
