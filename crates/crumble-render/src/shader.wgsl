// crumble's one shader module: the shadow-map pass, the lit instanced pass
// and the sky behind everything. Colours are linear until the very end.

struct Globals {
    view_proj: mat4x4<f32>,
    light_view_proj: mat4x4<f32>,
    inv_view_proj: mat4x4<f32>,
    // xyz: camera position; w: 1 / fog distance (metres).
    eye: vec4<f32>,
    // xyz: unit vector towards the sun; w: one shadow-map texel, in uv.
    sun_dir: vec4<f32>,
    // rgb: sunlight; w: world size of one shadow-map texel, metres.
    sun_color: vec4<f32>,
    sky_zenith: vec4<f32>,
    // rgb: sky colour at the horizon (and the haze); w: 1 to encode sRGB here.
    sky_horizon: vec4<f32>,
    // rgb: light bounced up from the ground.
    ground_bounce: vec4<f32>,
}

@group(0) @binding(0) var<uniform> g: Globals;
// Only the lit pass binds group 1: the shadow pass writes this texture.
@group(1) @binding(0) var shadow_map: texture_depth_2d;
@group(1) @binding(1) var shadow_sampler: sampler_comparison;

struct MeshVertex {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
}

struct InstanceData {
    // xyz: centre; w: metalness.
    @location(2) position_metal: vec4<f32>,
    // Unit quaternion, body to world.
    @location(3) rotation: vec4<f32>,
    // xyz: scale of the unit mesh (half extents, radius); w: edge width, metres.
    @location(4) scale_edge: vec4<f32>,
    // rgb: linear base colour.
    @location(5) color: vec4<f32>,
}

fn rotate(q: vec4<f32>, v: vec3<f32>) -> vec3<f32> {
    let t = 2.0 * cross(q.xyz, v);
    return v + q.w * t + cross(q.xyz, t);
}

fn world_position(v: MeshVertex, i: InstanceData) -> vec3<f32> {
    return i.position_metal.xyz + rotate(i.rotation, v.position * i.scale_edge.xyz);
}

// ---- shadow map -----------------------------------------------------------

@vertex
fn vs_shadow(v: MeshVertex, i: InstanceData) -> @builtin(position) vec4<f32> {
    return g.light_view_proj * vec4<f32>(world_position(v, i), 1.0);
}

// ---- lit pass -------------------------------------------------------------

struct Varyings {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    // Position on the unit mesh, -1 to 1 per axis.
    @location(2) local: vec3<f32>,
    @location(3) @interpolate(flat) scale_edge: vec4<f32>,
    @location(4) @interpolate(flat) color_metal: vec4<f32>,
}

@vertex
fn vs_main(v: MeshVertex, i: InstanceData) -> Varyings {
    var out: Varyings;
    let world = world_position(v, i);
    out.clip = g.view_proj * vec4<f32>(world, 1.0);
    out.world = world;
    out.normal = rotate(i.rotation, v.normal);
    out.local = v.position;
    out.scale_edge = i.scale_edge;
    out.color_metal = vec4<f32>(i.color.rgb, i.position_metal.w);
    return out;
}

// Fraction of sunlight reaching `world` (1 lit, 0 in shadow): four
// hardware-filtered (2 × 2 texel) comparisons half a texel off centre, a
// smooth 3 × 3 texel footprint; offset along the normal against acne.
fn sunlight(world: vec3<f32>, n: vec3<f32>) -> f32 {
    let offset = n * (g.sun_color.w * 1.5);
    let p = g.light_view_proj * vec4<f32>(world + offset, 1.0);
    let ndc = p.xyz / p.w;
    let uv = vec2<f32>(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5);
    if (uv.x < 0.0 || uv.x > 1.0 || uv.y < 0.0 || uv.y > 1.0 || ndc.z > 1.0) {
        return 1.0;
    }
    let h = 0.5 * g.sun_dir.w;
    var lit = textureSampleCompareLevel(shadow_map, shadow_sampler, uv + vec2<f32>(-h, -h), ndc.z);
    lit += textureSampleCompareLevel(shadow_map, shadow_sampler, uv + vec2<f32>(h, -h), ndc.z);
    lit += textureSampleCompareLevel(shadow_map, shadow_sampler, uv + vec2<f32>(-h, h), ndc.z);
    lit += textureSampleCompareLevel(shadow_map, shadow_sampler, uv + vec2<f32>(h, h), ndc.z);
    return lit * 0.25;
}

