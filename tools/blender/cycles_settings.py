"""Cycles set to what strahl's path tracer computes, for the scripts that render test scenes
with Cycles (tools/gltf/blender_cornell.py, tools/blender/render_gltf.py): DEPTH - 1 bounces of
every kind (strahl's depth counts the camera ray), no clamp, no glossy filter, caustics on, no
adaptive sampling, no denoising, seed 0, a box filter one pixel wide (strahl's pixel), the
Standard view transform, and float RGBA EXR output (multilayer when asked: passes beside the
image). Returns the scene's Cycles settings, for what a caller changes further.
"""


def like_strahl(scene, spp, depth, multilayer=False):
    scene.render.engine = "CYCLES"
    cycles = scene.cycles
    cycles.device = "CPU"
    cycles.samples = spp
    cycles.use_adaptive_sampling = False
    cycles.use_denoising = False
    cycles.seed = 0
    cycles.max_bounces = depth - 1
    cycles.diffuse_bounces = depth - 1
    cycles.glossy_bounces = depth - 1
    cycles.transmission_bounces = depth - 1
    cycles.transparent_max_bounces = depth - 1
    cycles.volume_bounces = 0
    cycles.sample_clamp_direct = 0.0
    cycles.sample_clamp_indirect = 0.0
    cycles.blur_glossy = 0.0
    cycles.caustics_reflective = True
    cycles.caustics_refractive = True
    cycles.pixel_filter_type = "BOX"
    cycles.filter_width = 1.0
    scene.render.threads_mode = "AUTO"
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    scene.render.image_settings.file_format = "OPEN_EXR_MULTILAYER" if multilayer else "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    scene.render.image_settings.color_mode = "RGBA"
    return cycles
