"""Renders a glTF file as it is with Blender Cycles, lit by a uniform white world (or a map), from
a camera given on the command line (tests/khronos_models.rs renders the same file with strahl,
from the same camera, under `--environment 1,1,1` or the same map).

    blender -b --factory-startup --python tools/blender/render_gltf.py -- \
        IN.gltf OUT_DIR SIZE SPP DEPTH EYE_X EYE_Y EYE_Z TARGET_X TARGET_Y TARGET_Z YFOV_DEG \
        [depth] [environment=MAP.exr] [multiscatter]

Writes OUT_DIR/cycles.exr (SIZE x SIZE, RGBA float); with `depth`, a multilayer EXR with the
Depth pass (`ViewLayer.Depth.Z`) too, of samples at the pixel centres (a box filter 0.01 pixel
wide, Cycles' narrowest). With `environment=MAP.exr`, the world is that equirectangular map
instead (an Environment Texture node, its default vector, texels looked up nearest: strahl's
`--environment MAP.exr`, whose orientation is Blender's). With `multiscatter`, every Principled
BSDF the importer made uses Cycles' Multiscatter GGX instead of its default GGX (single
scattering: a rough metal loses the energy its microfacets scatter more than once). EYE,
TARGET are in glTF's coordinates (y up); the camera's up is +y and its vertical field of view
YFOV_DEG, on a square image.
Blender's own glTF importer reads the file: what is compared is two readings of the same asset.

Cycles is set to what strahl computes (tools/blender/cycles_settings.py).
"""

import math, os, sys

import bpy
import numpy
from mathutils import Matrix, Vector

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cycles_settings import like_strahl  # noqa: E402

# Blender 3.4's glTF importer still says `numpy.bool`, which NumPy 1.24 removed (Debian
# bookworm's python3-numpy is 1.24): give it back the alias it meant.
if not hasattr(numpy, "bool"):
    numpy.bool = bool

argv = sys.argv[sys.argv.index("--") + 1:]
src, out_dir = argv[0], argv[1]
size, spp, depth = int(argv[2]), int(argv[3]), int(argv[4])
eye = Vector([float(x) for x in argv[5:8]])
target = Vector([float(x) for x in argv[8:11]])
yfov = math.radians(float(argv[11]))
with_depth = "depth" in argv[12:]
environment = next((a.split("=", 1)[1] for a in argv[12:] if a.startswith("environment=")), None)
os.makedirs(out_dir, exist_ok=True)

# glTF's y-up to Blender's z-up, (x, y, z) -> (x, -z, y), as the importer converts the file.
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=src)
scene = bpy.context.scene
to_blender = lambda v: Vector((v.x, -v.z, v.y))
cam_data = bpy.data.cameras.new("camera")
cam_data.sensor_fit = "VERTICAL"
cam_data.angle_y = yfov
# Clipping relative to the viewing distance (Blender's default starts at 0.1 m, which hides a
# model a few centimetres from the camera: MetalRoughSpheresNoTextures is 7 mm wide).
cam_data.clip_start = 1e-3 * (target - eye).length
cam_data.clip_end = 1e3 * (target - eye).length
cam = bpy.data.objects.new("camera", cam_data)
cam.location = to_blender(eye)
# The camera looks along its −z with +y up: columns u (right), v (up), w (back), w from the
# target to the eye, u = up × w with Blender's up +z (as strahl builds it with glTF's up; Vector's
# to_track_quat("-Z", "Z") turns the camera upside down when it looks along −y exactly).
w = (to_blender(eye) - to_blender(target)).normalized()
u = Vector((0.0, 0.0, 1.0)).cross(w).normalized()
cam.rotation_euler = Matrix((u, w.cross(u), w)).transposed().to_euler()
scene.collection.objects.link(cam)
scene.camera = cam
scene.render.resolution_x = size
scene.render.resolution_y = size
scene.render.resolution_percentage = 100

world = bpy.data.worlds.new("white")
world.use_nodes = True
background = world.node_tree.nodes["Background"]
background.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
if environment:
    texture = world.node_tree.nodes.new("ShaderNodeTexEnvironment")
    texture.image = bpy.data.images.load(os.path.abspath(environment))
    texture.image.colorspace_settings.name = "Linear"
    texture.interpolation = "Closest"
    world.node_tree.links.new(texture.outputs["Color"], background.inputs["Color"])
background.inputs["Strength"].default_value = 1.0
scene.world = world

if "multiscatter" in argv[12:]:
    for material in bpy.data.materials:
        for node in material.node_tree.nodes if material.node_tree else []:
            if node.type == "BSDF_PRINCIPLED":
                node.distribution = "MULTI_GGX"

cycles = like_strahl(scene, spp, depth, multilayer=with_depth)
if with_depth:
    cycles.filter_width = 0.01
    scene.view_layers[0].use_pass_z = True
scene.render.filepath = os.path.join(out_dir, "cycles.exr")
bpy.ops.render.render(write_still=True)
print("WROTE", scene.render.filepath)
