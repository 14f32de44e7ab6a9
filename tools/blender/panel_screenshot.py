"""Screenshots the strahl Render properties panel, for the README:

    xvfb-run -a -s "-screen 0 640x560x24" blender --factory-startup --addons strahl_engine \
        FILE.blend --python tools/blender/panel_screenshot.py -- OUT.png

(with the add-on installed, see README "Rendering from Blender"; or, without installing it,
`BLENDER_USER_SCRIPTS=DIR` with the add-on in DIR/addons/strahl_engine, as tests/blender_engine.rs
does). FILE.blend is any scene, e.g. the room tools/blender/room.py writes: on Blender's factory
startup scene instead of a file, Blender 3.4 under Xvfb segfaulted before drawing. Once the
window is drawn, the Properties editor shows the Render tab, fills the window and is saved as
OUT.png; then Blender quits.
"""

import sys

import bpy

out = sys.argv[sys.argv.index("--") + 1]
bpy.context.scene.render.engine = "STRAHL"


def shoot():
    window = bpy.context.window_manager.windows[0]
    areas = [a for a in window.screen.areas if a.type == "PROPERTIES"]
    area = max(areas, key=lambda a: a.width * a.height)
    area.spaces[0].context = "RENDER"
    with bpy.context.temp_override(window=window, screen=window.screen, area=area):
        bpy.ops.screen.screen_full_area()
    area = max((a for a in window.screen.areas if a.type == "PROPERTIES"), key=lambda a: a.width * a.height)

    window.cursor_warp(0, 0)  # no tooltip under the pointer

    def save():
        with bpy.context.temp_override(window=window, screen=window.screen, area=area):
            bpy.ops.screen.screenshot_area(filepath=out)
        print("WROTE", out)
        bpy.ops.wm.quit_blender()

    bpy.app.timers.register(save, first_interval=1.0)


bpy.app.timers.register(shoot, first_interval=2.0)
