"""Builds a Cornell-like room in Blender, exports it with Blender's own glTF exporter and renders
it with Cycles, for the path tracer's comparison with Cycles (tests/cycles.rs,
`make test-cycles`).

    blender -b --factory-startup --python tools/gltf/blender_cornell.py -- OUT_DIR SIZE SPP DEPTH [opaque] [passes] [centre] [rough] [blend] [dense]

writes OUT_DIR/cornell.gltf (+ .bin) and OUT_DIR/cycles.exr (SIZE x SIZE pixels, or W x H for a
SIZE of the form WxH, SPP samples, scene-linear RGBA floats; SPP 0 exports without rendering).
`blend` also saves OUT_DIR/cornell.blend, the scene as Cycles renders it (its settings below),
before rendering, or instead of it with SPP 0: tools/bench/cycles_time.py renders it. `dense`
puts a textured Suzanne subdivided to about 1M triangles in place of the block and
textures the floor, both with a UV grid Blender generates, saved as OUT_DIR/uvgrid.png (see
the end of this docstring). `opaque` makes the glass sphere white diffuse, lifts
both spheres 0.2 off the floor, closes the room with a white front wall and puts the camera
inside it (at (0, -0.9, 1), a 16 mm lens): then every pixel sees a surface of a closed, lit
room, with no contact point where the light goes to 0 and no opening for paths to escape. In Blender's Z-up coordinates (the exporter turns (x, y, z) into glTF's (x, z, -y)):

- a room x, y in [-1, 1], z in [0, 2], open towards -y: white floor, ceiling and back wall
  (0.725, 0.71, 0.68), red left wall (0.63, 0.065, 0.05), green right wall (0.14, 0.45, 0.091);
- the light: a 0.5 m square in a hole of the same size in the ceiling, facing down, emitting
  white radiance 15 W/(m^2 sr) (Emission strength 15; glTF emissiveFactor 1 and
  KHR_materials_emissive_strength 15); nothing is above it, so its back side lights nothing;
- a white diffuse block, a mirror-like metal sphere (metallic 1, roughness 0, base 0.9) and a
  glass sphere (transmission 1, IOR 1.5, roughness 0);
- a camera at (0, -3.9, 1) looking along +y, 60 mm lens on a 36 mm sensor (a square image
  that sees nothing but the room).

Diffuse surfaces are exported as the glTF metallic-roughness material (metallic 0, roughness 1,
specular 0) and rendered by Cycles with its Diffuse BSDF (Lambert), which is what that glTF
material is; Cycles' Principled BSDF would add its Disney diffuse retro-reflection instead.
Cycles is set to what strahl's path tracer computes: DEPTH scatterings (Cycles' max bounces
DEPTH - 1, every kind), no clamp, no glossy filter, caustics on, no adaptive sampling, no
denoising, a box filter of one pixel (strahl's) and a black world.

`dense`: Suzanne (Blender's monkey, 500 faces) with its Subdivision Surface modifier applied at
level 5 (1,007,616 triangles), smooth-shaded, 0.8 m across where the block stands, and the floor
a 200 x 200 grid of quads (80,000 triangles), 1,095,568 triangles in all; both diffuse
(metallic 0, roughness 1, specular 0) with a 1024 x 1024 UV grid (Blender's generated "UV
Grid", sRGB) as base colour, which Cycles renders with the Diffuse BSDF coloured by the same
image (linear interpolation).
"""

import json
import math
import os
import sys

import bpy

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "blender"))
from principled import principled  # noqa: E402
from cycles_settings import like_strahl  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1 :]
out_dir, size, spp, depth = args[:4]
width, height = (int(v) for v in size.split("x")) if "x" in size else (int(size), int(size))
spp, depth = int(spp), int(depth)
flags = set(args[4:])
opaque = "opaque" in flags
# `passes`: a multilayer EXR with Cycles' Depth and CryptoObject passes (6 levels), for the
# comparison of strahl's Depth and Cryptomatte with Cycles' (tests/cycles.rs); `centre`: every
# sample at the pixel centre (a box filter 0.01 pixel wide, Cycles' narrowest).
passes = "passes" in flags
centre = "centre" in flags
# `rough`: the metal sphere has roughness 0.4 (GGX, alpha 0.16) instead of 0; Cycles renders it
# with Multiscatter GGX, which keeps the energy single-scattering GGX loses, as strahl's glTF
# BRDF does (Kulla-Conty).
rough = "rough" in flags
blend = "blend" in flags
dense = "dense" in flags
os.makedirs(out_dir, exist_ok=True)

