//! The orbit camera and the mouse ray.

use crumble_render::Camera;
use glam::{Mat4, Vec2, Vec3, Vec4};

/// Pitch is kept short of straight up or down so the look-at basis never
/// degenerates.
const MAX_PITCH: f32 = 1.5;

/// A camera that orbits a target: yaw and pitch around it at a distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    /// Point orbited and looked at.
    pub target: Vec3,
    /// Angle around +y, radians.
    pub yaw: f32,
    /// Angle above the horizontal, radians.
    pub pitch: f32,
    /// Eye to target, metres.
    pub distance: f32,
    /// Vertical field of view, degrees.
    pub fov_y_deg: f32,
}

impl Orbit {
    /// The orbit that reproduces `camera` (same eye, target and field of view).
    pub fn from_camera(camera: &Camera) -> Self {
        let offset = camera.eye - camera.target;
        let distance = offset.length().max(1e-3);
        let dir = offset / distance;
        Self {
            target: camera.target,
            yaw: dir.x.atan2(dir.z),
            pitch: dir.y.clamp(-1.0, 1.0).asin().clamp(-MAX_PITCH, MAX_PITCH),
            distance,
            fov_y_deg: camera.fov_y_deg,
        }
    }

    /// Unit vector from the target towards the eye.
    fn back(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        Vec3::new(sy * cp, sp, cy * cp)
    }

    /// The renderer's camera for this orbit.
    pub fn camera(&self) -> Camera {
        Camera::look_at(self.target + self.back() * self.distance, self.target, self.fov_y_deg)
    }

    /// Rotates by a mouse drag of `dx`, `dy` pixels (left-drag).
    pub fn rotate(&mut self, dx: f32, dy: f32) {
        self.yaw -= dx * 0.008;
        self.pitch = (self.pitch + dy * 0.008).clamp(-MAX_PITCH, MAX_PITCH);
    }

    /// Moves the target in the view plane by a drag of `dx`, `dy` pixels in
    /// a window `height` pixels tall, so that the scene follows the mouse.
    pub fn pan(&mut self, dx: f32, dy: f32, height: f32) {
        let back = self.back();
        let right = Vec3::Y.cross(back).try_normalize().unwrap_or(Vec3::X);
        let up = back.cross(right);
        // World metres per pixel at the target's depth.
        let scale = 2.0 * self.distance * (self.fov_y_deg.to_radians() * 0.5).tan() / height.max(1.0);
        self.target += (-right * dx + up * dy) * scale;
    }

    /// Zooms by `steps` wheel notches (positive: closer).
    pub fn zoom(&mut self, steps: f32) {
        self.distance = (self.distance * 0.88f32.powf(steps)).clamp(0.05, 1.0e4);
    }
}

/// The ray under pixel `pixel` (x right, y down, from the top-left corner)
/// of a `size` image seen by `camera`: the eye and a unit direction. `None`
/// when the numbers cannot make a ray (zero size, degenerate camera).
pub fn mouse_ray(camera: &Camera, pixel: Vec2, size: Vec2) -> Option<(Vec3, Vec3)> {
    if !(size.x > 0.0 && size.y > 0.0) || camera.validate().is_err() {
        return None;
    }
    let ndc = Vec2::new(pixel.x / size.x * 2.0 - 1.0, 1.0 - pixel.y / size.y * 2.0);
    let inverse: Mat4 = camera.view_projection(size.x / size.y).inverse();
    // Reversed depth: z = 1 is the near plane, 0.5 lies at twice its distance;
    // any point in front of the eye along the pixel gives the direction.
    let p = inverse * Vec4::new(ndc.x, ndc.y, 0.5, 1.0);
    if p.w.abs() < 1e-12 {
        return None;
    }
    let dir = (p.truncate() / p.w - camera.eye).try_normalize()?;
    Some((camera.eye, dir))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_click_at_the_centre_goes_along_the_view_direction() {
        let cam = Camera::look_at(Vec3::new(3.0, 2.0, 5.0), Vec3::new(0.0, 0.5, 0.0), 45.0);
        let forward = (cam.target - cam.eye).normalize();
        for (w, h) in [(640.0, 360.0), (1280.0, 720.0), (300.0, 500.0)] {
            let (origin, dir) = mouse_ray(&cam, Vec2::new(w / 2.0, h / 2.0), Vec2::new(w, h)).unwrap();
            assert_eq!(origin, cam.eye);
            assert!(dir.dot(forward) > 0.99999, "{dir} vs {forward}");
        }
    }

    #[test]
    fn a_click_on_a_projected_point_aims_at_that_point() {
        let cam = Camera::look_at(Vec3::new(-2.0, 4.0, 6.0), Vec3::new(1.0, 0.0, 0.0), 60.0);
        let size = Vec2::new(800.0, 600.0);
        for p in [Vec3::new(1.5, 0.3, 0.2), Vec3::new(0.0, 1.0, -1.0), Vec3::new(2.0, -0.5, 1.0)] {
            let pixel = cam.project(p, 800, 600).unwrap();
            let (origin, dir) = mouse_ray(&cam, pixel, size).unwrap();
            let want = (p - origin).normalize();
            assert!(dir.dot(want) > 0.99999, "{p}: {dir} vs {want}");
        }
        // Left of centre goes left, top goes up.
        let (_, left) = mouse_ray(&cam, Vec2::new(0.0, 300.0), size).unwrap();
        let (_, top) = mouse_ray(&cam, Vec2::new(400.0, 0.0), size).unwrap();
        let (_, centre) = mouse_ray(&cam, Vec2::new(400.0, 300.0), size).unwrap();
        let right = centre.cross(Vec3::Y);
        assert!(left.dot(right) < 0.0 && top.y > centre.y);
    }

    #[test]
    fn bad_sizes_give_no_ray() {
        let cam = Camera::look_at(Vec3::ONE, Vec3::ZERO, 45.0);
        assert!(mouse_ray(&cam, Vec2::ZERO, Vec2::ZERO).is_none());
        assert!(mouse_ray(&Camera::look_at(Vec3::ONE, Vec3::ONE, 45.0), Vec2::ONE, Vec2::ONE).is_none());
    }

    #[test]
    fn the_orbit_round_trips_a_camera() {
        let cam = Camera::look_at(Vec3::new(3.0, 2.0, 5.0), Vec3::new(0.0, 0.5, 0.0), 45.0);
        let back = Orbit::from_camera(&cam).camera();
        assert!(back.eye.distance(cam.eye) < 1e-4 && back.target == cam.target, "{back:?}");
        let mut o = Orbit::from_camera(&cam);
        o.rotate(100.0, 5000.0);
        o.zoom(3.0);
        o.pan(10.0, -4.0, 720.0);
        o.camera().validate().unwrap();
    }
}
