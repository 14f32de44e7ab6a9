"""Writes glTF spheres of rough dielectric glTF materials with pygltflib (not strahl's code), for
the comparison of strahl, Cycles and a numerical reference under a uniform white world
(tests/cycles.rs, tools/dielectric_albedo.py):

    python3 tools/gltf/dielectric_sphere.py OUTDIR

Each file holds a unit UV sphere (smooth vertex normals, 256 x 128 quads) at the origin and a
perspective camera at (0, 0, DISTANCE) looking down -z (+y up, square, vertical field of view
YFOV_DEG): nearly orthographic, so that the viewing cosine mu_o on the sphere runs from 1 at the
image centre to 0 at its rim. MATERIALS are metallic 0 with the base colour and roughness
named in the file name: `black_044.gltf` is the specular layer alone; `blue_044.gltf` is the
dark blue of the Khronos ClearCoatTest's uncoated samples.
"""

import math
import os
import struct
import sys

import pygltflib as g

DISTANCE = 50.0
YFOV_DEG = 2.4
MATERIALS = {
    "black_044": ([0.0, 0.0, 0.0], 0.44),
    "blue_044": ([0.013, 0.022, 0.109], 0.44),
}
NU, NV = 256, 128


def sphere():
    """Positions (= normals) and triangle indices of the UV sphere."""
    pos = []
    for i in range(NV + 1):
        t = math.pi * i / NV
        for j in range(NU + 1):
            p = 2 * math.pi * j / NU
            pos.append((math.sin(t) * math.cos(p), math.cos(t), -math.sin(t) * math.sin(p)))
    idx = []
    for i in range(NV):
        for j in range(NU):
            a = i * (NU + 1) + j
            b = a + NU + 1
            idx += [a, b, a + 1, a + 1, b, b + 1]
    return pos, idx


def write(path, base, roughness):
    pos, idx = sphere()
    n = len(pos)
    blob = b"".join(struct.pack("<3f", *p) for p in pos)
    blob += blob
    blob += struct.pack(f"<{len(idx)}I", *idx)
    gltf = g.GLTF2(
        scene=0,
        scenes=[g.Scene(nodes=[0, 1])],
        nodes=[g.Node(mesh=0), g.Node(camera=0, translation=[0.0, 0.0, DISTANCE])],
        cameras=[
            g.Camera(
                type="perspective",
                perspective=g.Perspective(yfov=math.radians(YFOV_DEG), aspectRatio=1.0, znear=1.0),
            )
        ],
        meshes=[g.Mesh(primitives=[g.Primitive(attributes=g.Attributes(POSITION=0, NORMAL=1), indices=2, material=0)])],
        materials=[
            g.Material(
                name=os.path.splitext(os.path.basename(path))[0],
                pbrMetallicRoughness=g.PbrMetallicRoughness(
                    baseColorFactor=base + [1.0], metallicFactor=0.0, roughnessFactor=roughness
                ),
            )
        ],
        accessors=[
            g.Accessor(bufferView=0, componentType=g.FLOAT, count=n, type=g.VEC3, min=[-1, -1, -1], max=[1, 1, 1]),
            g.Accessor(bufferView=1, componentType=g.FLOAT, count=n, type=g.VEC3),
            g.Accessor(bufferView=2, componentType=g.UNSIGNED_INT, count=len(idx), type=g.SCALAR),
        ],
        bufferViews=[
            g.BufferView(buffer=0, byteOffset=0, byteLength=12 * n),
            g.BufferView(buffer=0, byteOffset=12 * n, byteLength=12 * n),
            g.BufferView(buffer=0, byteOffset=24 * n, byteLength=4 * len(idx)),
        ],
        buffers=[g.Buffer(byteLength=len(blob))],
    )
    gltf.set_binary_blob(blob)
    gltf.convert_buffers(g.BufferFormat.DATAURI)
    gltf.save(path)


def main(out):
    os.makedirs(out, exist_ok=True)
    for name, (base, roughness) in MATERIALS.items():
        write(os.path.join(out, f"{name}.gltf"), base, roughness)


if __name__ == "__main__":
    main(sys.argv[1])
