"""Builds a small scene in Blender and exports it with Blender's own glTF exporter, for
strahl's import tests (tests/gltf_external.rs, `make test-gltf-blender`).

    blender -b --factory-startup --python tools/gltf/blender_export.py -- OUT_DIR

writes OUT_DIR/blender.glb and OUT_DIR/checker.png. Blender is Z-up; its exporter turns
(x, y, z) into glTF's Y-up (x, z, -y). The scene, in glTF coordinates:

- a camera at (0, 0, 8) looking along -z, 50 mm lens, 36 mm sensor, 320 x 240;
- a point light of 1000 W at (2, 4, 3) and a sun of 2 W/m2 shining along -y, exported with
  lighting mode COMPAT (point: W / 4pi = W/sr; sun: W/m2), strahl's units;
- a textured quad x, y in [-3, 3] at z = -4 (base colour = a 4 x 4 checker PNG);
- a red cube of half-size 0.5 at (-1.5, 0, -2) and a *linked duplicate* (same mesh data)
  at (-1.5, 1.5, -2): one glTF mesh used by two nodes;
- a glass cube (transmission 1, IOR 1.45) of half-size 0.6 at (1.5, 0, -1).
"""

import math
import os
import sys

import bpy

out_dir = sys.argv[sys.argv.index("--") + 1]
os.makedirs(out_dir, exist_ok=True)

for obj in list(bpy.data.objects):
    bpy.data.objects.remove(obj, do_unlink=True)

scene = bpy.context.scene
scene.render.resolution_x = 320
scene.render.resolution_y = 240

cam_data = bpy.data.cameras.new("Camera")
cam_data.lens = 50.0
cam_data.sensor_width = 36.0
cam = bpy.data.objects.new("Camera", cam_data)
cam.location = (0.0, -8.0, 0.0)
cam.rotation_euler = (math.radians(90.0), 0.0, 0.0)
scene.collection.objects.link(cam)
scene.camera = cam

point = bpy.data.objects.new("Point", bpy.data.lights.new("Point", "POINT"))
point.data.energy = 1000.0
point.data.shadow_soft_size = 0.0
point.location = (2.0, -3.0, 4.0)
scene.collection.objects.link(point)
sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
sun.data.energy = 2.0
scene.collection.objects.link(sun)


def principled(name, base, transmission=0.0, ior=1.45):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = base
    bsdf.inputs["Metallic"].default_value = 0.0
    bsdf.inputs["Roughness"].default_value = 1.0
    bsdf.inputs["Transmission"].default_value = transmission
    bsdf.inputs["IOR"].default_value = ior
    return mat, bsdf


# The checker texture: 4 x 4 texels, sRGB.
img = bpy.data.images.new("checker", 4, 4, alpha=False)
texels = []
for j in range(4):  # Blender's rows run bottom to top
    for i in range(4):
        on = (i // 2 + j // 2) % 2 == 0
        texels += [0.9, 0.6, 0.1, 1.0] if on else [0.1, 0.2, 0.7, 1.0]
img.pixels = texels
img.filepath_raw = os.path.join(out_dir, "checker.png")
img.file_format = "PNG"
img.save()

bpy.ops.mesh.primitive_plane_add(size=2.0, location=(0.0, 4.0, 0.0), rotation=(math.radians(90.0), 0.0, 0.0))
wall = bpy.context.active_object
wall.scale = (3.0, 3.0, 3.0)
wall_mat, wall_bsdf = principled("wall", (1.0, 1.0, 1.0, 1.0))
tex = wall_mat.node_tree.nodes.new("ShaderNodeTexImage")
tex.image = bpy.data.images.load(os.path.join(out_dir, "checker.png"))
wall_mat.node_tree.links.new(tex.outputs["Color"], wall_bsdf.inputs["Base Color"])
wall.data.materials.append(wall_mat)

bpy.ops.mesh.primitive_cube_add(size=2.0, location=(-1.5, 2.0, 0.0))
red = bpy.context.active_object
red.scale = (0.5, 0.5, 0.5)
red.data.materials.append(principled("red", (0.8, 0.3, 0.2, 1.0))[0])
twin = red.copy()  # a linked duplicate: shares red.data
twin.location = (-1.5, 2.0, 1.5)
scene.collection.objects.link(twin)

bpy.ops.mesh.primitive_cube_add(size=2.0, location=(1.5, 1.0, 0.0))
glass = bpy.context.active_object
glass.scale = (0.6, 0.6, 0.6)
glass.data.materials.append(principled("glass", (1.0, 1.0, 1.0, 1.0), transmission=1.0, ior=1.45)[0])

bpy.ops.export_scene.gltf(
    filepath=os.path.join(out_dir, "blender.glb"),
    export_format="GLB",
    export_cameras=True,
    export_lights=True,
    convert_lighting_mode="COMPAT",
    export_apply=False,
)
print("wrote", os.path.join(out_dir, "blender.glb"))