for obj in list(bpy.data.objects):
    bpy.data.objects.remove(obj, do_unlink=True)
scene = bpy.context.scene

WHITE = (0.725, 0.71, 0.68)
RED = (0.63, 0.065, 0.05)
GREEN = (0.14, 0.45, 0.091)


def emitter(name, strength):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nodes = mat.node_tree.nodes
    nodes.remove(nodes["Principled BSDF"])
    emission = nodes.new("ShaderNodeEmission")
    emission.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    emission.inputs["Strength"].default_value = strength
    mat.node_tree.links.new(emission.outputs["Emission"], nodes["Material Output"].inputs["Surface"])
    return mat


def mesh_object(name, verts, faces, mat, smooth=False):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    mesh.update()
    if smooth:
        for p in mesh.polygons:
            p.use_smooth = True
    mesh.materials.append(mat)
    obj = bpy.data.objects.new(name, mesh)
    scene.collection.objects.link(obj)
    return obj


white = principled("white", WHITE, specular=0.0)
red = principled("red", RED, specular=0.0)
green = principled("green", GREEN, specular=0.0)


def uv_grid_material(name):
    """A diffuse material coloured by Blender's generated UV grid, saved as OUT_DIR/uvgrid.png."""
    image = bpy.data.images.new("uvgrid", 1024, 1024)
    image.generated_type = "UV_GRID"
    image.filepath_raw = os.path.join(out_dir, "uvgrid.png")
    image.file_format = "PNG"
    image.save()
    mat = principled(name, (1.0, 1.0, 1.0), specular=0.0)
    texture = mat.node_tree.nodes.new("ShaderNodeTexImage")
    texture.image = image
    texture.interpolation = "Linear"
    mat.node_tree.links.new(texture.outputs["Color"], mat.node_tree.nodes["Principled BSDF"].inputs["Base Color"])
    return mat


textured = uv_grid_material("uvgrid") if dense else None
# Faces wound so that their normals face into the room.
if dense:
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=200, y_subdivisions=200, size=2.0, calc_uvs=True)
    bpy.context.active_object.name = "floor"
    bpy.context.active_object.data.materials.append(textured)
else:
    mesh_object("floor", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [(0, 1, 2, 3)], white)
mesh_object("back", [(-1, 1, 0), (1, 1, 0), (1, 1, 2), (-1, 1, 2)], [(0, 1, 2, 3)], white)
mesh_object("left", [(-1, -1, 0), (-1, 1, 0), (-1, 1, 2), (-1, -1, 2)], [(0, 1, 2, 3)], red)
mesh_object("right", [(1, -1, 0), (1, -1, 2), (1, 1, 2), (1, 1, 0)], [(0, 1, 2, 3)], green)
if opaque:
    mesh_object("front", [(-1, -1, 0), (-1, -1, 2), (1, -1, 2), (1, -1, 0)], [(0, 1, 2, 3)], white)
h = 0.25
outer = [(-1, -1, 2), (1, -1, 2), (1, 1, 2), (-1, 1, 2)]
inner = [(-h, -h, 2), (h, -h, 2), (h, h, 2), (-h, h, 2)]
mesh_object(
    "ceiling",
    outer + inner,
    [(0, 4, 5, 1), (1, 5, 6, 2), (2, 6, 7, 3), (3, 7, 4, 0)],
    white,
)
mesh_object("light", [(-h, -h, 2), (-h, h, 2), (h, h, 2), (h, -h, 2)], [(0, 1, 2, 3)], emitter("light", 15.0))

if dense:
    bpy.ops.mesh.primitive_monkey_add(size=0.6, location=(-0.4, 0.3, 0.45), rotation=(0, 0, math.radians(-15)))
    block = bpy.context.active_object
    subdivision = block.modifiers.new("subdivision", "SUBSURF")
    subdivision.levels = subdivision.render_levels = 5
    bpy.ops.object.modifier_apply(modifier=subdivision.name)
    bpy.ops.object.shade_smooth()
    block.data.materials.append(textured)
