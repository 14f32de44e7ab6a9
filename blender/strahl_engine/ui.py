"""The settings strahl renders with and where they are edited: the scene's `strahl` settings
(integrator, samples, max depth, threads, backend, the farm's job folder and Slurm settings),
the Render properties panel with its Farm subpanel, a View Layer
panel with the passes strahl writes, and the add-on preference naming the strahl binary
(empty: `strahl` on PATH). Blender's own panels that apply to any engine (dimensions, output,
colour management, film) are shown for strahl too.
"""

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty, StringProperty

from . import passes

ENGINE = "STRAHL"


class StrahlPreferences(bpy.types.AddonPreferences):
    bl_idname = __package__

    binary: StringProperty(
        name="strahl binary",
        description="The strahl executable; empty: strahl on PATH",
        subtype="FILE_PATH",
        default="",
    )

    def draw(self, context):
        self.layout.prop(self, "binary")


class StrahlSettings(bpy.types.PropertyGroup):
    integrator: EnumProperty(
        name="Integrator",
        items=(
            ("path", "Path", "Path tracing: indirect light, next-event estimation with MIS"),
            ("whitted", "Whitted", "The lecture's ray tracer: direct light, mirrors and glass"),
        ),
        default="path",
    )
    samples: IntProperty(name="Samples", description="Samples per pixel (strahl takes up to 65536)", default=16, min=1, max=65536)
    max_depth: IntProperty(name="Max Depth", description="Longest chain of scattered rays", default=8, min=0, max=1024)
    use_adaptive_sampling: BoolProperty(
        name="Adaptive Sampling",
        description="Stop sampling a pixel once its noise is below the threshold (path tracer only; Cycles' rule)",
        default=False,
    )
    adaptive_threshold: FloatProperty(
        name="Noise Threshold",
        description="Cycles' noise threshold; Samples is then the maximum",
        default=0.01,
        min=0.0001,
        max=1.0,
        precision=4,
    )
    seed: IntProperty(
        name="Seed",
        description="Seed of the sample sequences: renders with different seeds have independent noise",
        default=0,
        min=0,
    )
    use_animated_seed: BoolProperty(
        name="Animated Seed",
        description="Add the frame number to the seed, so that the noise changes from frame to frame (as Cycles' animated seed)",
        default=False,
    )
    denoise: BoolProperty(
        name="Denoise",
        description="Denoise the frame with Intel Open Image Denoise (needs strahl built with `make oidn`; not with a border)",
        default=False,
    )
    threads: IntProperty(name="Threads", description="Worker threads; 0: one per core", default=0, min=0, max=4096)
    backend: EnumProperty(
        name="Backend",
        items=(
            ("embree", "Embree", "Intel Embree finds the closest hits"),
            ("native", "Native", "strahl's own BVH"),
        ),
        default="embree",
    )
    farm_directory: StringProperty(
        name="Job Folder",
        description="Where Write Farm Job puts each frame's scene, Slurm job and image (kept: the nodes read it)",
        subtype="DIR_PATH",
        default="",
    )
    farm_tiles: IntProperty(name="Tiles", description="Tiles (Slurm array tasks) per frame", default=4, min=1, max=10000)
    farm_partition: StringProperty(name="Partition", description="Slurm partition; empty: the cluster's default", default="")
    farm_time: StringProperty(name="Time Limit", description="Slurm time limit of each job, e.g. 30:00; empty: the partition's", default="")
    farm_submit: BoolProperty(name="Submit", description="Submit the jobs with sbatch, not only write them", default=False)


class _StrahlRenderPanel:
    """What the add-on's panels share: the Render properties tab, shown when strahl renders."""

    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"
    COMPAT_ENGINES = {ENGINE}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES


class RENDER_PT_strahl(_StrahlRenderPanel, bpy.types.Panel):
    bl_label = "strahl"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        settings = context.scene.strahl
        for prop in ("integrator", "samples", "max_depth"):
            layout.prop(settings, prop)
        row = layout.row()
        row.active = settings.integrator == "path"
        row.prop(settings, "use_adaptive_sampling")
        row = layout.row()
        row.active = settings.integrator == "path" and settings.use_adaptive_sampling
        row.prop(settings, "adaptive_threshold")
        row = layout.row(align=True)
        row.prop(settings, "seed")
        row.prop(settings, "use_animated_seed", text="", icon="TIME")
        layout.prop(settings, "denoise")
        for prop in ("threads", "backend"):
            layout.prop(settings, prop)
        layout.prop(context.scene.render, "film_transparent", text="Transparent")


class RENDER_PT_strahl_farm(_StrahlRenderPanel, bpy.types.Panel):
    bl_label = "Farm (Slurm)"
    bl_parent_id = "RENDER_PT_strahl"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        settings = context.scene.strahl
        for prop in ("farm_directory", "farm_tiles", "farm_partition", "farm_time", "farm_submit"):
            layout.prop(settings, prop)
        layout.operator("strahl.write_farm_job", icon="NETWORK_DRIVE")


class VIEWLAYER_PT_strahl_passes(bpy.types.Panel):
    bl_label = "Passes (strahl)"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "view_layer"
    COMPAT_ENGINES = {ENGINE}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        view_layer = context.view_layer
        for _, name, _, _, _, prop in passes.TABLE:
            layout.prop(view_layer, prop, text=name)
        for _, name, prop in passes.CRYPTOMATTE:
            layout.prop(view_layer, prop, text=name)
        layout.prop(view_layer, "pass_cryptomatte_depth", text="Cryptomatte Levels")


CLASSES = (StrahlPreferences, StrahlSettings, RENDER_PT_strahl, RENDER_PT_strahl_farm, VIEWLAYER_PT_strahl_passes)

# Blender's panels that work for any engine, by the engines they list.
_SHARED_WITH = "BLENDER_RENDER"


def _shared_panels():
    for panel in bpy.types.Panel.__subclasses__():
        engines = getattr(panel, "COMPAT_ENGINES", None)
        if engines is not None and _SHARED_WITH in engines:
            yield panel


def attach():
    bpy.types.Scene.strahl = PointerProperty(type=StrahlSettings)
    for panel in _shared_panels():
        panel.COMPAT_ENGINES.add(ENGINE)


def detach():
    for panel in _shared_panels():
        panel.COMPAT_ENGINES.discard(ENGINE)
    del bpy.types.Scene.strahl
