//! The three unit meshes every instance is drawn from: a cube from −1 to 1
//! (scaled by half extents), a sphere of radius 1 and a square in the x–z
//! plane from −1 to 1. Triangles wind counter-clockwise seen from outside.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// A mesh vertex: position and unit normal.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct Vertex {
    /// Position on the unit mesh.
    pub position: [f32; 3],
    /// Outward unit normal.
    pub normal: [f32; 3],
}

/// The unit cube: 4 vertices per face (flat normals), 12 triangles.
pub fn cube() -> (Vec<Vertex>, Vec<u16>) {
    // (normal, u, v) with u × v = normal, so the corners below go round
    // counter-clockwise seen from outside.
    let faces = [
        (Vec3::X, Vec3::Y, Vec3::Z),
        (Vec3::NEG_X, Vec3::Z, Vec3::Y),
        (Vec3::Y, Vec3::Z, Vec3::X),
        (Vec3::NEG_Y, Vec3::X, Vec3::Z),
        (Vec3::Z, Vec3::X, Vec3::Y),
        (Vec3::NEG_Z, Vec3::Y, Vec3::X),
    ];
    let mut vertices = Vec::with_capacity(24);
    let mut indices = Vec::with_capacity(36);
    for (n, u, v) in faces {
        let base = vertices.len() as u16;
        for (su, sv) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            vertices.push(Vertex { position: (n + u * su + v * sv).to_array(), normal: n.to_array() });
        }
        indices.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
    }
    (vertices, indices)
}

/// A unit sphere of `slices` segments round and `stacks` from pole to pole.
pub fn sphere(slices: u16, stacks: u16) -> (Vec<Vertex>, Vec<u16>) {
    let mut vertices = Vec::new();
    for j in 0..=stacks {
        let theta = std::f32::consts::PI * j as f32 / stacks as f32;
        for i in 0..=slices {
            let phi = std::f32::consts::TAU * i as f32 / slices as f32;
            let p = Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
            vertices.push(Vertex { position: p.to_array(), normal: p.to_array() });
        }
    }
    let row = slices + 1;
    let mut indices = Vec::new();
    for j in 0..stacks {
        for i in 0..slices {
            let (a, b, c, d) = (j * row + i, (j + 1) * row + i, (j + 1) * row + i + 1, j * row + i + 1);
            for tri in [[a, b, c], [a, c, d]] {
                let [p0, p1, p2] = tri.map(|k| Vec3::from_array(vertices[k as usize].position));
                let n = (p1 - p0).cross(p2 - p0);
                if n.length_squared() < 1e-12 {
                    continue; // the degenerate triangles at the poles
                }
                if n.dot(p0 + p1 + p2) > 0.0 {
                    indices.extend(tri);
                } else {
                    indices.extend([tri[0], tri[2], tri[1]]);
                }
            }
        }
    }
    (vertices, indices)
}

/// The unit square at y = 0 facing +y.
pub fn plane() -> (Vec<Vertex>, Vec<u16>) {
    let n = [0.0, 1.0, 0.0];
    let corners = [[-1.0, 0.0, -1.0], [-1.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 0.0, -1.0]];
    (corners.map(|p| Vertex { position: p, normal: n }).to_vec(), vec![0, 1, 2, 0, 2, 3])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_outward((vertices, indices): (Vec<Vertex>, Vec<u16>)) {
        assert_eq!(indices.len() % 3, 0);
        for t in indices.chunks(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|k| vertices[k as usize]);
            let [p0, p1, p2] = [a, b, c].map(|v| Vec3::from_array(v.position));
            let face = (p1 - p0).cross(p2 - p0);
            assert!(face.length() > 0.0);
            assert!(face.dot(Vec3::from_array(a.normal)) > 0.0, "triangle {t:?} winds inwards");
        }
    }

    #[test]
    fn meshes_wind_counter_clockwise_from_outside() {
        check_outward(cube());
        check_outward(sphere(48, 24));
        check_outward(plane());
        let (v, i) = sphere(48, 24);
        assert!(v.len() < u16::MAX as usize && i.len() == 48 * 23 * 6);
    }
}
