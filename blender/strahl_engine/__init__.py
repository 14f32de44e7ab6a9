"""strahl as a Blender render engine: F12 (or `blender -b FILE -E STRAHL -f N`) exports the
evaluated scene with Blender's own glTF exporter, runs `strahl render` on it and loads the
EXR's passes into the render result, so the compositor's Render Layers node offers them.

The add-on talks to strahl only through its command line and files: `engine` runs the
render, `farm` writes the Slurm jobs of a frame range (`strahl farm slurm`), `export` writes
the glTF file, `passes` maps Blender's view layer passes to strahl's `--passes`, `ui` holds
the settings, the panels and the preferences.
"""

bl_info = {
    "name": "strahl",
    "author": "strahl contributors",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "Properties > Render > Render Engine > strahl",
    "description": "Renders with strahl, an offline ray tracer, through its command line",
    "category": "Render",
}

from . import engine, farm, ui  # noqa: E402

_CLASSES = ui.CLASSES + (engine.StrahlRenderEngine, farm.STRAHL_OT_write_farm_job)


def register():
    import bpy

    for cls in _CLASSES:
        bpy.utils.register_class(cls)
    ui.attach()


def unregister():
    import bpy

    ui.detach()
    for cls in reversed(_CLASSES):
        bpy.utils.unregister_class(cls)
