"""Writes small glTF files with pygltflib (not strahl's code) for strahl's glTF geometry tests
(tests/gltf_geo.rs), each with its buffer embedded as a base64 data URI:

    python3 tools/gltf/geometry_cases.py OUT_DIR

- instancing.gltf: a box of half-size 0.25 (12 triangles) placed by one node with
  EXT_mesh_gpu_instancing 125 times on a 25 x 5 grid in the plane z = 0: instance k = 25 j + i
  at translation (i - 12, j - 2, 0), rotated 30 k degrees about z, scaled by
  s_k = 1 + (k % 3) / 4 in z only; the node itself is translated by (0, 0, -1). The box's front
  face is then at z = -1 + 0.25 s_k. Camera at (0, 0, 20), yfov 0.9, aspect 4.
- morph.gltf: the triangle (0,0,0), (1,0,0), (0,1,0) with two morph targets: target 0 moves
  every vertex by (0, 0, 1); target 1 is sparse (no bufferView: zeros, then vertex 1 moved by
  (0, 0.5, 0)). mesh.weights = [0.5, 1]. Node "own" (translation (-3, 0, 0)) uses the mesh's
  weights; node "override" (translation (3, 0, 0)) has weights [1, 0].
- modes.gltf: one mesh, three primitives: a TRIANGLE_STRIP of 4 vertices (the square
  [0,1]^2 at z = 0, two triangles); a TRIANGLE_FAN of 8 vertices (a regular hexagon of radius 1
  centred at (3, 0, 0) closed back on its first rim vertex: 6 triangles); and a TRIANGLES
  primitive whose POSITION is a sparse accessor over a base view (the triangle (0,0,-1),
  (1,0,-1), (0,1,-1) with vertex 2 replaced by (0, 2, -1)). All wound counter-clockwise seen
  from +z.
- ortho.gltf: an orthographic camera (xmag 2, ymag 1) at (0, 0, 5) looking along -z over the
  square [-10, 10]^2 at z = 0 and the rectangle [0, 2] x [0, 1] at z = 1 (the top-right
  quarter of the view), with a point light at (0, 0, 10).
"""

import base64
import json
import math
import os
import struct
import sys

import pygltflib as g

out_dir = sys.argv[1]


class Doc:
    def __init__(self):
        self.data = b""
        self.views = []
        self.accessors = []

    def view(self, raw):
        while len(self.data) % 4:
            self.data += b"\0"
        self.views.append(g.BufferView(buffer=0, byteOffset=len(self.data), byteLength=len(raw)))
        self.data += raw
        return len(self.views) - 1

    def floats(self, rows, kind):
        width = len(rows[0])
        raw = b"".join(struct.pack("<%df" % width, *r) for r in rows)
        lo = [min(r[c] for r in rows) for c in range(width)]
        hi = [max(r[c] for r in rows) for c in range(width)]
        self.accessors.append(
            g.Accessor(bufferView=self.view(raw), componentType=g.FLOAT, count=len(rows), type=kind, min=lo, max=hi)
        )
        return len(self.accessors) - 1

    def indices(self, idx):
        raw = struct.pack("<%dH" % len(idx), *idx)
        self.accessors.append(g.Accessor(bufferView=self.view(raw), componentType=g.UNSIGNED_SHORT, count=len(idx), type=g.SCALAR))
        return len(self.accessors) - 1

    def sparse(self, count, base_view, replaced, bounds=(None, None)):
        """A VEC3 float accessor of `count` elements: `base_view` (or zeros), `replaced` = {index: xyz};
        `bounds` its (min, max), which POSITION accessors must give."""
        keys = sorted(replaced)
        iv = self.view(struct.pack("<%dH" % len(keys), *keys))
        vv = self.view(b"".join(struct.pack("<3f", *replaced[k]) for k in keys))
        self.accessors.append(
            g.Accessor(
                bufferView=base_view,
                componentType=g.FLOAT,
                count=count,
                type=g.VEC3,
                min=bounds[0],
                max=bounds[1],
                sparse=g.Sparse(
                    count=len(keys),
                    indices=g.AccessorSparseIndices(bufferView=iv, componentType=g.UNSIGNED_SHORT),
                    values=g.AccessorSparseValues(bufferView=vv),
                ),
            )
        )
        return len(self.accessors) - 1

    def save(self, name, patch=None, **fields):
        uri = "data:application/octet-stream;base64," + base64.b64encode(self.data).decode()
        doc = g.GLTF2(
            scene=0,
            accessors=self.accessors,
            bufferViews=self.views,
            buffers=[g.Buffer(byteLength=len(self.data), uri=uri)],
            **fields,
        )
        path = os.path.join(out_dir, name)
        doc.save(path)
        if patch:  # what pygltflib has no field for, written into the JSON
            with open(path) as f:
                js = json.load(f)
            patch(js)
            with open(path, "w") as f:
                json.dump(js, f)


def box(d, h):
    p = [(x, y, z) for z in (-h, h) for y in (-h, h) for x in (-h, h)]
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    idx = [i for a, b, c, e in quads for i in (a, b, c, a, c, e)]
    return d.floats(p, g.VEC3), d.indices(idx)


