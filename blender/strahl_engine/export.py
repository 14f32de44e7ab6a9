"""The frame's scene as a glTF file strahl reads: Blender's own exporter
(`bpy.ops.export_scene.gltf`, separate .gltf + .bin) writes the renderable objects with
modifiers applied, linked duplicates and collection instances as one mesh used by several
nodes, cameras, Principled BSDF materials and the point, spot and sun lights
(`KHR_lights_punctual`) in Blender's own units: the exporter's "Unitless" lighting mode writes
a point or spot light of P W as intensity P/4π (W/sr) and a sun's W/m² unchanged, which strahl
reads one for one (docs/scene-format.md, Photometric units).

glTF has no area lights and the exporter drops them, so each area light of the frame is added
to the file as an emissive polygon: its square or rectangle (a 128-gon for a disk or
ellipse) in world space, black and non-reflecting, of radiance

    L = colour × P / (4 A)

where P is the light's power in W and A its area in m² after the object's scale: Cycles'
radiance for an area light (its kernel's 1/(4A); a 0.5 m square of 100 W lights a floor
exactly as an Emission quad of strength 100 / (4 · 0.25), measured to 1e-5 in Cycles 3.4).
The polygon's winding faces the light's −z, the side a Blender area light lights, and its
material is one-sided (glTF's default `doubleSided: false`), so strahl's emissive mesh lights
that side only and a camera behind it sees through it, as Cycles' area light; the spread angle
is ignored.

The exporter writes the frame being rendered (`export_current_frame`; by default it would
set the scene to frame 0 and back, and an animation would export the wrong frames).

The camera strahl looks through is the scene's active camera, passed by its index among the
file's cameras (an object's name could read as an index).
"""

import json
import math
import os
import struct

import bpy

GLTF_NAME = "scene.gltf"
AREA_LIGHTS_BIN = "strahl_area_lights.bin"
DISK_SEGMENTS = 128


class ExportError(Exception):
    """Why the frame cannot be exported, in one line."""


def export_frame(scene, view_layer, depsgraph, directory):
    """Writes the frame to `directory`/scene.gltf (+ .bin); returns (path, camera index).
    The exporter runs in a context of the scene and view layer (a render's own context has
    neither an active object nor a view layer)."""
    if scene.camera is None:
        raise ExportError("the scene has no active camera")
    path = os.path.join(directory, GLTF_NAME)
    override = {"scene": scene, "view_layer": view_layer}
    windows = [w for wm in bpy.data.window_managers for w in wm.windows]
    if windows:
        override.update(window=windows[0], screen=windows[0].screen)
    with bpy.context.temp_override(**override):
        result = bpy.ops.export_scene.gltf(
            filepath=path,
            export_format="GLTF_SEPARATE",
            use_active_scene=True,
            use_renderable=True,
            export_apply=True,
            export_cameras=True,
            export_lights=True,
            convert_lighting_mode="COMPAT",
            export_animations=False,
            export_current_frame=True,
            export_extras=False,
            export_yup=True,
        )
    if "FINISHED" not in result or not os.path.exists(path):
        raise ExportError("Blender's glTF exporter did not write the scene")
    with open(path) as f:
        doc = json.load(f)
    name_meshes_by_objects(doc)
    add_area_lights(doc, directory, area_lights(depsgraph))
    with open(path, "w") as f:
        json.dump(doc, f)
    return path, camera_index(doc, scene.camera.name)


def name_meshes_by_objects(doc):
    """Gives each mesh used by one node that node's name (the object's): strahl names its
    objects (Cryptomatte, `strahl info`) by glTF mesh, where Blender's exporter writes the
    mesh data's name (`Sphere.001`) and Blender's Cryptomatte the object's."""
    users = {}
    for node in doc.get("nodes", []):
        if "mesh" in node:
            users.setdefault(node["mesh"], []).append(node)
    for mesh, nodes in users.items():
        if len(nodes) == 1 and "name" in nodes[0]:
            doc["meshes"][mesh]["name"] = nodes[0]["name"]


def camera_index(doc, object_name):
    """The index in `cameras` of the camera on the node named `object_name`."""
    for node in doc.get("nodes", []):
        if node.get("name") == object_name and "camera" in node:
            return node["camera"]
    raise ExportError("the active camera %r is not in the exported file (is it hidden from renders?)" % object_name)


def to_gltf(v):
    """Blender's z-up (x, y, z) as glTF's y-up (x, z, −y), as the exporter turns it."""
    return (v[0], v[2], -v[1])


