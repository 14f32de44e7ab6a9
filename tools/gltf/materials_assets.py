"""Writes small glTF files with pygltflib (not strahl's code) for strahl's material tests
(tests/materials_gltf.rs):

    python3 tools/gltf/materials_assets.py OUTDIR

Every file holds one quad, x and y in [-1, 1] at z = 0 facing +z, with glTF texture
coordinates (0, 0) at its top-left corner (-1, 1) and (1, 1) at its bottom-right (1, -1), and
every image is the 4 x 4 PNG `quadrants.png` (RGB, 8 bits) whose 2 x 2 quadrants are
QUADRANTS below (top-left, top-right, bottom-left, bottom-right), embedded as a data: URI.

- metal_texture.gltf: metallic 1, roughness 0, baseColorFactor BASE, baseColorTexture, and
  COLOR_0 = VERTEX_COLOR at every vertex.
- emissive_texture.gltf: base colour 0, emissiveTexture, emissiveFactor EMISSIVE,
  KHR_materials_emissive_strength STRENGTH.
- extensions.gltf: KHR_materials_clearcoat (factor 0.5, roughness 0.25, with a
  clearcoatTexture), KHR_materials_sheen (colour (0.2, 0.3, 0.4), roughness 0.6),
  KHR_materials_specular (with a specularTexture), KHR_materials_volume, KHR_materials_iridescence
  (which strahl does not render), an occlusionTexture.
- metal_roughness_texture.gltf: base colour 0.5, metallic factor 1, roughness factor 1, a
  metallicRoughnessTexture (linear) whose quadrants give (G roughness, B metalness) =
  MR_QUADRANTS: a rough dielectric, a smooth metal, a rough metal, a smooth half metal.
- transform_offset_scale.gltf, transform_rotation.gltf: a baseColorTexture with
  KHR_texture_transform offset (0.5, 0) and scale 0.5 (the image's top-right quadrant over the
  whole quad), or offset (0, 1) and rotation pi/2 (u' = v, v' = 1 - u in glTF's coordinates).
"""

import base64
import json
import math
import os
import struct
import sys
import zlib

import pygltflib as g

QUADRANTS = [(255, 0, 0), (0, 128, 0), (0, 0, 64), (200, 200, 200)]
MR_QUADRANTS = [(0, 255, 0), (0, 0, 255), (0, 255, 255), (0, 0, 128)]
BASE = [0.9, 0.8, 0.7]
VERTEX_COLOR = [1.0, 0.5, 0.25]
EMISSIVE = [0.5, 1.0, 0.25]
STRENGTH = 4.0


