//! glTF 2.0 binary (`.glb`) output, built with `gltf-json`: one node per
//! body with a box, sphere or plane mesh, a material per kind of body, and
//! one animation with a translation and a rotation channel per moving body.
//!
//! Bodies that break are shown by scale: a body that appears (a piece of a
//! box that broke) or disappears (a box that broke) has a stepped `scale`
//! channel, 0 while it is not in the world and 1 while it is, and its node's
//! own scale is the one at the first frame. Every other body has no scale
//! channel and no node scale, so the file of a scene where nothing breaks
//! holds no scale at all.
//!
//! Layout rules the Khronos validator checks: every buffer view starts on a
//! 4-byte boundary, `POSITION` accessors and animation inputs carry exact
//! `min`/`max` (and their times strictly increase), animation data views
//! have no `target`, quaternions are unit.

use std::collections::{BTreeMap, HashMap};

use crumble_scene::{BodyInfo, BodyKind, BodyShape};
use gltf_json as json;
use json::accessor::{ComponentType, GenericComponentType, Type};
use json::validation::{Checked::Valid, USize64};
use json::Index;
use serde_json::json as value;

use crate::record::Recording;

/// Side of the ground plane's square, metres.
pub const GROUND_SIZE: f32 = 50.0;

/// A mesh: positions, normals and triangle indices.
struct MeshData {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    indices: Vec<u16>,
}

fn box_mesh(h: [f32; 3]) -> MeshData {
    let mut m = MeshData { positions: Vec::new(), normals: Vec::new(), indices: Vec::new() };
    // For each face: normal axis k and sign s; u, v are the other two axes
    // ordered so that the winding is counter-clockwise seen from outside.
    for k in 0..3 {
        for s in [1.0f32, -1.0] {
            let (u, v) = if s > 0.0 { ((k + 1) % 3, (k + 2) % 3) } else { ((k + 2) % 3, (k + 1) % 3) };
            let base = m.positions.len() as u16;
            for (a, b) in [(-1.0f32, -1.0f32), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                let mut p = [0.0f32; 3];
                p[k] = s * h[k];
                p[u] = a * h[u];
                p[v] = b * h[v];
                let mut n = [0.0f32; 3];
                n[k] = s;
                m.positions.push(p);
                m.normals.push(n);
            }
            m.indices.extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
        }
    }
    m
}

fn sphere_mesh(r: f32) -> MeshData {
    let (stacks, slices) = (12u16, 24u16);
    let mut m = MeshData { positions: Vec::new(), normals: Vec::new(), indices: Vec::new() };
    for i in 0..=stacks {
        let theta = std::f32::consts::PI * i as f32 / stacks as f32;
        for j in 0..=slices {
            let phi = std::f32::consts::TAU * j as f32 / slices as f32;
            let n = [theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin()];
            m.positions.push([n[0] * r, n[1] * r, n[2] * r]);
            m.normals.push(n);
        }
    }
    let row = slices + 1;
    for i in 0..stacks {
        for j in 0..slices {
            let (a, b) = (i * row + j, (i + 1) * row + j);
            if i != 0 {
                m.indices.extend_from_slice(&[a, a + 1, b]);
            }
            if i != stacks - 1 {
                m.indices.extend_from_slice(&[a + 1, b + 1, b]);
            }
        }
    }
    m
}

fn plane_mesh(size: f32) -> MeshData {
    let h = size * 0.5;
    MeshData {
        positions: vec![[-h, 0.0, -h], [-h, 0.0, h], [h, 0.0, h], [h, 0.0, -h]],
        normals: vec![[0.0, 1.0, 0.0]; 4],
        indices: vec![0, 1, 2, 0, 2, 3],
    }
}

/// Builds the buffer and the JSON document side by side.
struct Builder {
    root: json::Root,
    bin: Vec<u8>,
}

impl Builder {
    fn align(&mut self) {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
    }

    /// Appends `bytes` as a new buffer view starting on a 4-byte boundary.
    fn view(&mut self, bytes: &[u8], target: Option<json::buffer::Target>) -> Index<json::buffer::View> {
        self.align();
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.root.push(json::buffer::View {
            buffer: Index::new(0),
            byte_length: USize64(bytes.len() as u64),
            byte_offset: Some(USize64(offset as u64)),
            byte_stride: None,
            name: None,
            target: target.map(Valid),
            extensions: None,
            extras: Default::default(),
        })
    }