def area_lights(depsgraph):
    """(world-space polygon in glTF axes, radiance RGB) of every area light of the frame."""
    lights = []
    for inst in depsgraph.object_instances:
        obj = inst.object
        if obj.type != "LIGHT" or obj.data.type != "AREA" or not inst.show_self:
            continue
        light = obj.data
        m = inst.matrix_world
        a = light.size
        b = light.size_y if light.shape in ("RECTANGLE", "ELLIPSE") else light.size
        if light.shape in ("DISK", "ELLIPSE"):
            local = [
                (0.5 * a * math.cos(2 * math.pi * k / DISK_SEGMENTS), 0.5 * b * math.sin(2 * math.pi * k / DISK_SEGMENTS))
                for k in range(DISK_SEGMENTS)
            ]
            area_factor = math.pi / 4
        else:
            local = [(-a / 2, -b / 2), (a / 2, -b / 2), (a / 2, b / 2), (-a / 2, b / 2)]
            area_factor = 1.0
        sx = (m.to_3x3() @ _vec(a, 0)).length
        sy = (m.to_3x3() @ _vec(0, b)).length
        area = area_factor * sx * sy
        if area <= 0.0:
            continue
        scale = light.energy / (4.0 * area)
        radiance = [c * scale for c in light.color]
        # Clockwise seen from the light's +z: the winding's normal is its −z, the lit side.
        polygon = [to_gltf(m @ _vec(x, y)) for x, y in reversed(local)]
        lights.append((obj.name, polygon, radiance))
    return lights


def _vec(x, y):
    from mathutils import Vector

    return Vector((x, y, 0.0))


def add_area_lights(doc, directory, lights):
    """Adds each light as a mesh node of the default scene, its vertices and fan indices in a
    buffer of its own (`strahl_area_lights.bin` beside the file)."""
    if not lights:
        return
    data = bytearray()
    for key in ("buffers", "bufferViews", "accessors", "meshes", "materials", "nodes"):
        doc.setdefault(key, [])
    buffer = len(doc["buffers"])
    scene = doc["scenes"][doc.get("scene", 0)]
    scene.setdefault("nodes", [])
    for name, polygon, radiance in lights:
        n = len(polygon)
        indices = [i for k in range(1, n - 1) for i in (0, k, k + 1)]
        pos_offset = len(data)
        for p in polygon:
            data += struct.pack("<3f", *p)
        idx_offset = len(data)
        data += struct.pack("<%dI" % len(indices), *indices)
        views = len(doc["bufferViews"])
        doc["bufferViews"] += [
            {"buffer": buffer, "byteOffset": pos_offset, "byteLength": 12 * n},
            {"buffer": buffer, "byteOffset": idx_offset, "byteLength": 4 * len(indices)},
        ]
        accessors = len(doc["accessors"])
        doc["accessors"] += [
            {
                "bufferView": views,
                "componentType": 5126,
                "count": n,
                "type": "VEC3",
                "min": [min(p[i] for p in polygon) for i in range(3)],
                "max": [max(p[i] for p in polygon) for i in range(3)],
            },
            {"bufferView": views + 1, "componentType": 5125, "count": len(indices), "type": "SCALAR"},
        ]
        peak = max(radiance)
        material = len(doc["materials"])
        doc["materials"].append(
            {
                "name": name,
                "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0, "roughnessFactor": 1},
                "emissiveFactor": [c / peak for c in radiance] if peak > 0 else [0, 0, 0],
                "extensions": {
                    "KHR_materials_emissive_strength": {"emissiveStrength": peak},
                    "KHR_materials_specular": {"specularFactor": 0, "specularColorFactor": [0, 0, 0]},
                },
            }
        )
        mesh = len(doc["meshes"])
        doc["meshes"].append(
            {"name": name, "primitives": [{"attributes": {"POSITION": accessors}, "indices": accessors + 1, "material": material}]}
        )
        scene["nodes"].append(len(doc["nodes"]))
        doc["nodes"].append({"name": name, "mesh": mesh})
        # Keep each view 4-byte aligned.
        data += b"\0" * (-len(data) % 4)
    used = doc.setdefault("extensionsUsed", [])
    for ext in ("KHR_materials_emissive_strength", "KHR_materials_specular"):
        if ext not in used:
            used.append(ext)
    with open(os.path.join(directory, AREA_LIGHTS_BIN), "wb") as f:
        f.write(data)
    doc["buffers"].append({"uri": AREA_LIGHTS_BIN, "byteLength": len(data)})