def png(quadrants):
    """A 4 x 4 RGB PNG, each 2 x 2 quadrant one colour, written with zlib alone."""
    rows = b""
    for y in range(4):
        rows += b"\x00" + b"".join(bytes(quadrants[(y // 2) * 2 + x // 2]) for x in range(4))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    ihdr = struct.pack(">IIBBBBB", 4, 4, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b"")


def data_uri(data, mime):
    return f"data:{mime};base64," + base64.b64encode(data).decode()


def quad(material, images, colors=False, extensions_used=()):
    positions = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
    uvs = [(0, 1), (1, 1), (1, 0), (0, 0)]
    indices = [0, 1, 2, 0, 2, 3]
    blob = b"".join(struct.pack("<3f", *p) for p in positions)
    blob += b"".join(struct.pack("<2f", *t) for t in uvs)
    blob += b"".join(struct.pack("<3f", *VERTEX_COLOR) for _ in positions)
    blob += struct.pack("<6H", *indices)
    views = [
        g.BufferView(buffer=0, byteOffset=0, byteLength=48),
        g.BufferView(buffer=0, byteOffset=48, byteLength=32),
        g.BufferView(buffer=0, byteOffset=80, byteLength=48),
        g.BufferView(buffer=0, byteOffset=128, byteLength=12),
    ]
    accessors = [
        g.Accessor(bufferView=0, componentType=g.FLOAT, count=4, type=g.VEC3, min=[-1, -1, 0], max=[1, 1, 0]),
        g.Accessor(bufferView=1, componentType=g.FLOAT, count=4, type=g.VEC2),
        g.Accessor(bufferView=2, componentType=g.FLOAT, count=4, type=g.VEC3),
        g.Accessor(bufferView=3, componentType=g.UNSIGNED_SHORT, count=6, type=g.SCALAR),
    ]
    attributes = g.Attributes(POSITION=0, TEXCOORD_0=1, COLOR_0=2 if colors else None)
    return g.GLTF2(
        scene=0,
        scenes=[g.Scene(nodes=[0])],
        nodes=[g.Node(mesh=0)],
        meshes=[g.Mesh(primitives=[g.Primitive(attributes=attributes, indices=3, material=0)])],
        materials=[material],
        textures=[g.Texture(source=i, sampler=0) for i in range(len(images))],
        samplers=[g.Sampler(wrapS=33071, wrapT=33071)],
        images=[g.Image(uri=data_uri(png(q), "image/png")) for q in images],
        accessors=accessors,
        bufferViews=views,
        buffers=[g.Buffer(byteLength=len(blob), uri=data_uri(blob, "application/octet-stream"))],
        extensionsUsed=list(extensions_used),
    )


def main(out):
    os.makedirs(out, exist_ok=True)
    with open(os.path.join(out, "quadrants.png"), "wb") as f:
        f.write(png(QUADRANTS))

    metal = g.Material(
        doubleSided=True,
        pbrMetallicRoughness=g.PbrMetallicRoughness(
            baseColorFactor=BASE + [1], baseColorTexture=g.TextureInfo(index=0), metallicFactor=1, roughnessFactor=0
        )
    )
    quad(metal, [QUADRANTS], colors=True).save(os.path.join(out, "metal_texture.gltf"))

    emissive = g.Material(
        doubleSided=True,
        pbrMetallicRoughness=g.PbrMetallicRoughness(baseColorFactor=[0, 0, 0, 1], metallicFactor=0, roughnessFactor=1),
        emissiveTexture=g.TextureInfo(index=0),
        emissiveFactor=EMISSIVE,
        extensions={"KHR_materials_emissive_strength": {"emissiveStrength": STRENGTH}},
    )
    quad(emissive, [QUADRANTS], extensions_used=["KHR_materials_emissive_strength"]).save(
        os.path.join(out, "emissive_texture.gltf")
    )

    many = g.Material(
        doubleSided=True,
        pbrMetallicRoughness=g.PbrMetallicRoughness(baseColorFactor=[0.5, 0.5, 0.5, 1], metallicFactor=0),
        occlusionTexture=g.OcclusionTextureInfo(index=0),
        extensions={
            "KHR_materials_clearcoat": {
                "clearcoatFactor": 0.5,
                "clearcoatRoughnessFactor": 0.25,
                "clearcoatTexture": {"index": 0},
            },
            "KHR_materials_sheen": {"sheenColorFactor": [0.2, 0.3, 0.4], "sheenRoughnessFactor": 0.6},
            "KHR_materials_specular": {"specularFactor": 0.7, "specularTexture": {"index": 0}},
            "KHR_materials_volume": {
                "thicknessFactor": 0.1,
                "attenuationColor": [0.5, 0.25, 1.0],
                "attenuationDistance": 2.0,
            },
            "KHR_materials_iridescence": {"iridescenceFactor": 1.0},
        },
    )
    used = [
        "KHR_materials_clearcoat",
        "KHR_materials_sheen",
        "KHR_materials_specular",
        "KHR_materials_volume",
        "KHR_materials_iridescence",
    ]
    quad(many, [QUADRANTS], extensions_used=used).save(os.path.join(out, "extensions.gltf"))

    mr = g.Material(
        doubleSided=True,
        pbrMetallicRoughness=g.PbrMetallicRoughness(
            baseColorFactor=[0.5, 0.5, 0.5, 1],
            metallicFactor=1,
            roughnessFactor=1,
            metallicRoughnessTexture=g.TextureInfo(index=0),
        )
    )
    quad(mr, [MR_QUADRANTS]).save(os.path.join(out, "metal_roughness_texture.gltf"))

    for name, transform in [
        ("transform_offset_scale.gltf", {"offset": [0.5, 0], "scale": [0.5, 0.5]}),
        ("transform_rotation.gltf", {"offset": [0, 1], "rotation": math.pi / 2}),
    ]:
        info = g.TextureInfo(index=0, extensions={"KHR_texture_transform": transform})
        m = g.Material(
            doubleSided=True,
            pbrMetallicRoughness=g.PbrMetallicRoughness(baseColorTexture=info, metallicFactor=0, roughnessFactor=1),
        )
        quad(m, [QUADRANTS], extensions_used=["KHR_texture_transform"]).save(os.path.join(out, name))

    json.dump(
        {"quadrants": QUADRANTS, "base": BASE, "vertex_color": VERTEX_COLOR, "emissive": EMISSIVE, "strength": STRENGTH},
        open(os.path.join(out, "values.json"), "w"),
    )


if __name__ == "__main__":
    main(sys.argv[1])