    #[allow(clippy::too_many_arguments)]
    fn accessor(
        &mut self,
        view: Index<json::buffer::View>,
        byte_offset: usize,
        count: usize,
        component: ComponentType,
        type_: Type,
        min: Option<serde_json::Value>,
        max: Option<serde_json::Value>,
    ) -> Index<json::Accessor> {
        self.root.push(json::Accessor {
            buffer_view: Some(view),
            byte_offset: Some(USize64(byte_offset as u64)),
            count: USize64(count as u64),
            component_type: Valid(GenericComponentType(component)),
            extensions: None,
            extras: Default::default(),
            type_: Valid(type_),
            min,
            max,
            name: None,
            normalized: false,
            sparse: None,
        })
    }

    fn vec3_accessor(
        &mut self,
        data: &[[f32; 3]],
        target: Option<json::buffer::Target>,
        bounds: bool,
    ) -> Index<json::Accessor> {
        let view = self.view(&f32_bytes(data.iter().flatten()), target);
        let (min, max) = if bounds {
            let (lo, hi) = bounds3(data);
            (Some(value!(lo)), Some(value!(hi)))
        } else {
            (None, None)
        };
        self.accessor(view, 0, data.len(), ComponentType::F32, Type::Vec3, min, max)
    }

    fn mesh(&mut self, name: &str, data: &MeshData, material: Index<json::Material>) -> Index<json::Mesh> {
        use json::buffer::Target;
        let positions = self.vec3_accessor(&data.positions, Some(Target::ArrayBuffer), true);
        let normals = self.vec3_accessor(&data.normals, Some(Target::ArrayBuffer), false);
        let index_bytes: Vec<u8> = data.indices.iter().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.view(&index_bytes, Some(Target::ElementArrayBuffer));
        let indices = self.accessor(view, 0, data.indices.len(), ComponentType::U16, Type::Scalar, None, None);
        let mut attributes = BTreeMap::new();
        attributes.insert(Valid(json::mesh::Semantic::Positions), positions);
        attributes.insert(Valid(json::mesh::Semantic::Normals), normals);
        self.root.push(json::Mesh {
            extensions: None,
            extras: Default::default(),
            name: Some(name.into()),
            primitives: vec![json::mesh::Primitive {
                attributes,
                extensions: None,
                extras: Default::default(),
                indices: Some(indices),
                material: Some(material),
                mode: Valid(json::mesh::Mode::Triangles),
                targets: None,
            }],
            weights: None,
        })
    }

    fn material(&mut self, name: &str, rgba: [f32; 4], metallic: f32, roughness: f32) -> Index<json::Material> {
        let mut m = json::Material { name: Some(name.into()), ..Default::default() };
        m.pbr_metallic_roughness.base_color_factor = json::material::PbrBaseColorFactor(rgba);
        m.pbr_metallic_roughness.metallic_factor = json::material::StrengthFactor(metallic);
        m.pbr_metallic_roughness.roughness_factor = json::material::StrengthFactor(roughness);
        self.root.push(m)
    }
}

fn f32_bytes<'a>(values: impl Iterator<Item = &'a f32>) -> Vec<u8> {
    values.flat_map(|v| v.to_le_bytes()).collect()
}

