"""Renders the open .blend's current frame in Blender's interactive UI (not `-b`), as F12
does, saves it and quits; tests/blender_engine.rs runs it under Xvfb:

    xvfb-run -a blender --factory-startup --addons strahl_engine FILE.blend \
        --python tools/blender/f12_ui.py -- OUT_PATTERN

Once the window is up (a timer), `bpy.ops.render.render(write_still=True)` renders through
the window's context with the scene's engine and writes OUT_PATTERN (`#` the frame number);
the script prints `F12 <background> <result>` and quits Blender.
"""

import sys

import bpy

out = sys.argv[sys.argv.index("--") + 1]


def f12():
    scene = bpy.context.scene
    scene.render.filepath = out
    window = bpy.context.window_manager.windows[0]
    with bpy.context.temp_override(window=window, screen=window.screen):
        result = bpy.ops.render.render(write_still=True)
    print("F12", bpy.app.background, sorted(result), flush=True)
    bpy.ops.wm.quit_blender()


bpy.app.timers.register(f12, first_interval=1.0)
