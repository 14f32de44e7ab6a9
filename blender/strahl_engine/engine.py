"""The render engine "STRAHL": one frame of one view layer is

    export (export.py) → strahl render SCENE.gltf -o OUT.exr ... → RenderResult.load_from_file

in a temporary folder that is always removed. strahl runs as an argument list, never through
a shell (object, file and camera names from a .blend are hostile input), with the settings of
the Render panel; its stderr drives the progress bar (`rendering: 42% after 12.0 s, eta 16.5
s`, one line every half second, `--progress-interval 0.5`) and its first `error: …` line becomes the
render's one error report. When Blender asks to stop (Esc, Ctrl-C in the background)
strahl gets SIGTERM and is waited for, so no strahl process outlives the render.

The EXR's channels are Blender's multilayer names under the view layer's own name (strahl's
`--layer-name`: `Beauty.Combined.R`, `Beauty.DiffCol.G`, ...), so `RenderResult.load_from_file`
fills every registered pass by name; its Cryptomatte header entries (`cryptomatte/<key>/name`,
`/hash`, `/conversion`, `/manifest`) are copied into the result's metadata, where the
compositor's Cryptomatte node finds the layers.

Pixels: the frame is resolution × percentage / 100 (integer division, as Blender's); a border
render asks strahl for the border's pixels only (`--region`, rows counted from the top where
Blender counts from the bottom), and the result is the border's size.
"""

import math
import os
import queue
import re
import shutil
import signal
import subprocess
import tempfile
import threading

import bpy

from . import export, passes

PROGRESS = re.compile(r"^rendering: (\d+(?:\.\d+)?)% after ([0-9.]+) s, eta ([0-9.a-zA-Z]+) s")
EXR_NAME = "frame.exr"
# Seconds between strahl's progress lines (its --progress-interval).
PROGRESS_INTERVAL = 0.5
# Seconds strahl has after SIGTERM (it saves its checkpoint) before it is killed.
TERMINATE_GRACE = 30.0
# The strahl binaries that answered `--version`, by path.
_checked = {}


class StrahlError(Exception):
    """A render that cannot go on, in one line for `report`."""


def find_strahl():
    """The strahl executable: the add-on preference, else `strahl` on PATH; checked once
    with `strahl --version`."""
    prefs = bpy.context.preferences.addons.get(__package__)
    configured = prefs.preferences.binary if prefs else ""
    path = bpy.path.abspath(configured) if configured else shutil.which("strahl")
    if not path:
        raise StrahlError("strahl is not on PATH; set its path in the add-on's preferences")
    if path not in _checked:
        try:
            out = subprocess.run([path, "--version"], capture_output=True, text=True, timeout=30)
        except (OSError, subprocess.TimeoutExpired) as e:
            raise StrahlError("cannot run %s: %s" % (path, e)) from None
        first = out.stdout.splitlines()[0] if out.stdout else ""
        if out.returncode != 0 or not first.startswith("strahl "):
            raise StrahlError("%s is not strahl (--version said %r)" % (path, first or out.stderr.strip()))
        _checked[path] = first
    return path


def frame_size(render):
    """The frame's width and height in pixels, as Blender computes them."""
    pct = render.resolution_percentage
    return render.resolution_x * pct // 100, render.resolution_y * pct // 100


def border_region(render, width, height):
    """The border as strahl's region (x0, y0, x1, y1), rows from the top; None without one.
    Blender truncates border × size to whole pixels, in single precision."""
    if not render.use_border:
        return None
    x0 = math.floor(render.border_min_x * width)
    x1 = math.floor(render.border_max_x * width)
    ymin = math.floor(render.border_min_y * height)
    ymax = math.floor(render.border_max_y * height)
    if x1 <= x0 or ymax <= ymin:
        return None
    return x0, height - ymax, x1, height - ymin


def strahl_arguments(binary, gltf, camera, exr, scene, view_layer, width, height, region):
    """strahl's command line for the frame: a list, each value its own argument."""
    settings = scene.strahl
    args = [binary, "render", gltf, "-o", exr]
    args += render_options(camera, scene, view_layer, width, height)
    # A progress line every PROGRESS_INTERVAL seconds moves Blender's bar (strahl's default: 5 s).
    args += ["--progress-interval", repr(PROGRESS_INTERVAL)]
    # strahl denoises whole frames only (a border render is a region).
    if settings.denoise and region is None:
        args.append("--denoise")
    if settings.threads > 0:
        args += ["--threads", str(settings.threads)]
    if region is not None:
        args += ["--region", "%d,%d,%d,%d" % region]
    return args


def sample_seed(settings, frame):
    """The panel's seed, plus the frame number (negative frames as 0) with Animated Seed,
    wrapped into strahl's range of seeds, 0 to 2^31 - 1 (Blender's own seeds' range)."""
    seed = settings.seed + (max(0, frame) if settings.use_animated_seed else 0)
    return seed % 2**31


def render_options(camera, scene, view_layer, width, height, extra_passes=()):
    """The `strahl render` options of the panel's and the view layer's settings that a frame
    and each of its farm tiles share (no output, threads, region or denoising)."""
    settings = scene.strahl
    args = ["--camera", str(camera), "--width", str(width), "--height", str(height)]
    args += ["--integrator", settings.integrator, "--spp", str(settings.samples), "--depth", str(settings.max_depth)]
    args += ["--backend", settings.backend]
    # The header's Frame and Time, as Blender stamps them.
    fps = max(1, round(scene.render.fps / scene.render.fps_base))
    args += ["--frame", str(max(0, scene.frame_current)), "--fps", str(fps)]
    if settings.integrator == "path" and settings.use_adaptive_sampling:
        args += ["--adaptive-threshold", repr(float(settings.adaptive_threshold))]
    seed = sample_seed(settings, scene.frame_current)
    if seed:
        args += ["--seed", str(seed)]
    names = passes.requested(view_layer)
    names += [p for p in extra_passes if p not in names]
    args += ["--passes", ",".join(names), "--layer-name", view_layer.name]
    if view_layer.use_pass_cryptomatte_object or view_layer.use_pass_cryptomatte_material:
        args += ["--cryptomatte-levels", str(passes.crypto_levels(view_layer))]
    if scene.render.film_transparent:
        args.append("--transparent")
    return args


