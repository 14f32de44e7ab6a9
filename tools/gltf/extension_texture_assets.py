"""Writes small glTF files with pygltflib (not strahl's code) for the tests of the material
extensions' textures (tests/gltf_extension_textures.rs):

    python3 tools/gltf/extension_texture_assets.py OUTDIR

Every file holds a quad, x and y in [-1, 1] at z = 0 facing +z, with glTF texture coordinates
(0, 0) at its top-left corner (-1, 1) and (1, 1) at its bottom-right (1, -1); TEXCOORD_1, where
a file has it, is TEXCOORD_0 mirrored left to right (u -> 1 - u).

For each case in CASES, two files:

- CASE.gltf: one material whose extension texture is a 4 x 4 PNG (RGBA, 8 bits, embedded as a
  data: URI) with its left half LEFT and its right half RIGHT (texels as bytes), times the
  extension's factors FACTORS;
- CASE_twin.gltf: the same quad cut at x = 0 into two primitives, the left one with the
  material's factors set to what the texture's left half gives (LEFT_FACTORS), the right one to
  what its right half gives (RIGHT_FACTORS), and no extension texture.

A renderer that applies the texture renders the two files alike. Besides:

- thickness.gltf: KHR_materials_volume with a thicknessTexture (which ray tracers ignore).
- bad_index.gltf: a clearcoatTexture naming texture 7 of a file with one texture.
- shared.gltf: specularTexture, sheenRoughnessTexture (both alpha) and clearcoatTexture,
  clearcoatRoughnessTexture (both linear) naming the same image, and a clearcoatNormalTexture.
- transmission_texcoord1.gltf, transmission_transform_texcoord1.gltf, transmission_texcoord2.gltf,
  transmission_transform.gltf: the transmission case's texture read through texCoord 1, through
  KHR_texture_transform's texCoord 1, through texCoord 2, and with an offset and scale.

values.json holds CASES for the test.
"""

import base64
import json
import os
import struct
import sys
import zlib

import pygltflib as g


def srgb_to_linear(c):
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4


def png(left, right):
    """A 4 x 4 RGBA PNG, its two left columns `left`, its two right columns `right`."""
    rows = b""
    for _ in range(4):
        rows += b"\x00" + bytes(left) * 2 + bytes(right) * 2

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    ihdr = struct.pack(">IIBBBBB", 4, 4, 8, 6, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b"")


def data_uri(data, mime):
    return f"data:{mime};base64," + base64.b64encode(data).decode()


def mesh_file(parts, materials, images=(), extensions_used=()):
    """`parts`: per primitive, its x range (x0, x1); the quad's y runs over [-1, 1]."""
    blob = b""
    views, accessors, primitives = [], [], []

    def add(data, **accessor):
        nonlocal blob
        views.append(g.BufferView(buffer=0, byteOffset=len(blob), byteLength=len(data)))
        accessors.append(g.Accessor(bufferView=len(views) - 1, **accessor))
        blob += data + b"\x00" * (-len(data) % 4)
        return len(accessors) - 1

    for i, (x0, x1) in enumerate(parts):
        positions = [(x0, -1, 0), (x1, -1, 0), (x1, 1, 0), (x0, 1, 0)]
        uvs = [((x + 1) / 2, (1 - y) / 2) for x, y, _ in positions]
        mirrored = [(1 - u, v) for u, v in uvs]
        p = add(
            b"".join(struct.pack("<3f", *q) for q in positions),
            componentType=g.FLOAT,
            count=4,
            type=g.VEC3,
            min=[x0, -1, 0],
            max=[x1, 1, 0],
        )
        t0 = add(b"".join(struct.pack("<2f", *t) for t in uvs), componentType=g.FLOAT, count=4, type=g.VEC2)
        t1 = add(b"".join(struct.pack("<2f", *t) for t in mirrored), componentType=g.FLOAT, count=4, type=g.VEC2)
        idx = add(struct.pack("<6H", 0, 1, 2, 0, 2, 3), componentType=g.UNSIGNED_SHORT, count=6, type=g.SCALAR)
        attributes = g.Attributes(POSITION=p, TEXCOORD_0=t0, TEXCOORD_1=t1)
        primitives.append(g.Primitive(attributes=attributes, indices=idx, material=i % len(materials)))
    return g.GLTF2(
        scene=0,
        scenes=[g.Scene(nodes=[0])],
        nodes=[g.Node(mesh=0)],
        meshes=[g.Mesh(primitives=primitives)],
        materials=materials,
        textures=[g.Texture(source=i, sampler=0) for i in range(len(images))],
        samplers=[g.Sampler(wrapS=33071, wrapT=33071)],
        images=[g.Image(uri=data_uri(data, "image/png")) for data in images],
        accessors=accessors,
        bufferViews=views,
        buffers=[g.Buffer(byteLength=len(blob), uri=data_uri(blob, "application/octet-stream"))],
        extensionsUsed=list(extensions_used),
    )


