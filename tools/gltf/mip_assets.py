"""Writes a glTF file with pygltflib (not strahl's code) for strahl's mip-mapping test
(tests/mip_maps.rs):

    python3 tools/gltf/mip_assets.py OUTDIR

checker_floor.gltf: one quad, the floor y = 0 for x, z in [-HALF, HALF], facing +y, whose
material emits its texture and reflects nothing (base colour 0, emissiveFactor 1,
emissiveTexture): the 64 x 64 PNG checker.png (RGB, 8 bits) of 8 x 8 cells of 8 texels, white
(255) and black (0), so its mean is 0.5 in linear units. Its texture coordinates are
(x, z) / PERIOD, the sampler repeats, so a cell is PERIOD / 8 metres wide.

checker_floor_linear.gltf: the same, its sampler's minFilter LINEAR (9729): no mipmaps.

bumpy_floor.gltf, bumpy_floor_linear.gltf: the same floor, grey and lit by nothing, with a
normalTexture (linear) of the same checker layout whose cells tilt the normal by 40 degrees
one way or the other along the tangent (+x): texels (209, 128, 225) and (46, 128, 225), whose
mean is a normal within 0.5 degrees of the untilted one. No TANGENT: strahl takes MikkTSpace's.
"""

import base64
import os
import struct
import sys
import zlib

import pygltflib as g

SIZE = 64
CELL = 8
PERIOD = 16.0
HALF = 2000.0


def png(even=(255, 255, 255), odd=(0, 0, 0)):
    """The checker of cells `even` and `odd` (RGB) as a PNG, written with zlib alone."""
    rows = b""
    for y in range(SIZE):
        row = bytes(c for x in range(SIZE) for c in (even if (x // CELL + y // CELL) % 2 == 0 else odd))
        rows += b"\x00" + row

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    ihdr = struct.pack(">IIBBBBB", SIZE, SIZE, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b"")


def data_uri(data, mime):
    return f"data:{mime};base64," + base64.b64encode(data).decode()


def main(out):
    os.makedirs(out, exist_ok=True)
    positions = [(-HALF, 0, HALF), (HALF, 0, HALF), (HALF, 0, -HALF), (-HALF, 0, -HALF)]
    uvs = [(x / PERIOD, z / PERIOD) for x, _, z in positions]
    indices = [0, 1, 2, 0, 2, 3]
    blob = b"".join(struct.pack("<3f", *p) for p in positions)
    blob += b"".join(struct.pack("<3f", 0, 1, 0) for _ in positions)
    blob += b"".join(struct.pack("<2f", *t) for t in uvs)
    blob += struct.pack("<6H", *indices)
    views = [
        g.BufferView(buffer=0, byteOffset=0, byteLength=48),
        g.BufferView(buffer=0, byteOffset=48, byteLength=48),
        g.BufferView(buffer=0, byteOffset=96, byteLength=32),
        g.BufferView(buffer=0, byteOffset=128, byteLength=12),
    ]
    accessors = [
        g.Accessor(bufferView=0, componentType=g.FLOAT, count=4, type=g.VEC3, min=[-HALF, 0, -HALF], max=[HALF, 0, HALF]),
        g.Accessor(bufferView=1, componentType=g.FLOAT, count=4, type=g.VEC3),
        g.Accessor(bufferView=2, componentType=g.FLOAT, count=4, type=g.VEC2),
        g.Accessor(bufferView=3, componentType=g.UNSIGNED_SHORT, count=6, type=g.SCALAR),
    ]
    material = g.Material(
        doubleSided=True,
        pbrMetallicRoughness=g.PbrMetallicRoughness(baseColorFactor=[0, 0, 0, 1], metallicFactor=0, roughnessFactor=1),
        emissiveTexture=g.TextureInfo(index=0),
        emissiveFactor=[1, 1, 1],
    )
    bumpy = g.Material(
        doubleSided=True,
        pbrMetallicRoughness=g.PbrMetallicRoughness(baseColorFactor=[0.5, 0.5, 0.5, 1], metallicFactor=0, roughnessFactor=1),
        normalTexture=g.NormalMaterialTexture(index=0),
    )
    bumps = png((209, 128, 225), (46, 128, 225))
    for name, mat, image, sampler in [
        ("checker_floor.gltf", material, png(), g.Sampler(wrapS=10497, wrapT=10497)),
        ("checker_floor_linear.gltf", material, png(), g.Sampler(wrapS=10497, wrapT=10497, minFilter=9729)),
        ("bumpy_floor.gltf", bumpy, bumps, g.Sampler(wrapS=10497, wrapT=10497)),
        ("bumpy_floor_linear.gltf", bumpy, bumps, g.Sampler(wrapS=10497, wrapT=10497, minFilter=9729)),
    ]:
        write(out, name, sampler, mat, image, accessors, views, blob)


def write(out, name, sampler, material, image, accessors, views, blob):
    g.GLTF2(
        scene=0,
        scenes=[g.Scene(nodes=[0])],
        nodes=[g.Node(mesh=0)],
        meshes=[g.Mesh(primitives=[g.Primitive(attributes=g.Attributes(POSITION=0, NORMAL=1, TEXCOORD_0=2), indices=3, material=0)])],
        materials=[material],
        textures=[g.Texture(source=0, sampler=0)],
        samplers=[sampler],
        images=[g.Image(uri=data_uri(image, "image/png"))],
        accessors=accessors,
        bufferViews=views,
        buffers=[g.Buffer(byteLength=len(blob), uri=data_uri(blob, "application/octet-stream"))],
    ).save(os.path.join(out, name))


if __name__ == "__main__":
    main(sys.argv[1])
