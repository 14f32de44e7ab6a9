"""Builds the .blend that tests/blender_engine.rs renders with the strahl add-on, and the
glTF file of its frame 1 that strahl renders directly for comparison.

    BLENDER_USER_SCRIPTS=DIR blender -b --factory-startup --addons strahl_engine \
        --python tools/blender/room.py -- OUT_DIR

writes OUT_DIR/room.blend and OUT_DIR/reference/scene.gltf (+ .bin), exported by the add-on's
`export.export_frame` (Blender's glTF exporter, plus the area light as an emissive square),
and prints `CAMERA <index>`. The scene, in Blender's z-up metres:

- a room x, y in [-1, 1], z in [0, 2], open towards -y: white floor, ceiling and back wall,
  red left and green right wall (diffuse Principled BSDF: metallic 0, roughness 1);
- a metal sphere (metallic 1, roughness 0.2, base 0.9) that moves from x = 0.5 at frame 1 to
  x = 0.1 at frame 3, and a glass sphere (transmission 1, IOR 1.5, roughness 0);
- an area light: a 0.5 m square 1.98 m up, facing down, 60 W (radiance 60 W/(m² sr));
- a camera at (0, -3.4, 1) looking along +y, 50 mm lens;
- 64 × 48 pixels, strahl path tracer at 4 samples, depth 6, one thread;
- view layer passes Depth, Normal, DiffCol and Cryptomatte objects (2 levels); output a
  32-bit multilayer EXR;
- a compositor tree: Composite = DiffCol mixed towards magenta (1, 0, 1) by the Cryptomatte
  matte of the object "metal": RGB = DiffCol·(1 − m) + (1, 0, 1)·m.
"""

import math
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from principled import principled  # noqa: E402

import strahl_engine.export

out_dir = sys.argv[sys.argv.index("--") + 1]
os.makedirs(out_dir, exist_ok=True)

for obj in list(bpy.data.objects):
    bpy.data.objects.remove(obj, do_unlink=True)
scene = bpy.context.scene

WHITE = (0.725, 0.71, 0.68)


def quad(name, verts, mat):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], [(0, 1, 2, 3)])
    mesh.update()
    mesh.materials.append(mat)
    obj = bpy.data.objects.new(name, mesh)
    scene.collection.objects.link(obj)


white = principled("white", WHITE, specular=0.0)
quad("floor", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], white)
quad("ceiling", [(-1, -1, 2), (-1, 1, 2), (1, 1, 2), (1, -1, 2)], white)
quad("back", [(-1, 1, 0), (1, 1, 0), (1, 1, 2), (-1, 1, 2)], white)
quad("left", [(-1, -1, 0), (-1, 1, 0), (-1, 1, 2), (-1, -1, 2)], principled("red", (0.63, 0.065, 0.05), specular=0.0))
quad("right", [(1, -1, 0), (1, -1, 2), (1, 1, 2), (1, 1, 0)], principled("green", (0.14, 0.45, 0.091), specular=0.0))

bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16, radius=0.35, location=(0.5, 0.3, 0.35))
metal = bpy.context.active_object
metal.name = "metal"
bpy.ops.object.shade_smooth()
metal.data.materials.append(principled("metal", (0.9, 0.9, 0.9), metallic=1.0, roughness=0.2, specular=0.5))
metal.keyframe_insert("location", frame=1)
metal.location.x = 0.1
metal.keyframe_insert("location", frame=3)
metal.location.x = 0.5

bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16, radius=0.3, location=(-0.4, -0.3, 0.3))
glass = bpy.context.active_object
glass.name = "glass"
bpy.ops.object.shade_smooth()
glass.data.materials.append(principled("glass", (1.0, 1.0, 1.0), roughness=0.0, transmission=1.0, specular=0.5))

light_data = bpy.data.lights.new("area", "AREA")
light_data.shape = "SQUARE"
light_data.size = 0.5
light_data.energy = 60.0
light = bpy.data.objects.new("area", light_data)
light.location = (0.0, 0.0, 1.98)
scene.collection.objects.link(light)

cam_data = bpy.data.cameras.new("camera")
cam_data.lens = 50.0
cam_data.sensor_width = 36.0
cam = bpy.data.objects.new("camera", cam_data)
cam.location = (0.0, -3.4, 1.0)
cam.rotation_euler = (math.radians(90.0), 0.0, 0.0)
scene.collection.objects.link(cam)
scene.camera = cam

scene.frame_start, scene.frame_end = 1, 3
scene.frame_set(1)
render = scene.render
render.engine = "STRAHL"
render.resolution_x, render.resolution_y, render.resolution_percentage = 64, 48, 100
render.film_transparent = False
render.image_settings.file_format = "OPEN_EXR_MULTILAYER"
render.image_settings.color_depth = "32"
render.image_settings.exr_codec = "ZIP"
render.use_file_extension = True
scene.strahl.integrator = "path"
scene.strahl.samples = 4
scene.strahl.max_depth = 6
scene.strahl.threads = 1
scene.strahl.backend = "embree"

view_layer = scene.view_layers[0]
view_layer.use_pass_z = True
view_layer.use_pass_normal = True
view_layer.use_pass_diffuse_color = True
view_layer.use_pass_cryptomatte_object = True
view_layer.pass_cryptomatte_depth = 2

scene.use_nodes = True
tree = scene.node_tree
for node in list(tree.nodes):
    tree.nodes.remove(node)
layers = tree.nodes.new("CompositorNodeRLayers")
crypto = tree.nodes.new("CompositorNodeCryptomatteV2")
crypto.source = "RENDER"
crypto.scene = scene
crypto.matte_id = "metal"
mix = tree.nodes.new("CompositorNodeMixRGB")
mix.blend_type = "MIX"
mix.inputs[2].default_value = (1.0, 0.0, 1.0, 1.0)
composite = tree.nodes.new("CompositorNodeComposite")
composite.use_alpha = False
tree.links.new(layers.outputs["Image"], crypto.inputs["Image"])
tree.links.new(crypto.outputs["Matte"], mix.inputs["Fac"])
tree.links.new(layers.outputs["DiffCol"], mix.inputs[1])
tree.links.new(mix.outputs["Image"], composite.inputs["Image"])

bpy.ops.wm.save_as_mainfile(filepath=os.path.join(out_dir, "room.blend"))

reference = os.path.join(out_dir, "reference")
os.makedirs(reference, exist_ok=True)
depsgraph = bpy.context.evaluated_depsgraph_get()
_, camera = strahl_engine.export.export_frame(scene, bpy.context.view_layer, depsgraph, reference)
print("CAMERA", camera)
