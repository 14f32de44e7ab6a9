"""Writes small glTF files with pygltflib (not strahl's code) for strahl's alpha and
doubleSided tests (tests/gltf_alpha.rs):

    python3 tools/gltf/alpha_assets.py OUTDIR

Every file holds one quad, x and y in [-1, 1] at z = 0 facing +z (counter-clockwise seen
from +z), with glTF texture coordinates (0, 0) at its top-left corner (-1, 1) and (1, 1) at
its bottom-right (1, -1). Its base colour is black; the `_lit` files emit EMISSION (so a
camera sees exactly EMISSION where the quad is), the `_sheet` files emit nothing (shadow
casters).

- mask_*.gltf: alphaMode MASK, alphaCutoff CUTOFF, baseColorFactor alpha 1, COLOR_0 alpha
  VERTEX_ALPHA at every vertex, and a baseColorTexture: the 4 x 4 RGBA PNG whose 2 x 2
  quadrants (top-left, top-right, bottom-left, bottom-right) have alpha MASK_ALPHA / 255.
  So alpha = VERTEX_ALPHA * MASK_ALPHA / 255 = 0.7, 0, 0.56, 0.7: the top-left and
  bottom-right quadrants are there, the others are holes (the bottom-left one only because
  of the vertex alpha).
- blend_*.gltf: alphaMode BLEND, baseColorFactor alpha BLEND_ALPHA, no texture.
- one_sided_*.gltf: alphaMode OPAQUE, doubleSided false.
- one_sided_emitter.gltf: doubleSided false, base colour black, emitting EMITTER (from its
  front, +z, only).
- mask_twice.gltf, one_sided_twice.gltf: the quad of mask_lit.gltf and of one_sided_lit.gltf
  placed by two nodes (so stored once and instanced), both scaled by 1/2, one translated by
  TWICE_OFFSET along -x, the other along +x and mirrored in x (scale -1/2).
"""

import base64
import json
import os
import struct
import sys
import zlib

import pygltflib as g

CUTOFF = 0.6
VERTEX_ALPHA = 0.7
MASK_ALPHA = [255, 0, 204, 255]
BLEND_ALPHA = 0.25
EMISSION = [0.0, 1.0, 0.0]
EMITTER = [1.0, 1.0, 1.0]
TWICE_OFFSET = 1.1