def material(base, extension, values, texture=None):
    """A dielectric of base colour `base` (roughness 0.5) with `extension` = `values`, plus
    `texture` = (key, textureInfo) in it."""
    ext = dict(values)
    if texture:
        ext[texture[0]] = texture[1]
    extensions = {extension: ext}
    if extension == "KHR_materials_specular":
        extensions["KHR_materials_ior"] = {"ior": 2.0}  # F0 = 1/9: a brighter highlight
    return g.Material(
        doubleSided=True,
        pbrMetallicRoughness=g.PbrMetallicRoughness(baseColorFactor=base + [1], metallicFactor=0, roughnessFactor=0.5),
        extensions=extensions,
    )


def lin(byte):
    return byte / 255


def srgb(byte):
    return srgb_to_linear(byte / 255)


# name: extension, texture key, base colour, factors, texel bytes (RGBA) left and right, and the
# factors those texels give; `tex_coord` 1 reads TEXCOORD_1 (mirrored), so left and right trade.
CASES = {
    "transmission": dict(
        extension="KHR_materials_transmission",
        key="transmissionTexture",
        base=[1.0, 1.0, 1.0],
        factors={"transmissionFactor": 1.0},
        left=[0, 255, 255, 255],
        right=[255, 0, 0, 0],
        left_factors={"transmissionFactor": 0.0},
        right_factors={"transmissionFactor": 1.0},
    ),
    "specular": dict(
        extension="KHR_materials_specular",
        key="specularTexture",
        base=[0.0, 0.0, 0.0],
        factors={"specularFactor": 1.0},
        left=[255, 255, 255, 0],
        right=[0, 0, 0, 255],
        left_factors={"specularFactor": 0.0},
        right_factors={"specularFactor": 1.0},
    ),
    "specular_color": dict(
        extension="KHR_materials_specular",
        key="specularColorTexture",
        base=[0.0, 0.0, 0.0],
        factors={"specularColorFactor": [1.0, 1.0, 1.0]},
        left=[128, 64, 255, 0],
        right=[255, 200, 30, 0],
        left_factors={"specularColorFactor": [srgb(128), srgb(64), 1.0]},
        right_factors={"specularColorFactor": [1.0, srgb(200), srgb(30)]},
    ),
    "clearcoat": dict(
        extension="KHR_materials_clearcoat",
        key="clearcoatTexture",
        base=[0.5, 0.5, 0.5],
        factors={"clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 0.3},
        left=[0, 255, 255, 255],
        right=[255, 0, 0, 0],
        left_factors={"clearcoatFactor": 0.0, "clearcoatRoughnessFactor": 0.3},
        right_factors={"clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 0.3},
    ),
    "clearcoat_roughness": dict(
        extension="KHR_materials_clearcoat",
        key="clearcoatRoughnessTexture",
        base=[0.5, 0.5, 0.5],
        factors={"clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 0.8},
        left=[255, 64, 255, 255],
        right=[0, 255, 0, 0],
        left_factors={"clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 0.8 * lin(64)},
        right_factors={"clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 0.8},
    ),
    "sheen_color": dict(
        extension="KHR_materials_sheen",
        key="sheenColorTexture",
        base=[0.2, 0.2, 0.2],
        factors={"sheenColorFactor": [1.0, 1.0, 1.0], "sheenRoughnessFactor": 1.0},
        left=[0, 0, 0, 255],
        right=[255, 128, 64, 0],
        left_factors={"sheenColorFactor": [0.0, 0.0, 0.0], "sheenRoughnessFactor": 1.0},
        right_factors={"sheenColorFactor": [1.0, srgb(128), srgb(64)], "sheenRoughnessFactor": 1.0},
    ),
    "sheen_roughness": dict(
        extension="KHR_materials_sheen",
        key="sheenRoughnessTexture",
        base=[0.2, 0.2, 0.2],
        factors={"sheenColorFactor": [1.0, 1.0, 1.0], "sheenRoughnessFactor": 1.0},
        left=[255, 255, 255, 51],
        right=[0, 0, 0, 255],
        left_factors={"sheenColorFactor": [1.0, 1.0, 1.0], "sheenRoughnessFactor": lin(51)},
        right_factors={"sheenColorFactor": [1.0, 1.0, 1.0], "sheenRoughnessFactor": 1.0},
    ),
}


def write_case(out, name, case, tex_coord=0, transform=None):
    info = {"index": 0}
    if tex_coord:
        info["texCoord"] = tex_coord
    used = [case["extension"]]
    if case["extension"] == "KHR_materials_specular":
        used.append("KHR_materials_ior")
    if transform:
        info["extensions"] = {"KHR_texture_transform": transform}
        used.append("KHR_texture_transform")
    textured = material(case["base"], case["extension"], case["factors"], (case["key"], info))
    image = png(case["left"], case["right"])
    mesh_file([(-1, 1)], [textured], [image], used).save(os.path.join(out, f"{name}.gltf"))


def main(out):
    os.makedirs(out, exist_ok=True)
    for name, case in CASES.items():
        write_case(out, name, case)
        left = material(case["base"], case["extension"], case["left_factors"])
        right = material(case["base"], case["extension"], case["right_factors"])
        used = [case["extension"]] + (["KHR_materials_ior"] if case["extension"] == "KHR_materials_specular" else [])
        mesh_file([(-1, 0), (0, 1)], [left, right], (), used).save(os.path.join(out, f"{name}_twin.gltf"))

    # The texture read through TEXCOORD_1 (mirrored: left and right trade places), and through
    # KHR_texture_transform's texCoord, which overrides the textureInfo's.
    write_case(out, "transmission_texcoord1", CASES["transmission"], tex_coord=1)
    write_case(out, "transmission_transform_texcoord1", CASES["transmission"], transform={"texCoord": 1})
    # texCoord 2: a set strahl does not read; TEXCOORD_0 is read instead (with a warning).
    write_case(out, "transmission_texcoord2", CASES["transmission"], tex_coord=2)
    # KHR_texture_transform: u' = 0.25 u + 0.75 shows the texture's right half over the whole
    # quad (u' from 0.75, the centre of the third texel column, to 1).
    write_case(
        out, "transmission_transform", CASES["transmission"], transform={"offset": [0.75, 0], "scale": [0.25, 1]}
    )

    volume = material(
        [1.0, 1.0, 1.0],
        "KHR_materials_volume",
        {"thicknessFactor": 0.5, "attenuationColor": [0.5, 0.5, 0.5], "attenuationDistance": 1.0},
        ("thicknessTexture", {"index": 0}),
    )
    volume.extensions["KHR_materials_transmission"] = {"transmissionFactor": 1.0}
    mesh_file(
        [(-1, 1)],
        [volume],
        [png([0, 0, 0, 255], [0, 255, 0, 255])],
        ["KHR_materials_volume", "KHR_materials_transmission"],
    ).save(os.path.join(out, "thickness.gltf"))

    bad = material([0.5, 0.5, 0.5], "KHR_materials_clearcoat", {"clearcoatFactor": 1.0}, ("clearcoatTexture", {"index": 7}))
    mesh_file([(-1, 1)], [bad], [png([0] * 4, [255] * 4)], ["KHR_materials_clearcoat"]).save(
        os.path.join(out, "bad_index.gltf")
    )

    shared = material(
        [0.5, 0.5, 0.5],
        "KHR_materials_clearcoat",
        {
            "clearcoatFactor": 1.0,
            "clearcoatRoughnessFactor": 1.0,
            "clearcoatTexture": {"index": 0},
            "clearcoatRoughnessTexture": {"index": 0},
            "clearcoatNormalTexture": {"index": 0},
        },
    )
    shared.extensions["KHR_materials_sheen"] = {
        "sheenColorFactor": [1, 1, 1],
        "sheenRoughnessFactor": 1.0,
        "sheenRoughnessTexture": {"index": 0},
    }
    shared.extensions["KHR_materials_specular"] = {"specularTexture": {"index": 0}}
    mesh_file(
        [(-1, 1)],
        [shared],
        [png([10, 20, 30, 40], [50, 60, 70, 80])],
        ["KHR_materials_clearcoat", "KHR_materials_sheen", "KHR_materials_specular"],
    ).save(os.path.join(out, "shared.gltf"))

    json.dump(CASES, open(os.path.join(out, "values.json"), "w"), indent=1)


if __name__ == "__main__":
    main(sys.argv[1])
