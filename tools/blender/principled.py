"""A Principled BSDF material for the scripts that build test scenes in Blender
(tools/blender/room.py, tools/gltf/blender_cornell.py): Blender 3.4's node inputs set from the
values given, IOR 1.5. `specular` has no default on purpose: Blender's own is 0.5, and the
diffuse walls of the test rooms set 0 so that they are Lambertian, as strahl's scenes are.
"""

import bpy


def principled(name, base, *, specular, metallic=0.0, roughness=1.0, transmission=0.0):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*base, 1.0)
    bsdf.inputs["Metallic"].default_value = metallic
    bsdf.inputs["Roughness"].default_value = roughness
    bsdf.inputs["Transmission"].default_value = transmission
    bsdf.inputs["Specular"].default_value = specular
    bsdf.inputs["IOR"].default_value = 1.5
    return mat
