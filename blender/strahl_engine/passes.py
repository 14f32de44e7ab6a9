"""Blender's view layer passes and strahl's `--passes`: one table maps each pass strahl writes
to the name, channels and view layer setting Blender gives it, so the EXR's layer
`ViewLayer.<Blender name>.<channel>` loads into the render pass of that name.

A pass is asked for when its view layer checkbox is on; `Combined` always is. Cryptomatte
levels follow the view layer's `pass_cryptomatte_depth`: strahl writes ceil(levels / 2) RGBA
layers `CryptoObject00`, `CryptoObject01`, ... as Blender does. Passes strahl does not have
(e.g. Vector, Mist, AO, Shadow) are not registered and stay off.

Meaning differences (see docs/compositing.md): strahl's Depth is the distance along the camera
ray (Blender's is along the view axis) and is +inf where nothing is hit.
"""

import math

# (strahl pass, Blender pass name, channels, channel ids, socket type, ViewLayer property)
TABLE = (
    ("depth", "Depth", 1, "Z", "VALUE", "use_pass_z"),
    ("normal", "Normal", 3, "XYZ", "VECTOR", "use_pass_normal"),
    ("albedo", "DiffCol", 3, "RGB", "COLOR", "use_pass_diffuse_color"),
    ("emission", "Emit", 3, "RGB", "COLOR", "use_pass_emit"),
    ("diffuse_direct", "DiffDir", 3, "RGB", "COLOR", "use_pass_diffuse_direct"),
    ("diffuse_indirect", "DiffInd", 3, "RGB", "COLOR", "use_pass_diffuse_indirect"),
    ("glossy_direct", "GlossDir", 3, "RGB", "COLOR", "use_pass_glossy_direct"),
    ("glossy_indirect", "GlossInd", 3, "RGB", "COLOR", "use_pass_glossy_indirect"),
    ("glossy_color", "GlossCol", 3, "RGB", "COLOR", "use_pass_glossy_color"),
    ("transmission_direct", "TransDir", 3, "RGB", "COLOR", "use_pass_transmission_direct"),
    ("transmission_indirect", "TransInd", 3, "RGB", "COLOR", "use_pass_transmission_indirect"),
    ("transmission_color", "TransCol", 3, "RGB", "COLOR", "use_pass_transmission_color"),
    ("background", "Env", 3, "RGB", "COLOR", "use_pass_environment"),
    ("position", "Position", 3, "XYZ", "VECTOR", "use_pass_position"),
    ("object_index", "IndexOB", 1, "X", "VALUE", "use_pass_object_index"),
    ("material_index", "IndexMA", 1, "X", "VALUE", "use_pass_material_index"),
)

# (strahl pass, Blender pass name prefix, ViewLayer property)
CRYPTOMATTE = (
    ("crypto_object", "CryptoObject", "use_pass_cryptomatte_object"),
    ("crypto_material", "CryptoMaterial", "use_pass_cryptomatte_material"),
)

# strahl's largest `--cryptomatte-levels`.
MAX_CRYPTO_LEVELS = 16


def crypto_levels(view_layer):
    """The Cryptomatte ranks per pixel the view layer asks for, within strahl's range."""
    return max(1, min(MAX_CRYPTO_LEVELS, int(view_layer.pass_cryptomatte_depth)))


def crypto_layer_names(prefix, levels):
    """`CryptoObject00`, `CryptoObject01`, ...: two ranks per RGBA layer."""
    return ["%s%02d" % (prefix, i) for i in range(math.ceil(levels / 2))]


def requested(view_layer):
    """strahl's pass names for `--passes`: `combined` and every table pass switched on."""
    names = ["combined"]
    names += [strahl for strahl, _, _, _, _, prop in TABLE if getattr(view_layer, prop, False)]
    names += [strahl for strahl, _, prop in CRYPTOMATTE if getattr(view_layer, prop, False)]
    return names


def blender_passes(view_layer):
    """(name, channels, channel ids, type) of every pass besides Combined that strahl writes
    for this view layer, in the order of the table."""
    out = [(name, n, ids, kind) for _, name, n, ids, kind, prop in TABLE if getattr(view_layer, prop, False)]
    levels = crypto_levels(view_layer)
    for _, prefix, prop in CRYPTOMATTE:
        if getattr(view_layer, prop, False):
            out += [(name, 4, "rgba", "COLOR") for name in crypto_layer_names(prefix, levels)]
    return out


def register(engine, scene, view_layer):
    """Registers Combined and the passes strahl will write, so the compositor offers them."""
    engine.register_pass(scene, view_layer, "Combined", 4, "RGBA", "COLOR")
    for name, channels, ids, kind in blender_passes(view_layer):
        engine.register_pass(scene, view_layer, name, channels, ids, kind)
