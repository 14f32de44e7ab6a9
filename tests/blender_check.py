"""Run by Blender headless:
`blender -b --factory-startup --python blender_check.py -- FILE.exr NAME INDEX WIDTH HEIGHT`.
Prints the passes Blender's Image node offers for strahl's EXR (`PASSES ...`), then extracts
the Cryptomatte matte of the object NAME with Blender's own Cryptomatte node and compares it
with the file's object-index pass (IndexOB == INDEX): `MATTE OK` when they agree on at least
99.9 % of the pixels (the file is rendered at 1 spp, so the index pass is exact); then
rebuilds Combined from the light-path passes with Blender's recipe in Mix nodes and prints
`RECIPE OK` when it agrees with Combined within 1e-4 relative."""

import sys

import bpy

path, name, wanted_index, w, h = sys.argv[sys.argv.index("--") + 1 :][:5]
wanted_index, w, h = float(wanted_index), int(w), int(h)
image = bpy.data.images.load(path)
scene = bpy.context.scene
scene.use_nodes = True
tree = scene.node_tree
for n in list(tree.nodes):
    tree.nodes.remove(n)
node = tree.nodes.new("CompositorNodeImage")
node.image = image
print("PASSES " + " ".join(o.name for o in node.outputs if o.enabled))
sys.stdout.flush()

scene.render.resolution_x, scene.render.resolution_y = w, h
scene.render.resolution_percentage = 100
scene.render.use_compositing = True
if scene.camera is None:
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    scene.collection.objects.link(camera)
    scene.camera = camera
crypto = tree.nodes.new("CompositorNodeCryptomatteV2")
crypto.source = "IMAGE"
crypto.image = image
crypto.layer_name = "ViewLayer.CryptoObject"
crypto.matte_id = name
composite = tree.nodes.new("CompositorNodeComposite")
composite.use_alpha = False
scene.render.image_settings.file_format = "OPEN_EXR"
scene.render.image_settings.color_depth = "32"
scene.render.image_settings.color_mode = "RGB"
out_path = path + ".blender.exr"
scene.render.filepath = out_path


def viewed(socket):
    """The red channel of `socket` as the compositor writes it to a file, read back."""
    tree.links.new(socket, composite.inputs[0])
    bpy.ops.render.render(write_still=True)
    result = bpy.data.images.load(out_path, check_existing=False)
    pixels = list(result.pixels)[0::4]
    bpy.data.images.remove(result)
    return pixels


matte = viewed(crypto.outputs["Matte"])
index = viewed(node.outputs["IndexOB"])
own = [1.0 if abs(i - wanted_index) < 1e-3 else 0.0 for i in index]
agree = sum(abs(m - o) < 1e-4 for m, o in zip(matte, own)) / max(len(own), 1)
print(f"object '{name}': {sum(own):.0f} pixels by index, {sum(matte):.1f} by matte, agree {100 * agree:.3f} %")
print("MATTE OK" if agree >= 0.999 and sum(own) > 0 and len(matte) == w * h else "MATTE BAD")


def viewed_rgb(socket):
    """The R, G and B channels of `socket` as the compositor writes them, read back."""
    tree.links.new(socket, composite.inputs[0])
    bpy.ops.render.render(write_still=True)
    result = bpy.data.images.load(out_path, check_existing=False)
    pixels = list(result.pixels)
    bpy.data.images.remove(result)
    return [pixels[c::4] for c in range(3)]


def mix(kind, a, b):
    """A Mix node `kind` (ADD, MULTIPLY) of sockets `a` and `b`, factor 1."""
    m = tree.nodes.new("CompositorNodeMixRGB")
    m.blend_type = kind
    m.inputs[0].default_value = 1.0
    tree.links.new(a, m.inputs[1])
    tree.links.new(b, m.inputs[2])
    return m.outputs[0]


# Blender's recipe (manual, "Render Passes"): Combined = (DiffDir + DiffInd) * DiffCol
# + (GlossDir + GlossInd) * GlossCol + (TransDir + TransInd) * TransCol + Emit + Env,
# built from Mix nodes as a compositor user builds it.
out = node.outputs
if all(p in out for p in ("DiffDir", "DiffInd", "GlossCol", "TransDir", "TransCol")):
    total = mix("ADD", out["Emit"], out["Env"])
    for d, i, c in (("DiffDir", "DiffInd", "DiffCol"), ("GlossDir", "GlossInd", "GlossCol"),
                    ("TransDir", "TransInd", "TransCol")):
        total = mix("ADD", total, mix("MULTIPLY", mix("ADD", out[d], out[i]), out[c]))
    rebuilt = viewed_rgb(total)
    combined = viewed_rgb(out["Combined"] if "Combined" in out else out["Image"])
    worst = 0.0
    for r, c in zip(rebuilt, combined):
        for x, y in zip(r, c):
            worst = max(worst, abs(x - y) / max(abs(y), 1e-3))
    lit = sum(y > 0 for y in combined[0])
    print(f"recipe: worst relative difference {worst:.3g} over {len(combined[0])} pixels ({lit} lit)")
    print("RECIPE OK" if worst <= 1e-4 and lit > 0 else "RECIPE BAD")