fn bounds3(data: &[[f32; 3]]) -> ([f32; 3], [f32; 3]) {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in data {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

/// The scale keys, `(time, scale)` with a scale of 0 (hidden) or 1 (shown),
/// of a body that appears or disappears; `None` for any other body.
///
/// A piece of a box that broke (`BodyInfo::parent`) is shown from its
/// `spawn_time` on and a body that broke (`BodyInfo::despawn`) until it
/// broke: before its split a piece's recorded poses are its parent's (it
/// moves as a part of it) and after it the parent's poses stay at the pose
/// it broke at, so at any instant either the parent or its pieces are
/// shown, never both and never neither. The first key is at the first
/// frame, `t0`. A change after the last frame, `t1`, is keyed at `t1`: the
/// recording takes in a split up to half a step after a frame's time, so
/// the last frame's poses already show it, and the channel ends with the
/// animation. Keys at the same `f32` time are one key.
fn visibility_keys(body: &BodyInfo, t0: f32, t1: f32) -> Option<Vec<(f32, f32)>> {
    let appears = body.parent.map(|_| (body.spawn_time as f32).min(t1));
    let disappears = body.despawn.map(|(t, _)| (t as f32).min(t1));
    if appears.is_none() && disappears.is_none() {
        return None;
    }
    let shown = |t: f32| appears.is_none_or(|a| t >= a) && disappears.is_none_or(|d| t < d);
    let mut times = vec![t0];
    times.extend(appears.into_iter().chain(disappears).filter(|&t| t > t0));
    times.sort_by(f32::total_cmp);
    times.dedup();
    Some(times.into_iter().map(|t| (t, if shown(t) { 1.0 } else { 0.0 })).collect())
}

/// Appends a sampler and the channel that drives `path` of `node` with it.
fn push_channel(
    samplers: &mut Vec<json::animation::Sampler>,
    channels: &mut Vec<json::animation::Channel>,
    (input, output): (Index<json::Accessor>, Index<json::Accessor>),
    interpolation: json::animation::Interpolation,
    node: Index<json::Node>,
    path: json::animation::Property,
) {
    let sampler = Index::push(
        samplers,
        json::animation::Sampler {
            extensions: None,
            extras: Default::default(),
            input,
            interpolation: Valid(interpolation),
            output,
        },
    );
    channels.push(json::animation::Channel {
        sampler,
        target: json::animation::Target { extensions: None, extras: Default::default(), node, path: Valid(path) },
        extensions: None,
        extras: Default::default(),
    });
}

/// The recording as a complete `.glb` file.
pub fn to_glb(rec: &Recording) -> Result<Vec<u8>, String> {
    if rec.frames.is_empty() {
        return Err("no frames to write".into());
    }
    let mut b = Builder { root: json::Root::default(), bin: Vec::new() };
    b.root.asset = json::Asset {
        generator: Some(format!("crumble {}", env!("CARGO_PKG_VERSION"))),
        version: "2.0".into(),
        copyright: None,
        extensions: None,
        extras: Default::default(),
        min_version: None,
    };
    // Materials are made on first use: the validator flags unused objects.
    let mut materials: [Option<Index<json::Material>>; 3] = [None; 3];
    let mut material_for = |b: &mut Builder, kind: BodyKind| {
        let slot = kind as usize;
        *materials[slot].get_or_insert_with(|| match kind {
            BodyKind::Brick => b.material("brick", [0.62, 0.20, 0.13, 1.0], 0.0, 0.9),
            BodyKind::Ball => b.material("steel", [0.56, 0.57, 0.58, 1.0], 1.0, 0.35),
            BodyKind::Ground => b.material("ground", [0.80, 0.80, 0.80, 1.0], 0.0, 1.0),
        })
    };

    // One mesh per distinct shape: a wall has only two brick sizes.
    let mut meshes: HashMap<(u8, [u32; 3]), Index<json::Mesh>> = HashMap::new();
    let first = &rec.frames[0];
    let (t0, t1) = (first.t as f32, rec.frames[rec.frames.len() - 1].t as f32);
    let visibility: Vec<Option<Vec<(f32, f32)>>> = rec.bodies.iter().map(|b| visibility_keys(b, t0, t1)).collect();
    let mut nodes = Vec::with_capacity(rec.bodies.len());
    for (i, body) in rec.bodies.iter().enumerate() {
        let key = match body.shape {
            BodyShape::Box { half_extents: h } => (0, h.to_array().map(f32::to_bits)),
            BodyShape::Sphere { radius } => (1, [radius.to_bits(), 0, 0]),
            BodyShape::Plane { .. } => (2, [0; 3]),
        };
        let mesh = match meshes.get(&key) {
            Some(&m) => m,
            None => {
                let data = match body.shape {
                    BodyShape::Box { half_extents: h } => box_mesh(h.to_array()),
                    BodyShape::Sphere { radius } => sphere_mesh(radius),
                    BodyShape::Plane { .. } => plane_mesh(GROUND_SIZE),
                };
                let material = material_for(&mut b, body.kind());
                let m = b.mesh(&format!("mesh{}", meshes.len()), &data, material);
                meshes.insert(key, m);
                m
            }
        };
        let node = b.root.push(json::Node {
            mesh: Some(mesh),
            name: Some(body.name.clone()),
            translation: Some(first.positions[i]),
            rotation: Some(json::scene::UnitQuaternion(first.rotations[i])),
            // A viewer that does not play the animation shows the first
            // frame: a piece not split off yet is hidden there too.
            scale: visibility[i].as_ref().and_then(|k| (k[0].1 == 0.0).then_some([0.0; 3])),
            ..Default::default()
        });
        nodes.push(node);
    }
    let scene = b.root.push(json::Scene {
        extensions: None,
        extras: Default::default(),
        name: Some("crumble".into()),
        nodes: nodes.clone(),
    });
    b.root.scene = Some(scene);

    // The animation: one shared time input, then every moving body's
    // translations and rotations in one buffer view, then the scale keys of
    // the bodies that appear or disappear in another. The scale samplers
    // come last, so the first sampler's input is the frame times, from which
    // `scripts/blender_render.py` reads the fps.
    let times: Vec<f32> = rec.frames.iter().map(|f| f.t as f32).collect();
    let time_view = b.view(&f32_bytes(times.iter()), None);
    let input =
        b.accessor(time_view, 0, times.len(), ComponentType::F32, Type::Scalar, Some(value!([t0])), Some(value!([t1])));
    let moving: Vec<usize> = (0..rec.bodies.len()).filter(|&i| !rec.bodies[i].is_static).collect();
    let changing: Vec<(usize, &[(f32, f32)])> =
        visibility.iter().enumerate().filter_map(|(i, k)| Some((i, k.as_deref()?))).collect();
    if (!moving.is_empty() || !changing.is_empty()) && times.len() > 1 {
        use json::animation::{Interpolation, Property};
        let mut channels = Vec::new();
        let mut samplers = Vec::new();
        if !moving.is_empty() {
            let n = times.len();
            let mut data: Vec<u8> = Vec::with_capacity(moving.len() * n * 28);
            for &i in &moving {
                data.extend(f32_bytes(rec.frames.iter().flat_map(|f| f.positions[i].iter())));
                data.extend(f32_bytes(rec.frames.iter().flat_map(|f| f.rotations[i].iter())));
            }
            let view = b.view(&data, None);
            let mut offset = 0;
            for &i in &moving {
                let translations = b.accessor(view, offset, n, ComponentType::F32, Type::Vec3, None, None);
                offset += n * 12;
                let rotations = b.accessor(view, offset, n, ComponentType::F32, Type::Vec4, None, None);
                offset += n * 16;
                for (output, path) in [(translations, Property::Translation), (rotations, Property::Rotation)] {
                    push_channel(&mut samplers, &mut channels, (input, output), Interpolation::Linear, nodes[i], path);
                }
            }
        }
        if !changing.is_empty() {
            // Each body's key times, then its scales (uniform, 0 or 1).
            let mut data: Vec<u8> = Vec::new();
            for (_, keys) in &changing {
                data.extend(f32_bytes(keys.iter().map(|(t, _)| t)));
                data.extend(f32_bytes(keys.iter().flat_map(|(_, s)| [s, s, s])));
            }
            let view = b.view(&data, None);
            let mut offset = 0;
            for &(i, keys) in &changing {
                let n = keys.len();
                let (lo, hi) = (keys[0].0, keys[n - 1].0);
                let key_times = b.accessor(
                    view,
                    offset,
                    n,
                    ComponentType::F32,
                    Type::Scalar,
                    Some(value!([lo])),
                    Some(value!([hi])),
                );
                offset += n * 4;
                let scales = b.accessor(view, offset, n, ComponentType::F32, Type::Vec3, None, None);
                offset += n * 12;
                // STEP: the body is there or not, never half-sized between keys.
                push_channel(
                    &mut samplers,
                    &mut channels,
                    (key_times, scales),
                    Interpolation::Step,
                    nodes[i],
                    Property::Scale,
                );
            }
        }
        b.root.push(json::Animation {
            extensions: None,
            extras: Default::default(),
            channels,
            name: Some("simulation".into()),
            samplers,
        });
    }
    b.align();
    b.root.push(json::Buffer {
        byte_length: USize64(b.bin.len() as u64),
        name: None,
        uri: None,
        extensions: None,
        extras: Default::default(),
    });
    let json_bytes = b.root.to_vec().map_err(|e| e.to_string())?;
    Ok(glb_container(json_bytes, b.bin))
}

/// Wraps JSON and binary chunks in a GLB container (header, JSON chunk
/// padded with spaces, BIN chunk padded with zeros).
fn glb_container(mut json_bytes: Vec<u8>, mut bin: Vec<u8>) -> Vec<u8> {
    while !json_bytes.len().is_multiple_of(4) {
        json_bytes.push(b' ');
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json_bytes.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json_bytes.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json_bytes);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_faces_wind_outwards() {
        let m = box_mesh([1.0, 2.0, 3.0]);
        for tri in m.indices.chunks(3) {
            let [a, b, c] = [tri[0], tri[1], tri[2]].map(|i| glam_v(m.positions[i as usize]));
            let n = (b - a).cross(c - a);
            assert!(n.dot(glam_v(m.normals[tri[0] as usize])) > 0.0);
        }
    }

    #[test]
    fn sphere_normals_are_unit_and_outwards() {
        let m = sphere_mesh(0.5);
        for (p, n) in m.positions.iter().zip(&m.normals) {
            assert!((glam_v(*n).length() - 1.0).abs() < 1e-5);
            assert!((glam_v(*p) - glam_v(*n) * 0.5).length() < 1e-5);
        }
        for tri in m.indices.chunks(3) {
            let [a, b, c] = [tri[0], tri[1], tri[2]].map(|i| glam_v(m.positions[i as usize]));
            let n = (b - a).cross(c - a);
            assert!(n.dot(a + b + c) > 0.0, "inward triangle {tri:?}");
        }
    }

    fn glam_v(a: [f32; 3]) -> crumble::Vec3 {
        crumble::Vec3::from_array(a)
    }
}
