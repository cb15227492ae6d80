"""Render a crumble `.glb` animation in Blender, without opening its window.

    blender -b -P scripts/blender_render.py -- wall.glb out.mp4
    blender -b -P scripts/blender_render.py -- wall.glb out.png --frame 20
    blender -b -P scripts/blender_render.py -- --help

The script imports the file, gives bricks, balls and the ground their own
materials, adds a ground plane when the file has none, a sun with shadows
and a camera framing everything the animation touches (3/4 view of the
wall's front, the side the projectile comes from), then renders a still
(`.png`) or an H.264 video (`.mp4`, through Blender's FFmpeg output).

Bricks that break are in the file too: a broken brick and its pieces are
each an object, shown only while it is in the simulation by a stepped
scale channel (a piece at scale 0 until it breaks off, then 1; the brick
1 until it breaks, then 0). Pieces are bricks here, and a body at scale 0
counts for nothing: not in the framing, the ground's height or the
choice of the still frame.

Frame numbers are crumble's: frame N shows time N / fps, so the animation
runs from frame 0. The fps is read from the file's keyframe times.

The default engine is Cycles on the CPU, which works on a machine with no
display or GPU (denoised when this Blender has OpenImageDenoise; Debian's
has not, so raise --samples for a cleaner picture). Eevee needs OpenGL:
with a GPU and a display it is much the faster; with neither, Blender 3.4
falls back to a surfaceless EGL context on Mesa's software renderer, which
works but is slower than Cycles.

Written for Blender 3.4 (Debian bookworm's: `apt-get install blender
python3-numpy`, the glTF importer needs numpy) and later 3.x; uses only
`bpy`, `mathutils` and the Python standard library. Run by plain `python3`
it checks its command line and stops before needing Blender.
"""

import argparse
import json
import math
import os
import struct
import sys
import time

try:
    import bpy
    import mathutils
except ImportError:  # plain Python: only the command line can be checked
    bpy = mathutils = None

PROG = "blender -b -P scripts/blender_render.py --"
STILL_EXTENSIONS = (".png",)
VIDEO_EXTENSIONS = (".mp4",)
DEFAULT_SAMPLES = {"CYCLES": 16, "EEVEE": 32}


class UserError(Exception):
    """A problem with the command line or the input: reported in one line, exit 1."""


def fail(message, code=1):
    sys.stderr.write("blender_render.py: error: %s\n" % message)
    sys.stderr.flush()
    sys.exit(code)


# ---------------------------------------------------------------- arguments


def parse_size(text):
    parts = text.lower().split("x")
    if len(parts) != 2 or not all(p.isdigit() for p in parts):
        raise argparse.ArgumentTypeError("expected WIDTHxHEIGHT, e.g. 1280x720, got %r" % text)
    w, h = int(parts[0]), int(parts[1])
    if not (1 <= w <= 16384 and 1 <= h <= 16384):
        raise argparse.ArgumentTypeError("width and height must be between 1 and 16384, got %r" % text)
    return w, h


def parse_range(text):
    parts = text.split(":")
    try:
        if len(parts) != 2:
            raise ValueError
        a, b = int(parts[0]), int(parts[1])
    except ValueError:
        raise argparse.ArgumentTypeError("expected FIRST:LAST frame numbers, e.g. 0:60, got %r" % text)
    if a > b:
        raise argparse.ArgumentTypeError("first frame %d is after last frame %d" % (a, b))
    return a, b


def parse_engine(text):
    key = text.upper()
    if key in ("CYCLES",):
        return "CYCLES"
    if key in ("EEVEE", "BLENDER_EEVEE"):
        return "EEVEE"
    raise argparse.ArgumentTypeError("unknown engine %r: use CYCLES or EEVEE" % text)


def positive_int(text):
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError("expected a whole number, got %r" % text)
    if n < 1:
        raise argparse.ArgumentTypeError("must be at least 1, got %d" % n)
    return n


