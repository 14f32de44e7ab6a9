"""Writes a glTF file with pygltflib (not strahl's code) for strahl's import tests
(tests/gltf_external.rs): a node hierarchy mixing a matrix and TRS transforms, a
non-indexed primitive used by two nodes (one mirrored), a camera and a point light, with the
buffer embedded as a base64 data URI.

    python3 tools/gltf/pygltflib_scene.py OUT.gltf

World placement of the unit square (x, y in [0, 1], z = 0):
- root: matrix = translate (0, 1, 0) * scale 2;
- child of root: translate (1, 0, 0), rotate 180 deg about z: square -> (2 - 2x, 1 - 2y, 0);
- grandchild: translate (0, -1.5, -1), scale (1, 1, -1): square -> (2 - 2x, 4 - 2y, -2).
Camera at (0, 0, 10), yfov 0.6, aspect 1; point light at (0, 0, 5), intensity 30.
The material is double-sided: the grandchild's transform mirrors the square, which turns its
front (glTF: the winding as the determinant's sign orders it) away from the camera, and the
scene built by hand in the test has two-sided triangles.
"""

import base64
import struct
import sys

import pygltflib as g

square = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 0, 0), (1, 1, 0), (0, 1, 0)]
data = b"".join(struct.pack("<3f", *p) for p in square)
uri = "data:application/octet-stream;base64," + base64.b64encode(data).decode()

doc = g.GLTF2(
    scene=0,
    scenes=[g.Scene(nodes=[0, 3, 4])],
    nodes=[
        g.Node(name="root", matrix=[2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 0, 1, 0, 1], children=[1]),
        g.Node(name="child", mesh=0, translation=[1, 0, 0], rotation=[0, 0, 1, 0], children=[2]),
        g.Node(name="grandchild", mesh=0, translation=[0, -1.5, -1], scale=[1, 1, -1]),
        g.Node(name="camera", camera=0, translation=[0, 0, 10]),
        g.Node(name="lamp", translation=[0, 0, 5], extensions={"KHR_lights_punctual": {"light": 0}}),
    ],
    meshes=[g.Mesh(primitives=[g.Primitive(attributes=g.Attributes(POSITION=0), material=0)])],
    materials=[
        g.Material(
            pbrMetallicRoughness=g.PbrMetallicRoughness(baseColorFactor=[0.2, 0.6, 0.9, 1], metallicFactor=0),
            doubleSided=True,
        )
    ],
    cameras=[g.Camera(type="perspective", perspective=g.Perspective(yfov=0.6, aspectRatio=1.0, znear=0.1))],
    accessors=[g.Accessor(bufferView=0, componentType=g.FLOAT, count=6, type=g.VEC3, min=[0, 0, 0], max=[1, 1, 0])],
    bufferViews=[g.BufferView(buffer=0, byteLength=len(data))],
    buffers=[g.Buffer(byteLength=len(data), uri=uri)],
    extensionsUsed=["KHR_lights_punctual"],
    extensions={"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 30, "color": [1, 1, 1]}]}},
)
doc.save(sys.argv[1])