def png_rgba(alphas):
    """A 4 x 4 RGBA PNG, black, each 2 x 2 quadrant of one alpha, written with zlib alone."""
    rows = b""
    for y in range(4):
        rows += b"\x00" + b"".join(bytes([0, 0, 0, alphas[(y // 2) * 2 + x // 2]]) for x in range(4))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    ihdr = struct.pack(">IIBBBBB", 4, 4, 8, 6, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b"")


def data_uri(data, mime):
    return f"data:{mime};base64," + base64.b64encode(data).decode()


def quad(material, image=None, vertex_alpha=None):
    positions = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
    uvs = [(0, 1), (1, 1), (1, 0), (0, 0)]
    indices = [0, 1, 2, 0, 2, 3]
    colors = [(1.0, 1.0, 1.0, vertex_alpha if vertex_alpha is not None else 1.0)] * 4
    blob = b"".join(struct.pack("<3f", *p) for p in positions)
    blob += b"".join(struct.pack("<2f", *t) for t in uvs)
    blob += b"".join(struct.pack("<4f", *c) for c in colors)
    blob += struct.pack("<6H", *indices)
    views = [
        g.BufferView(buffer=0, byteOffset=0, byteLength=48),
        g.BufferView(buffer=0, byteOffset=48, byteLength=32),
        g.BufferView(buffer=0, byteOffset=80, byteLength=64),
        g.BufferView(buffer=0, byteOffset=144, byteLength=12),
    ]
    accessors = [
        g.Accessor(bufferView=0, componentType=g.FLOAT, count=4, type=g.VEC3, min=[-1, -1, 0], max=[1, 1, 0]),
        g.Accessor(bufferView=1, componentType=g.FLOAT, count=4, type=g.VEC2),
        g.Accessor(bufferView=2, componentType=g.FLOAT, count=4, type=g.VEC4),
        g.Accessor(bufferView=3, componentType=g.UNSIGNED_SHORT, count=6, type=g.SCALAR),
    ]
    attributes = g.Attributes(POSITION=0, TEXCOORD_0=1, COLOR_0=2 if vertex_alpha is not None else None)
    images = [image] if image else []
    return g.GLTF2(
        scene=0,
        scenes=[g.Scene(nodes=[0])],
        nodes=[g.Node(mesh=0)],
        meshes=[g.Mesh(primitives=[g.Primitive(attributes=attributes, indices=3, material=0)])],
        materials=[material],
        textures=[g.Texture(source=0, sampler=0)] if images else [],
        samplers=[g.Sampler(wrapS=33071, wrapT=33071)] if images else [],
        images=[g.Image(uri=data_uri(png_rgba(a), "image/png")) for a in images],
        accessors=accessors,
        bufferViews=views,
        buffers=[g.Buffer(byteLength=len(blob), uri=data_uri(blob, "application/octet-stream"))],
    )


def material(lit, **kw):
    pbr = kw.pop("pbr")
    return g.Material(pbrMetallicRoughness=pbr, emissiveFactor=EMISSION if lit else [0, 0, 0], **kw)


def main(out):
    os.makedirs(out, exist_ok=True)
    for lit, suffix in [(True, "lit"), (False, "sheet")]:
        mask = material(
            lit,
            pbr=g.PbrMetallicRoughness(
                baseColorFactor=[0, 0, 0, 1], baseColorTexture=g.TextureInfo(index=0), metallicFactor=0
            ),
            alphaMode="MASK",
            alphaCutoff=CUTOFF,
            doubleSided=True,
        )
        quad(mask, MASK_ALPHA, vertex_alpha=VERTEX_ALPHA).save(os.path.join(out, f"mask_{suffix}.gltf"))
        blend = material(
            lit,
            pbr=g.PbrMetallicRoughness(baseColorFactor=[0, 0, 0, BLEND_ALPHA], metallicFactor=0),
            alphaMode="BLEND",
            doubleSided=True,
        )
        quad(blend).save(os.path.join(out, f"blend_{suffix}.gltf"))
        one_sided = material(
            lit, pbr=g.PbrMetallicRoughness(baseColorFactor=[0, 0, 0, 1], metallicFactor=0), doubleSided=False
        )
        quad(one_sided).save(os.path.join(out, f"one_sided_{suffix}.gltf"))
        if lit:
            for name, asset in [("mask", quad(mask, MASK_ALPHA, vertex_alpha=VERTEX_ALPHA)), ("one_sided", quad(one_sided))]:
                asset.nodes = [
                    g.Node(mesh=0, translation=[-TWICE_OFFSET, 0, 0], scale=[0.5, 0.5, 0.5]),
                    g.Node(mesh=0, translation=[TWICE_OFFSET, 0, 0], scale=[-0.5, 0.5, 0.5]),
                ]
                asset.scenes = [g.Scene(nodes=[0, 1])]
                asset.save(os.path.join(out, f"{name}_twice.gltf"))
    emitter = g.Material(
        pbrMetallicRoughness=g.PbrMetallicRoughness(baseColorFactor=[0, 0, 0, 1], metallicFactor=0),
        emissiveFactor=EMITTER,
        doubleSided=False,
    )
    quad(emitter).save(os.path.join(out, "one_sided_emitter.gltf"))
    json.dump(
        {
            "cutoff": CUTOFF,
            "vertex_alpha": VERTEX_ALPHA,
            "mask_alpha": MASK_ALPHA,
            "blend_alpha": BLEND_ALPHA,
            "emission": EMISSION,
            "twice_offset": TWICE_OFFSET,
        },
        open(os.path.join(out, "values.json"), "w"),
    )


if __name__ == "__main__":
    main(sys.argv[1])