def build_parser():
    p = argparse.ArgumentParser(
        prog=PROG,
        description="Render a crumble .glb animation to an H.264 .mp4 video or a .png still.\n"
        "Frame N shows simulated time N / fps: the animation starts at frame 0.\n"
        "The default still frame is mid-break: the first at which half of the bodies\n"
        "that end up moved have moved.",
        epilog="Examples:\n"
        "  %(prog)s wall.glb wall.mp4\n"
        "  %(prog)s wall.glb wall.mp4 --frames 0:30 --size 640x360 --samples 8\n"
        "  %(prog)s wall.glb wall.png --frame 12 --samples 64\n"
        "Cycles (CPU) works anywhere; Eevee needs OpenGL and is only fast with a GPU.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("input", help="the .glb written by `crumble run SCENE --out FILE.glb`")
    p.add_argument("output", help="FILE.mp4 (video) or FILE.png (one still)")
    p.add_argument(
        "--engine",
        type=parse_engine,
        default="CYCLES",
        metavar="CYCLES|EEVEE",
        help="CYCLES (default: CPU, works headless) or EEVEE (faster, needs OpenGL)",
    )
    p.add_argument(
        "--samples",
        type=positive_int,
        metavar="N",
        help="samples per pixel (default %d for Cycles, %d for Eevee)"
        % (DEFAULT_SAMPLES["CYCLES"], DEFAULT_SAMPLES["EEVEE"]),
    )
    p.add_argument("--size", type=parse_size, default=(1280, 720), metavar="WxH", help="image size (default 1280x720)")
    p.add_argument("--frame", type=int, metavar="N", help="the frame of a .png still (default: mid-break)")
    p.add_argument(
        "--frames", type=parse_range, metavar="A:B", help="the frames of an .mp4, inclusive (default: the whole animation)"
    )
    p.add_argument("--blend", metavar="FILE.blend", help="also save the prepared scene, to tweak it by hand")
    return p


def script_argv():
    """The arguments after Blender's `--` (all of them when run by plain Python)."""
    argv = sys.argv
    if "--" in argv:
        return argv[argv.index("--") + 1 :]
    return argv[1:] if bpy is None else []


def check_args(args):
    if not os.path.isfile(args.input):
        raise UserError("input file not found: %s" % args.input)
    if not args.input.lower().endswith(".glb"):
        raise UserError("input must be a .glb file (crumble run SCENE --out FILE.glb), got %s" % args.input)
    out = args.output.lower()
    if out.endswith(STILL_EXTENSIONS):
        args.kind = "still"
        if args.frames is not None:
            raise UserError("--frames is for videos; a .png still takes --frame N")
    elif out.endswith(VIDEO_EXTENSIONS):
        args.kind = "video"
        if args.frame is not None:
            raise UserError("--frame is for stills; a video takes --frames A:B")
        w, h = args.size
        if w % 2 or h % 2:
            raise UserError("H.264 needs an even width and height, got %dx%d" % (w, h))
    else:
        raise UserError("output must end in .mp4 (video) or .png (still), got %s" % args.output)
    out_dir = os.path.dirname(os.path.abspath(args.output))
    if not os.path.isdir(out_dir):
        raise UserError("output directory does not exist: %s" % out_dir)
    if args.samples is None:
        args.samples = DEFAULT_SAMPLES[args.engine]


# ---------------------------------------------------------------- the .glb


def read_glb_json_and_bin(path):
    """The JSON chunk (parsed) and the BIN chunk (bytes or None) of a .glb."""
    with open(path, "rb") as f:
        data = f.read()
    if len(data) < 20 or data[:4] != b"glTF":
        raise UserError("%s is not a glTF binary (no 'glTF' header)" % path)
    version, total = struct.unpack_from("<II", data, 4)
    if version != 2:
        raise UserError("%s is glTF version %d; only 2 is supported" % (path, version))
    pos, doc, bin_chunk = 12, None, None
    while pos + 8 <= min(total, len(data)):
        length, kind = struct.unpack_from("<I4s", data, pos)
        chunk = data[pos + 8 : pos + 8 + length]
        if kind == b"JSON" and doc is None:
            doc = json.loads(chunk.decode("utf-8"))
        elif kind == b"BIN\0" and bin_chunk is None:
            bin_chunk = chunk
        pos += 8 + length
    if doc is None:
        raise UserError("%s has no JSON chunk" % path)
    return doc, bin_chunk


def keyframe_times(doc, bin_chunk):
    """The keyframe times of the first animation, seconds (empty if none):
    those of its sampler with the most keyframes. A pose is sampled at
    every frame, while a scale channel that shows or hides a body (a
    broken brick, its pieces) has a key or two, wherever it comes."""
    anims = doc.get("animations") or []
    if not anims or not anims[0].get("samplers") or bin_chunk is None:
        return []
    accessors = doc.get("accessors") or []
    inputs = [s.get("input") for s in anims[0]["samplers"]]
    inputs = [i for i in inputs if isinstance(i, int) and 0 <= i < len(accessors)]
    if not inputs:
        return []
    acc = accessors[max(inputs, key=lambda i: accessors[i].get("count", 0))]
    if acc.get("componentType") != 5126 or acc.get("type") != "SCALAR" or "bufferView" not in acc:
        return []
    view = doc["bufferViews"][acc["bufferView"]]
    if view.get("buffer", 0) != 0:
        return []
    start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    return list(struct.unpack_from("<%df" % acc["count"], bin_chunk, start))


def fps_from_times(times, default=30):
    """The frame rate of evenly spaced keyframes: the median step, rounded."""
    steps = sorted(b - a for a, b in zip(times, times[1:]) if b > a)
    if not steps:
        return default
    return max(1, int(round(1.0 / steps[len(steps) // 2])))


# ---------------------------------------------------------------- the scene


def reset_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    for obj in list(scene.objects):
        bpy.data.objects.remove(obj, do_unlink=True)
    return scene


def prepare_importer():
    """Blender's glTF importer needs numpy; Blender 3.4's also uses `numpy.bool`,
    which numpy 1.24 removed (Debian bookworm ships both): put the alias back."""
    try:
        import numpy
    except ImportError:
        raise UserError(
            "Blender's glTF importer needs numpy, which its Python cannot import "
            "(on Debian/Ubuntu: apt-get install python3-numpy)"
        )
    if "bool" not in numpy.__dict__:
        numpy.bool = bool


def import_glb(path):
    prepare_importer()
    before = set(bpy.data.objects)
    try:
        result = bpy.ops.import_scene.gltf(filepath=os.path.abspath(path))
    except RuntimeError as e:
        raise UserError("Blender could not import %s: %s" % (path, str(e).strip()))
    if "FINISHED" not in result:
        raise UserError("Blender could not import %s" % path)
    objects = [o for o in bpy.data.objects if o not in before and o.type == "MESH"]
    if not objects:
        raise UserError("%s holds no meshes" % path)
    return objects


def object_action(obj):
    """The object's action: the active one, else the first on its NLA tracks."""
    ad = obj.animation_data
    if ad is None:
        return None
    if ad.action is None:
        for track in ad.nla_tracks:
            for strip in track.strips:
                if strip.action is not None:
                    ad.action = strip.action
                    track.mute = True
                    return ad.action
        return None
    return ad.action


def animation_range(objects):
    lo, hi = None, None
    for obj in objects:
        action = object_action(obj)
        if action is None:
            continue
        a, b = action.frame_range
        lo = a if lo is None else min(lo, a)
        hi = b if hi is None else max(hi, b)
    if lo is None:
        return 0, 0
    return int(math.floor(lo + 1e-4)), int(math.ceil(hi - 1e-4))


def classify(obj):
    """'ground', 'ball' or 'brick'.

    crumble names its three materials after the kinds of body (`brick`,
    `steel`, `ground`); a file from elsewhere is sorted by shape: a flat quad
    is ground, a mesh whose vertices are all as far from its centre is a ball.
    """
    kinds = {"brick": "brick", "steel": "ball", "ground": "ground"}
    for slot in obj.material_slots:
        if slot.material:
            name = slot.material.name.lower().split(".")[0]
            if name in kinds:
                return kinds[name]
    verts = [v.co for v in obj.data.vertices]
    if not verts:
        return "brick"
    extent = [max(v[k] for v in verts) - min(v[k] for v in verts) for k in range(3)]
    if len(verts) <= 8 and min(extent) < 1e-6 * max(max(extent), 1e-9):
        return "ground"
    centre = [sum(v[k] for v in verts) / len(verts) for k in range(3)]
    radii = [math.dist(v, centre) for v in verts]
    if len(verts) > 24 and max(radii) - min(radii) < 0.02 * max(radii):
        return "ball"
    return "brick"


def principled(name):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes.get("Principled BSDF")
    return mat, bsdf


def brick_material():
    """Brick tones, a different one per brick (Object Info's random), mottled a little."""
    mat, bsdf = principled("crumble brick")
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    info = nodes.new("ShaderNodeObjectInfo")
    ramp = nodes.new("ShaderNodeValToRGB")
    tones = [(0.0, (0.30, 0.07, 0.04)), (0.35, (0.45, 0.12, 0.06)), (0.7, (0.52, 0.19, 0.09)), (1.0, (0.40, 0.16, 0.10))]
    elements = ramp.color_ramp.elements
    while len(elements) < len(tones):
        elements.new(0.5)
    for el, (at, rgb) in zip(elements, tones):
        el.position = at
        el.color = (rgb[0], rgb[1], rgb[2], 1.0)
    links.new(info.outputs["Random"], ramp.inputs["Fac"])
    noise = nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 40.0
    noise.inputs["Detail"].default_value = 4.0
    mottle = nodes.new("ShaderNodeMapRange")
    mottle.inputs["To Min"].default_value = 0.8
    mottle.inputs["To Max"].default_value = 1.1
    links.new(noise.outputs["Fac"], mottle.inputs["Value"])
    mix = nodes.new("ShaderNodeMixRGB")
    mix.blend_type = "MULTIPLY"
    mix.inputs["Fac"].default_value = 1.0
    links.new(ramp.outputs["Color"], mix.inputs["Color1"])
    links.new(mottle.outputs["Result"], mix.inputs["Color2"])
    links.new(mix.outputs["Color"], bsdf.inputs["Base Color"])
    bsdf.inputs["Roughness"].default_value = 0.85
    bsdf.inputs["Specular"].default_value = 0.3
    return mat


def steel_material():
    mat, bsdf = principled("crumble steel")
    bsdf.inputs["Base Color"].default_value = (0.62, 0.63, 0.65, 1.0)
    bsdf.inputs["Metallic"].default_value = 1.0
    bsdf.inputs["Roughness"].default_value = 0.22
    return mat


def ground_material():
    mat, bsdf = principled("crumble ground")
    bsdf.inputs["Base Color"].default_value = (0.55, 0.55, 0.55, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.95
    bsdf.inputs["Specular"].default_value = 0.2
    return mat


def assign(obj, mat):
    # Meshes are shared between bodies of one size: set the material on the
    # mesh, and per-brick variation comes from each object's random value.
    obj.data.materials.clear()
    obj.data.materials.append(mat)


def world_corners(obj):
    mw = obj.matrix_world
    return [mw @ mathutils.Vector(c) for c in obj.bound_box]


def present(obj):
    """Whether `obj` is in the simulation at the current frame: crumble
    hides a body that is not (a brick after it broke, a piece before it
    broke off) by scaling it to 0."""
    return min(abs(x) for x in obj.matrix_world.to_scale()) > 1e-6


def own_size(obj):
    """The longest side of `obj`'s own box, whatever its scale now."""
    corners = [mathutils.Vector(c) for c in obj.bound_box]
    return max((max(c[k] for c in corners) - min(c[k] for c in corners)) for k in range(3))


class Box:
    def __init__(self):
        self.lo = [math.inf] * 3
        self.hi = [-math.inf] * 3

    def add(self, p):
        for k in range(3):
            self.lo[k] = min(self.lo[k], p[k])
            self.hi[k] = max(self.hi[k], p[k])

    def empty(self):
        return self.lo[0] > self.hi[0]

    def centre(self):
        return [(a + b) / 2 for a, b in zip(self.lo, self.hi)]

    def size(self):
        return [b - a for a, b in zip(self.lo, self.hi)]

    def corners(self):
        return [(x, y, z) for x in (self.lo[0], self.hi[0]) for y in (self.lo[1], self.hi[1]) for z in (self.lo[2], self.hi[2])]


def survey(scene, bodies, first, last):
    """What the camera must show, and the default still frame.

    Returns the bodies' box at the first frame, the corners of every body at
    every frame (deduplicated on a fine grid), the lowest height any body
    reaches, and the still frame: the first at which half of the bodies that
    end up more than twice their size away from their start have got there
    (mid-break). Only bodies in the simulation at a frame count there
    (`present`): a piece's start is its place in its brick at the first
    frame, where the file keeps it while hidden.
    """
    start_box = Box()
    scene.frame_set(first)
    start = {}
    for obj in bodies:
        if present(obj):
            for c in world_corners(obj):
                start_box.add(c)
        start[obj.name] = (obj.matrix_world.translation.copy(), own_size(obj))
    if start_box.empty():
        return start_box, [], 0.0, first
    lowest = start_box.lo[2]
    size = max(max(start_box.size()), 1e-3)
    # A body thrown far away must not shrink the whole picture: only points
    # within two start-sizes of the start box count.
    reach = 2.0 * size
    grid = size / 200.0
    points = {}
    moved_per_frame = []
    step = max(1, (last - first) // 200)
    frames = list(range(first, last + 1, step))
    if frames[-1] != last:
        frames.append(last)
    for f in frames:
        scene.frame_set(f)
        moved = 0
        for obj in bodies:
            if (f != first and obj.animation_data is None) or not present(obj):
                continue
            for c in world_corners(obj):
                lowest = min(lowest, c[2])
                if all(start_box.lo[k] - reach <= c[k] <= start_box.hi[k] + reach for k in range(3)):
                    points.setdefault(tuple(round(c[k] / grid) for k in range(3)), c)
            p0, body_size = start[obj.name]
            if (obj.matrix_world.translation - p0).length > 2.0 * body_size:
                moved += 1
        moved_per_frame.append((f, moved))
    final = moved_per_frame[-1][1]
    still = last
    if final > 0:
        still = next(f for f, m in moved_per_frame if m * 2 >= final)
    scene.frame_set(first)
    return start_box, list(points.values()), lowest, still


def front_direction(bricks, balls):
    """Unit horizontal vector from the wall towards its front: where the ball
    comes from. Read at the current frame, from the bricks present then."""
    wall = Box()
    for o in bricks:
        if present(o):
            wall.add(o.matrix_world.translation)
    if balls and not wall.empty():
        c = wall.centre()
        b = balls[0].matrix_world.translation
        d = (b[0] - c[0], b[1] - c[1])
        n = math.hypot(*d)
        if n > 1e-6:
            return d[0] / n, d[1] / n
    # glTF's +z (crumble's facing in the examples) is Blender's -y.
    return 0.0, -1.0


def add_ground(box, height, mat):
    """A plane under everything: nothing the animation shows goes through it."""
    size = max(50.0, 20.0 * max(box.size()))
    c = box.centre()
    bpy.ops.mesh.primitive_plane_add(size=size, location=(c[0], c[1], height))
    plane = bpy.context.active_object
    plane.name = "ground (added)"
    assign(plane, mat)
    return plane


def horizontal_turn(front, degrees):
    """`front` (x, y) turned by `degrees` about the vertical."""
    t = math.radians(degrees)
    fx, fy = front
    return fx * math.cos(t) - fy * math.sin(t), fx * math.sin(t) + fy * math.cos(t)


def direction(front, azimuth_deg, elevation_deg):
    """Unit vector `azimuth_deg` round from `front` and `elevation_deg` up."""
    hx, hy = horizontal_turn(front, azimuth_deg)
    el = math.radians(elevation_deg)
    return mathutils.Vector((hx * math.cos(el), hy * math.cos(el), math.sin(el)))


def add_camera(scene, points, front, aspect, azimuth_deg=35.0, elevation_deg=30.0, lens=40.0):
    """A camera on the front side, turned 3/4, framing every point with a little air.

    The direction is fixed; the aim and the distance are solved for: the
    distance is the least at which every point is inside the (shrunk) field
    of view, and the aim moves until the points' image is centred.
    """
    back = direction(front, azimuth_deg, elevation_deg)
    data = bpy.data.cameras.new("crumble camera")
    data.lens = lens
    data.sensor_fit = "HORIZONTAL"
    cam = bpy.data.objects.new("crumble camera", data)
    scene.collection.objects.link(cam)
    rot = (-back).to_track_quat("-Z", "Y")
    cam.rotation_euler = rot.to_euler()
    right = rot @ mathutils.Vector((1.0, 0.0, 0.0))
    up = rot @ mathutils.Vector((0.0, 1.0, 0.0))
    margin = 0.9
    tan_x = margin * data.sensor_width / (2.0 * lens)
    tan_y = tan_x / aspect

    box = Box()
    for p in points:
        box.add(p)
    target = mathutils.Vector(box.centre())

    def distance(target):
        d = 0.0
        for p in points:
            v = p - target
            along = v.dot(back)
            d = max(d, along + abs(v.dot(right)) / tan_x, along + abs(v.dot(up)) / tan_y)
        return d

    for _ in range(20):
        dist = distance(target)
        eye = target + back * dist
        xs, ys = [], []
        for p in points:
            w = p - eye
            depth = max(-w.dot(back), 1e-6)
            xs.append(w.dot(right) / depth)
            ys.append(w.dot(up) / depth)
        cx, cy = (min(xs) + max(xs)) / 2.0, (min(ys) + max(ys)) / 2.0
        if abs(cx) < 1e-4 * tan_x and abs(cy) < 1e-4 * tan_y:
            break
        target = target + (right * cx + up * cy) * dist
    dist = distance(target)
    cam.location = target + back * dist
    data.clip_start = max(1e-3, dist * 0.01)
    data.clip_end = dist * 100.0
    scene.camera = cam
    return cam, dist


def add_sun(scene, front, box):
    """A sun from the front, high and to the other side from the camera, so shadows fall in view."""
    towards_sun = direction(front, -55.0, 45.0)
    data = bpy.data.lights.new("crumble sun", "SUN")
    data.energy = 4.0
    data.angle = math.radians(1.5)
    data.use_shadow = True
    if hasattr(data, "shadow_cascade_max_distance"):
        data.shadow_cascade_max_distance = max(10.0, 4.0 * max(box.size()))
        data.shadow_cascade_count = 4
    sun = bpy.data.objects.new("crumble sun", data)
    scene.collection.objects.link(sun)
    sun.rotation_euler = (-towards_sun).to_track_quat("-Z", "Y").to_euler()
    sun.location = mathutils.Vector(box.centre()) + towards_sun * 5.0
    return sun


def set_world(scene):
    world = bpy.data.worlds.new("crumble sky")
    world.use_nodes = True
    bg = world.node_tree.nodes.get("Background")
    bg.inputs["Color"].default_value = (0.62, 0.72, 0.88, 1.0)
    bg.inputs["Strength"].default_value = 0.6
    scene.world = world


def set_render(scene, args, fps):
    r = scene.render
    r.fps, r.fps_base = fps, 1.0
    r.resolution_x, r.resolution_y = args.size
    r.resolution_percentage = 100
    r.film_transparent = False
    r.use_persistent_data = True
    scene.view_settings.view_transform = "Filmic"
    scene.view_settings.look = "Medium High Contrast"
    if args.engine == "CYCLES":
        r.engine = "CYCLES"
        c = scene.cycles
        c.device = "CPU"
        c.samples = args.samples
        c.use_adaptive_sampling = True
        c.max_bounces = 4
        c.diffuse_bounces = 2
        c.glossy_bounces = 2
        c.transmission_bounces = 2
        c.caustics_reflective = False
        c.caustics_refractive = False
        c.sample_clamp_indirect = 5.0
        c.blur_glossy = 1.0
        c.use_denoising = denoiser_available()
        if c.use_denoising:
            c.denoiser = "OPENIMAGEDENOISE"
        if hasattr(c, "use_preview_denoising"):
            c.use_preview_denoising = False
    else:
        r.engine = "BLENDER_EEVEE"
        e = scene.eevee
        e.taa_render_samples = args.samples
        e.use_gtao = True
        e.use_soft_shadows = True
        e.shadow_cascade_size = "2048"
        e.shadow_cube_size = "1024"


def denoiser_available():
    try:
        import _cycles

        return bool(getattr(_cycles, "with_openimagedenoise", False))
    except ImportError:
        return False


def render_to(scene, args, first, last):
    """Renders into a hidden name beside the output, then renames: no half files."""
    out = os.path.abspath(args.output)
    folder, name = os.path.split(out)
    stem, ext = os.path.splitext(name)
    partial = os.path.join(folder, ".%s.partial%s" % (stem, ext))
    if os.path.exists(partial):
        os.remove(partial)
    r = scene.render
    r.use_file_extension = False
    r.filepath = partial
    try:
        if args.kind == "still":
            r.image_settings.file_format = "PNG"
            r.image_settings.color_mode = "RGB"
            r.image_settings.color_depth = "8"
            r.image_settings.compression = 100
            scene.frame_set(first)
            bpy.ops.render.render(write_still=True)
        else:
            r.image_settings.file_format = "FFMPEG"
            f = r.ffmpeg
            f.format = "MPEG4"
            f.codec = "H264"
            f.constant_rate_factor = "HIGH"
            f.ffmpeg_preset = "GOOD"
            f.gopsize = max(1, r.fps)
            f.audio_codec = "NONE"
            scene.frame_start, scene.frame_end = first, last
            bpy.ops.render.render(animation=True)
        if not os.path.isfile(partial) or os.path.getsize(partial) == 0:
            raise UserError("Blender wrote no %s (see its messages above)" % ext)
        os.replace(partial, out)
    finally:
        if os.path.exists(partial):
            os.remove(partial)


# ---------------------------------------------------------------- main


def main():
    args = build_parser().parse_args(script_argv())
    check_args(args)
    doc, bin_chunk = read_glb_json_and_bin(args.input)
    fps = fps_from_times(keyframe_times(doc, bin_chunk))

    if bpy is None:
        raise UserError("this script runs inside Blender: %s %s" % (PROG, " ".join(script_argv())))

    t0 = time.time()
    scene = reset_scene()
    # The importer turns seconds into frames with the scene's fps: set it first.
    scene.render.fps, scene.render.fps_base = fps, 1.0
    objects = import_glb(args.input)
    first, last = animation_range(objects)
    scene.frame_start, scene.frame_end = first, last
    scene.frame_preview_start, scene.frame_preview_end = first, last

    kinds = {o.name: classify(o) for o in objects}
    bricks = [o for o in objects if kinds[o.name] == "brick"]
    balls = [o for o in objects if kinds[o.name] == "ball"]
    grounds = [o for o in objects if kinds[o.name] == "ground"]
    mats = {"brick": brick_material(), "ball": steel_material(), "ground": ground_material()}
    for o in objects:
        assign(o, mats[kinds[o.name]])

    start_box, points, lowest, auto_still = survey(scene, bricks + balls, first, last)
    # At the first frame (where survey leaves the scene): the pieces of
    # bricks that break later are hidden there.
    pieces = sum(1 for o in bricks if not present(o))
    if start_box.empty():
        # Only a ground: frame a few metres of it.
        start_box.add((-2, -2, 0))
        start_box.add((2, 2, 1))
        points = [mathutils.Vector(c) for c in start_box.corners()]
    ground_added = not grounds
    if ground_added:
        add_ground(start_box, lowest, mats["ground"])
    w, h = args.size
    front = front_direction(bricks, balls)
    _, dist = add_camera(scene, points, front, w / h)
    add_sun(scene, front, start_box)
    set_world(scene)
    set_render(scene, args, fps)

    if args.kind == "still":
        a = b = auto_still if args.frame is None else args.frame
    else:
        a, b = (first, last) if args.frames is None else args.frames
    for f in sorted({a, b}):
        if not first <= f <= last:
            sys.stderr.write(
                "blender_render.py: warning: frame %d is outside the animation (%d..%d); "
                "bodies hold their first or last pose there\n" % (f, first, last)
            )
    print(
        "blender_render: %d bricks%s, %d balls, %s ground; %d fps, animation frames %d..%d; camera %.2f m away"
        % (
            len(bricks),
            " (%d of them pieces of bricks that break)" % pieces if pieces else "",
            len(balls),
            "added" if ground_added else "imported",
            fps,
            first,
            last,
            dist,
        )
    )
    print(
        "blender_render: %s %dx%d, %s with %d samples%s, frame%s %s"
        % (
            args.kind,
            w,
            h,
            args.engine,
            args.samples,
            " (denoised)" if args.engine == "CYCLES" and scene.cycles.use_denoising else "",
            "" if a == b else "s",
            a if a == b else "%d..%d" % (a, b),
        )
    )
    if args.blend:
        bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(args.blend), check_existing=False)
        print("blender_render: saved %s" % args.blend)
    t1 = time.time()
    render_to(scene, args, a, b)
    # The playback range stays the animation's, whatever was rendered.
    scene.frame_start, scene.frame_end = first, last
    t2 = time.time()
    print(
        "blender_render: wrote %s in %.1f s (set-up %.1f s, render %.1f s%s)"
        % (
            args.output,
            t2 - t0,
            t1 - t0,
            t2 - t1,
            ", %.2f s per frame" % ((t2 - t1) / (b - a + 1)) if b > a else "",
        )
    )


if __name__ == "__main__":
    try:
        main()
    except UserError as e:
        fail(str(e))
    except SystemExit:
        raise
    except Exception as e:  # an unexpected failure must still exit non-zero
        import traceback

        traceback.print_exc()
        fail("%s: %s" % (type(e).__name__, e))
    sys.stdout.flush()