def exr_string_attributes(path, prefix):
    """The string attributes of an OpenEXR file's (first) header whose names start with
    `prefix`: name, type, size and value in turn after the 8-byte magic and version, up to an
    empty name (the OpenEXR file layout)."""
    out = {}
    with open(path, "rb") as f:
        head = f.read(8)
        if len(head) < 8 or head[:4] != b"\x76\x2f\x31\x01":
            return out
        while True:
            name = _read_cstring(f)
            if not name:
                return out
            kind = _read_cstring(f)
            size_bytes = f.read(4)
            if len(size_bytes) < 4:
                return out
            size = int.from_bytes(size_bytes, "little", signed=True)
            if size < 0:
                return out
            value = f.read(size)
            if kind == "string" and name.startswith(prefix):
                out[name] = value.decode("utf-8", "replace")


def _read_cstring(f, limit=256):
    data = bytearray()
    while len(data) <= limit:
        c = f.read(1)
        if not c or c == b"\0":
            break
        data += c
    return data.decode("utf-8", "replace")


def _pump(stream, lines):
    """Puts each line of `stream` on the queue `lines`, then None."""
    for line in iter(stream.readline, ""):
        lines.put(line.rstrip("\n"))
    lines.put(None)


class StrahlRenderEngine(bpy.types.RenderEngine):
    bl_idname = "STRAHL"
    bl_label = "strahl"
    bl_use_preview = False
    bl_use_postprocess = True
    bl_use_eevee_viewport = True

    def update_render_passes(self, scene=None, renderlayer=None):
        passes.register(self, scene, renderlayer)

    def render(self, depsgraph):
        scene = depsgraph.scene
        view_layer = depsgraph.view_layer
        directory = tempfile.mkdtemp(prefix="strahl-blender-")
        try:
            self._render(scene, view_layer, depsgraph, directory)
        except (StrahlError, export.ExportError) as e:
            self.report({"ERROR"}, "strahl: %s" % e)
        finally:
            shutil.rmtree(directory, ignore_errors=True)

    def _render(self, scene, view_layer, depsgraph, directory):
        binary = find_strahl()
        width, height = frame_size(scene.render)
        region = border_region(scene.render, width, height)
        self.update_stats("", "strahl: exporting frame %d" % scene.frame_current)
        gltf, camera = export.export_frame(scene, view_layer, depsgraph, directory)
        exr = os.path.join(directory, EXR_NAME)
        args = strahl_arguments(binary, gltf, camera, exr, scene, view_layer, width, height, region)
        if not self._run(args):
            return
        if region is None:
            x, y, w, h = 0, 0, width, height
        else:
            x, y, w, h = region[0], height - region[3], region[2] - region[0], region[3] - region[1]
        result = self.begin_result(0, 0, w, h, layer=view_layer.name)
        try:
            result.load_from_file(exr)
            for name, value in exr_string_attributes(exr, "cryptomatte/").items():
                result.stamp_data_add_field(name, value)
        finally:
            self.end_result(result)

    def _run(self, args):
        """Runs strahl, following its progress; True when it wrote the image, False when
        the render was cancelled. Raises StrahlError with strahl's error line."""
        print("strahl: running %s" % " ".join(repr(a) for a in args))
        proc = subprocess.Popen(
            args, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, errors="replace"
        )
        print("strahl: pid %d" % proc.pid, flush=True)
        lines = queue.Queue()
        readers = [threading.Thread(target=_pump, args=(s, lines), daemon=True) for s in (proc.stderr, proc.stdout)]
        for t in readers:
            t.start()
        error, last, open_streams = None, "", 2
        self.update_stats("", "strahl: rendering")
        try:
            while open_streams or proc.poll() is None:
                if self.test_break():
                    self._stop(proc)
                    self.update_stats("", "strahl: cancelled")
                    return False
                try:
                    line = lines.get(timeout=0.1)
                except queue.Empty:
                    continue
                if line is None:
                    open_streams -= 1
                    continue
                m = PROGRESS.match(line)
                if m:
                    self.set_progress(float(m.group(1)) / 100.0)
                    self.update_stats("", "strahl: %s%%, eta %s s" % (m.group(1), m.group(3)))
                    continue
                print("strahl: %s" % line)
                if line.strip():
                    last = line.strip()
                if error is None and line.startswith("error:"):
                    error = line[len("error:") :].strip()
        except BaseException:
            self._stop(proc)
            raise
        for t in readers:
            t.join(timeout=5)
        if proc.returncode != 0:
            raise StrahlError(error or last or "strahl exited with status %d" % proc.returncode)
        self.set_progress(1.0)
        return True

    def set_progress(self, fraction):
        """Moves Blender's progress bar (every value the bar gets passes here)."""
        self.update_progress(fraction)

    @staticmethod
    def _stop(proc):
        """SIGTERM, then SIGKILL after TERMINATE_GRACE seconds; waits, so no process is left."""
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
            try:
                proc.wait(timeout=TERMINATE_GRACE)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        print("strahl: pid %d stopped (status %s)" % (proc.pid, proc.returncode), flush=True)
