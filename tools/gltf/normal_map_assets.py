"""Writes small glTF files with pygltflib (not strahl's code) for strahl's normal-map tests
(tests/normal_maps.rs):

    python3 tools/gltf/normal_map_assets.py OUTDIR

Every file holds one quad, x and y in [-1, 1] at z = 0 facing +z (NORMAL (0, 0, 1)), with glTF
texture coordinates (0, 0) at its top-left corner (-1, 1) and (1, 1) at its bottom-right
(1, -1): u grows along +x and the image's "up" (decreasing glTF v) along +y. Its material is
a pure Lambertian reflector (base colour ALBEDO, metallic 0, roughness 1,
KHR_materials_specular specularFactor 0) with a normalTexture: the 2 x 2 PNG `flat.png`
(RGB, 8 bits) whose four texels are all TEXEL, the tangent-space normal
(2 TEXEL / 255 - 1) tilted from +z (T = +x, B = +y on this quad).

- tangent.gltf: TANGENT (1, 0, 0, 1) given at every vertex, normalTexture scale 1.
- mikktspace.gltf: the same without TANGENT (MikkTSpace computes it).
- scale0.gltf: without TANGENT, normalTexture scale 0 (unperturbed).
- flipped.gltf: TANGENT (1, 0, 0, -1) (the bitangent reversed, B = -y).
"""

import base64
import os
import struct
import sys
import zlib

import pygltflib as g

ALBEDO = 0.5
TEXEL = (166, 191, 223)


def png(texel):
    """A 2 x 2 RGB PNG of one colour, written with zlib alone."""
    rows = b"".join(b"\x00" + bytes(texel) * 2 for _ in range(2))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    ihdr = struct.pack(">IIBBBBB", 2, 2, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b"")


def data_uri(data, mime):
    return f"data:{mime};base64," + base64.b64encode(data).decode()


def quad(tangent_w=None, scale=1.0):
    positions = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
    uvs = [(0, 1), (1, 1), (1, 0), (0, 0)]
    indices = [0, 1, 2, 0, 2, 3]
    blob = b"".join(struct.pack("<3f", *p) for p in positions)
    blob += b"".join(struct.pack("<3f", 0, 0, 1) for _ in positions)
    blob += b"".join(struct.pack("<2f", *t) for t in uvs)
    blob += b"".join(struct.pack("<4f", 1, 0, 0, tangent_w or 1) for _ in positions)
    blob += struct.pack("<6H", *indices)
    views = [
        g.BufferView(buffer=0, byteOffset=0, byteLength=48),
        g.BufferView(buffer=0, byteOffset=48, byteLength=48),
        g.BufferView(buffer=0, byteOffset=96, byteLength=32),
        g.BufferView(buffer=0, byteOffset=128, byteLength=64),
        g.BufferView(buffer=0, byteOffset=192, byteLength=12),
    ]
    accessors = [
        g.Accessor(bufferView=0, componentType=g.FLOAT, count=4, type=g.VEC3, min=[-1, -1, 0], max=[1, 1, 0]),
        g.Accessor(bufferView=1, componentType=g.FLOAT, count=4, type=g.VEC3),
        g.Accessor(bufferView=2, componentType=g.FLOAT, count=4, type=g.VEC2),
        g.Accessor(bufferView=3, componentType=g.FLOAT, count=4, type=g.VEC4),
        g.Accessor(bufferView=4, componentType=g.UNSIGNED_SHORT, count=6, type=g.SCALAR),
    ]
    attributes = g.Attributes(POSITION=0, NORMAL=1, TEXCOORD_0=2, TANGENT=3 if tangent_w else None)
    material = g.Material(
        doubleSided=True,
        pbrMetallicRoughness=g.PbrMetallicRoughness(
            baseColorFactor=[ALBEDO, ALBEDO, ALBEDO, 1], metallicFactor=0, roughnessFactor=1
        ),
        normalTexture=g.NormalMaterialTexture(index=0, scale=scale),
        extensions={"KHR_materials_specular": {"specularFactor": 0}},
    )
    return g.GLTF2(
        scene=0,
        scenes=[g.Scene(nodes=[0])],
        nodes=[g.Node(mesh=0)],
        meshes=[g.Mesh(primitives=[g.Primitive(attributes=attributes, indices=4, material=0)])],
        materials=[material],
        textures=[g.Texture(source=0, sampler=0)],
        samplers=[g.Sampler(wrapS=33071, wrapT=33071)],
        images=[g.Image(uri=data_uri(png(TEXEL), "image/png"))],
        accessors=accessors,
        bufferViews=views,
        buffers=[g.Buffer(byteLength=len(blob), uri=data_uri(blob, "application/octet-stream"))],
        extensionsUsed=["KHR_materials_specular"],
    )


def main(out):
    os.makedirs(out, exist_ok=True)
    quad(tangent_w=1).save(os.path.join(out, "tangent.gltf"))
    quad().save(os.path.join(out, "mikktspace.gltf"))
    quad(scale=0.0).save(os.path.join(out, "scale0.gltf"))
    quad(tangent_w=-1).save(os.path.join(out, "flipped.gltf"))


if __name__ == "__main__":
    main(sys.argv[1])