def instancing():
    d = Doc()
    pos, idx = box(d, 0.25)
    t, r, s = [], [], []
    for k in range(125):
        i, j = k % 25, k // 25
        t.append((i - 12.0, j - 2.0, 0.0))
        a = math.radians(30 * k) / 2
        r.append((0.0, 0.0, math.sin(a), math.cos(a)))
        s.append((1.0, 1.0, 1 + (k % 3) / 4))
    ta, ra, sa = d.floats(t, g.VEC3), d.floats(r, g.VEC4), d.floats(s, g.VEC3)
    ext = {"EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": ta, "ROTATION": ra, "SCALE": sa}}}
    d.save(
        "instancing.gltf",
        scenes=[g.Scene(nodes=[0, 1])],
        nodes=[
            g.Node(name="boxes", mesh=0, translation=[0, 0, -1], extensions=ext),
            g.Node(name="camera", camera=0, translation=[0, 0, 20]),
        ],
        meshes=[g.Mesh(primitives=[g.Primitive(attributes=g.Attributes(POSITION=pos), indices=idx)])],
        cameras=[g.Camera(type="perspective", perspective=g.Perspective(yfov=0.9, aspectRatio=4.0, znear=0.1))],
        extensionsUsed=["EXT_mesh_gpu_instancing"],
        extensionsRequired=["EXT_mesh_gpu_instancing"],
    )


def morph():
    d = Doc()
    pos = d.floats([(0, 0, 0), (1, 0, 0), (0, 1, 0)], g.VEC3)
    up = d.floats([(0, 0, 1)] * 3, g.VEC3)
    sparse = d.sparse(3, None, {1: (0.0, 0.5, 0.0)})
    prim = g.Primitive(attributes=g.Attributes(POSITION=pos), targets=[{"POSITION": up}, {"POSITION": sparse}])
    d.save(
        "morph.gltf",
        scenes=[g.Scene(nodes=[0, 1])],
        nodes=[
            g.Node(name="own", mesh=0, translation=[-3, 0, 0]),
            g.Node(name="override", mesh=0, translation=[3, 0, 0]),
        ],
        patch=lambda js: js["nodes"][1].update(weights=[1.0, 0.0]),
        meshes=[g.Mesh(primitives=[prim], weights=[0.5, 1.0])],
    )


def modes():
    d = Doc()
    strip = d.floats([(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0)], g.VEC3)
    rim = [(3 + math.cos(math.radians(60 * i)), math.sin(math.radians(60 * i)), 0.0) for i in range(7)]
    fan = d.floats([(3.0, 0.0, 0.0)] + rim, g.VEC3)
    base = d.view(struct.pack("<9f", 0, 0, -1, 1, 0, -1, 0, 1, -1))
    sparse = d.sparse(3, base, {2: (0.0, 2.0, -1.0)}, ([0, 0, -1], [1, 2, -1]))
    d.save(
        "modes.gltf",
        scenes=[g.Scene(nodes=[0])],
        nodes=[g.Node(name="modes", mesh=0)],
        meshes=[
            g.Mesh(
                primitives=[
                    g.Primitive(attributes=g.Attributes(POSITION=strip), mode=g.TRIANGLE_STRIP),
                    g.Primitive(attributes=g.Attributes(POSITION=fan), mode=g.TRIANGLE_FAN),
                    g.Primitive(attributes=g.Attributes(POSITION=sparse), mode=g.TRIANGLES),
                ]
            )
        ],
    )


def ortho():
    d = Doc()
    quad = [0, 1, 2, 0, 2, 3]
    floor = d.floats([(-10, -10, 0), (10, -10, 0), (10, 10, 0), (-10, 10, 0)], g.VEC3)
    fi = d.indices(quad)
    card = d.floats([(0, 0, 1), (2, 0, 1), (2, 1, 1), (0, 1, 1)], g.VEC3)
    ci = d.indices(quad)
    d.save(
        "ortho.gltf",
        scenes=[g.Scene(nodes=[0, 1, 2, 3])],
        nodes=[
            g.Node(name="floor", mesh=0),
            g.Node(name="card", mesh=1),
            g.Node(name="camera", camera=0, translation=[0, 0, 5]),
            g.Node(name="lamp", translation=[0, 0, 10], extensions={"KHR_lights_punctual": {"light": 0}}),
        ],
        meshes=[
            g.Mesh(primitives=[g.Primitive(attributes=g.Attributes(POSITION=floor), indices=fi)]),
            g.Mesh(primitives=[g.Primitive(attributes=g.Attributes(POSITION=card), indices=ci)]),
        ],
        cameras=[g.Camera(type="orthographic", orthographic=g.Orthographic(xmag=2.0, ymag=1.0, znear=0.0, zfar=100.0))],
        extensionsUsed=["KHR_lights_punctual"],
        extensions={"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 100, "color": [1, 1, 1]}]}},
    )


instancing()
morph()
ortho()
modes()