else:
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(-0.45, 0.35, 0.6), rotation=(0, 0, math.radians(20)))
    block = bpy.context.active_object
    block.scale = (0.55, 0.55, 1.2)
    block.data.materials.append(principled("block", WHITE, specular=0.0))
block.name = "block"

# `opaque` lifts both spheres off the floor, so that no point of the floor is a contact point,
# where the light goes to 0.
lift = 0.2 if opaque else 0.0
bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32, radius=0.35, location=(0.5, 0.3, 0.35 + lift))
metal = bpy.context.active_object
metal.name = "metal"
bpy.ops.object.shade_smooth()
metal.data.materials.append(
    principled("metal", (0.9, 0.9, 0.9), metallic=1.0, roughness=0.4 if rough else 0.0, specular=0.5)
)

bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32, radius=0.3, location=(0.35, -0.45, 0.3 + lift))
glass = bpy.context.active_object
glass.name = "glass"
bpy.ops.object.shade_smooth()
if opaque:
    glass.data.materials.append(principled("opaque", WHITE, specular=0.0))
else:
    glass.data.materials.append(principled("glass", (1.0, 1.0, 1.0), roughness=0.0, transmission=1.0, specular=0.5))

cam_data = bpy.data.cameras.new("camera")
cam_data.lens = 16.0 if opaque else 60.0
cam_data.sensor_width = 36.0
cam_data.sensor_fit = "AUTO"
cam = bpy.data.objects.new("camera", cam_data)
cam.location = (0.0, -0.9, 1.0) if opaque else (0.0, -3.9, 1.0)
cam.rotation_euler = (math.radians(90.0), 0.0, 0.0)
scene.collection.objects.link(cam)
scene.camera = cam
scene.render.resolution_x = width
scene.render.resolution_y = height
scene.render.resolution_percentage = 100

gltf_path = os.path.join(out_dir, "cornell.gltf")
bpy.ops.export_scene.gltf(
    filepath=gltf_path,
    export_format="GLTF_SEPARATE",
    export_cameras=True,
    export_lights=False,
    export_apply=True,
)

# Principled's Specular 0 exports as KHR_materials_specular's specularColorFactor 0 (F0 = 0) but
# keeps specularFactor 1, which by the extension still reflects at grazing angles (F90 = 1). Set
# specularFactor 0 as well, so that the file's diffuse materials are exactly Lambert, as the
# Diffuse BSDF that Cycles renders below.
with open(gltf_path) as f:
    doc = json.load(f)
for material in doc.get("materials", []):
    specular = material.get("extensions", {}).get("KHR_materials_specular")
    if specular is not None and specular.get("specularColorFactor") == [0, 0, 0]:
        specular["specularFactor"] = 0.0
with open(gltf_path, "w") as f:
    json.dump(doc, f)

if spp == 0 and not blend:
    sys.exit(0)

# Cycles renders what the glTF file says: Lambert where the glTF material is diffuse.
for mat in (white, red, green, block.data.materials[0]) + ((glass.data.materials[0],) if opaque else ()):
    nodes = mat.node_tree.nodes
    base_input = nodes["Principled BSDF"].inputs["Base Color"]
    base = base_input.default_value[:]
    texture = base_input.links[0].from_socket if base_input.is_linked else None
    nodes.remove(nodes["Principled BSDF"])
    diffuse = nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = base
    if texture is not None:
        mat.node_tree.links.new(texture, diffuse.inputs["Color"])
    diffuse.inputs["Roughness"].default_value = 0.0
    mat.node_tree.links.new(diffuse.outputs["BSDF"], nodes["Material Output"].inputs["Surface"])

if rough:
    metal.data.materials[0].node_tree.nodes["Principled BSDF"].distribution = "MULTI_GGX"

world = bpy.data.worlds.new("black")
world.use_nodes = True
world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
scene.world = world

cycles = like_strahl(scene, spp, depth, multilayer=passes)
if centre:
    cycles.filter_width = 0.01
if passes:
    layer = scene.view_layers[0]
    layer.use_pass_z = True
    layer.use_pass_cryptomatte_object = True
    layer.pass_cryptomatte_depth = 6
scene.render.filepath = os.path.join(out_dir, "cycles.exr")
if blend:
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(out_dir, "cornell.blend"))
    if spp == 0:
        sys.exit(0)
bpy.ops.render.render(write_still=True)
print("WROTE", scene.render.filepath)
