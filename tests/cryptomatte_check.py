"""Decodes strahl's Cryptomatte with code strahl did not write: Python's OpenEXR reads the file,
PyPI's mmh3 hashes the names, and the Cryptomatte 1.1 float conversion is applied here. For every
object in the manifest, the matte (the coverage summed over the ranks whose id is the object's)
must equal the object-index pass's coverage (IndexOB = 1 + the object's place in the manifest)
on at least 99.9 % of pixels (the file is rendered at 1 spp, so the index pass is exact); and no
rank holds an id that is not in the manifest ("unknown ids: 0").
Usage: python3 cryptomatte_check.py FILE.exr"""

import json
import struct
import sys

import mmh3
import numpy as np
import OpenEXR


def crypto_id(name):
    """The float id of a name: MurmurHash3_x86_32, exponent bit flipped if all 0s or all 1s."""
    h = mmh3.hash(name, seed=0, signed=False)
    exponent = (h >> 23) & 0xFF
    if exponent in (0, 255):
        h ^= 1 << 23
    return h, struct.unpack("<f", struct.pack("<I", h))[0]


def main(path):
    with OpenEXR.File(path, separate_channels=True) as f:
        header = dict(f.header())
        channels = {name: np.asarray(c.pixels) for name, c in f.channels().items()}
    layers = {}
    for key, value in header.items():
        if key.startswith("cryptomatte/"):
            _, k, field = key.split("/")
            layers.setdefault(k, {})[field] = value
    assert layers, "no cryptomatte attributes"
    for k, layer in layers.items():
        assert layer["hash"] == "MurmurHash3_32" and layer["conversion"] == "uint32_to_float32", layer
        assert ("%08x" % mmh3.hash(layer["name"], signed=False))[:7] == k, (k, layer["name"])
    objects = next(l for l in layers.values() if l["name"].endswith("CryptoObject"))
    manifest = json.loads(objects["manifest"])
    prefix = objects["name"]
    ranks = sorted({n.rsplit(".", 1)[0] for n in channels if n.startswith(prefix) and n[len(prefix):][:2].isdigit()})
    assert ranks, "no CryptoObject layers"
    index = channels[[n for n in channels if n.endswith("IndexOB.X") or n == "object_index.X"][0]]
    failures = 0
    for k, (name, hex_id) in enumerate(manifest.items()):
        bits, fid = crypto_id(name)
        assert "%08x" % bits == hex_id, (name, hex_id, "%08x" % bits)
        matte = np.zeros(index.shape, dtype=np.float64)
        for layer in ranks:
            c = [channels[layer + "." + x] for x in ("r", "g", "b", "a")] if layer + ".r" in channels else [
                channels[layer + "." + x] for x in ("R", "G", "B", "A")
            ]
            for id_channel, coverage in ((c[0], c[1]), (c[2], c[3])):
                matte += np.where(id_channel.view(np.uint32) == np.uint32(bits), coverage, 0.0)
        own = (index == k + 1).astype(np.float64)
        agree = np.mean(np.abs(matte - own) < 1e-6)
        pixels = int(own.sum())
        print(f"object '{name}': id {hex_id}, {pixels} pixels, matte agrees on {100 * agree:.3f} % of pixels")
        if agree < 0.999 or pixels == 0:
            failures += 1
    # Every id stored with a nonzero coverage is a name's: lossy compression would make others.
    known = {np.uint32(int(h, 16)) for h in manifest.values()}
    unknown = 0
    for layer in ranks:
        c = [channels[layer + "." + x] for x in ("r", "g", "b", "a")] if layer + ".r" in channels else [
            channels[layer + "." + x] for x in ("R", "G", "B", "A")
        ]
        for id_channel, coverage in ((c[0], c[1]), (c[2], c[3])):
            ids = id_channel.view(np.uint32)[coverage != 0]
            unknown += int(sum(1 for i in ids if i not in known))
    print(f"unknown ids: {unknown}")
    if unknown:
        failures += 1
    materials = next((l for l in layers.values() if l["name"].endswith("CryptoMaterial")), None)
    if materials:
        for name, hex_id in json.loads(materials["manifest"]).items():
            assert "%08x" % crypto_id(name)[0] == hex_id, (name, hex_id)
        print(f"material manifest: {len(json.loads(materials['manifest']))} names, ids match mmh3")
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main(sys.argv[1])