fn sky(dir: vec3<f32>) -> vec3<f32> {
    let up = clamp(dir.y, 0.0, 1.0);
    return mix(g.sky_horizon.rgb, g.sky_zenith.rgb, pow(up, 0.6));
}

// Distance from the nearest box edge, metres, for a point on the unit box
// at `local` scaled by `scale`: the second smallest of the per-axis
// distances to the faces (the smallest is zero: the face the point is on).
fn edge_distance(local: vec3<f32>, scale: vec3<f32>) -> f32 {
    let d = (vec3<f32>(1.0) - abs(local)) * scale;
    let lo = min(d.x, min(d.y, d.z));
    let hi = max(d.x, max(d.y, d.z));
    return d.x + d.y + d.z - lo - hi;
}

fn encode(c: vec3<f32>) -> vec3<f32> {
    if (g.sky_horizon.w < 0.5) {
        return c;
    }
    let x = clamp(c, vec3<f32>(0.0), vec3<f32>(1.0));
    let lo = x * 12.92;
    let hi = 1.055 * pow(x, vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(hi, lo, x <= vec3<f32>(0.0031308));
}

@fragment
fn fs_main(in: Varyings) -> @location(0) vec4<f32> {
    let n = normalize(in.normal);
    let l = g.sun_dir.xyz;
    let to_eye = g.eye.xyz - in.world;
    let dist = length(to_eye);
    let v = to_eye / max(dist, 1e-6);
    var base = in.color_metal.rgb;
    let metal = in.color_metal.a;

    // Darkened box edges; derivatives are taken outside any branch.
    let edge_width = in.scale_edge.w;
    let e = edge_distance(in.local, in.scale_edge.xyz);
    // At least about a pixel wide, so far-away edges do not shimmer.
    let w = max(edge_width, fwidth(e) * 1.2);
    let edge = mix(0.55, 1.0, smoothstep(0.0, w, e));
    base *= select(1.0, edge, edge_width > 0.0);

    let ndl = max(dot(n, l), 0.0);
    var lit = 0.0;
    if (ndl > 0.0) {
        lit = sunlight(in.world, n);
    }
    let sky_light = mix(g.sky_horizon.rgb, g.sky_zenith.rgb, 0.5);
    let hemi = mix(g.ground_bounce.rgb, sky_light, n.y * 0.5 + 0.5);
    let diffuse = base * (hemi * 0.55 + g.sun_color.rgb * (ndl * lit));

    var color = diffuse;
    // Metal only (a branch taken alike by all of an instance's pixels): the
    // mirrored sky, a Fresnel rim and a sharp highlight.
    if (metal > 0.0) {
        let h = normalize(l + v);
        let spec = pow(max(dot(n, h), 0.0), 180.0) * ndl * lit * 1.6;
        let r = reflect(-v, n);
        let env = select(g.ground_bounce.rgb * 1.4, sky(r), r.y > -0.05);
        let k = 1.0 - max(dot(n, v), 0.0);
        let fresnel = 0.25 + 0.75 * (k * k) * (k * k) * k;
        let mirror = base * env * mix(0.35, 1.0, fresnel);
        color = mix(diffuse, mirror * 0.8 + diffuse * 0.35, metal) + g.sun_color.rgb * (spec * metal);
    }

    let haze = dist * g.eye.w;
    color = mix(color, g.sky_horizon.rgb, 1.0 - exp(-haze * haze));
    return vec4<f32>(encode(color), 1.0);
}

// ---- sky ------------------------------------------------------------------

struct SkyVaryings {
    @builtin(position) clip: vec4<f32>,
    @location(0) ndc: vec2<f32>,
}

@vertex
fn vs_sky(@builtin(vertex_index) index: u32) -> SkyVaryings {
    // One triangle covering the screen, at the far plane (depth 0, reversed).
    let x = f32((index << 1u) & 2u) * 2.0 - 1.0;
    let y = f32(index & 2u) * 2.0 - 1.0;
    var out: SkyVaryings;
    out.clip = vec4<f32>(x, y, 0.0, 1.0);
    out.ndc = vec2<f32>(x, y);
    return out;
}

@fragment
fn fs_sky(in: SkyVaryings) -> @location(0) vec4<f32> {
    let near = g.inv_view_proj * vec4<f32>(in.ndc, 1.0, 1.0);
    let dir = normalize(near.xyz / near.w - g.eye.xyz);
    return vec4<f32>(encode(sky(dir)), 1.0);
}
