"""The farm button: `bpy.ops.strahl.write_farm_job(directory=...)` writes one `strahl farm
slurm` job per frame of the scene's range (frame_start to frame_end by frame_step) into a job
folder the user chooses:

    FOLDER/frame_0001/scene.gltf (+ .bin)     the frame's evaluated scene (export.py)
    FOLDER/frame_0001.exr.farm/               render.sbatch, merge.sbatch, later the tiles
    FOLDER/frame_0001.exr                     the frame, once the merge job has run

Each frame is exported as F12 exports it, then `strahl farm slurm SCENE -o FRAME.exr --tiles
N [--partition P] [--time T] [--cpus C] [--denoise] [--submit] -- RENDER OPTIONS` runs, the
render options being the panel's and the view layer's (engine.render_options), so a merged
frame is the F12 render of that frame, pixel for pixel. strahl runs as an argument list,
never through a shell, in the job folder; the folder's path is absolute, so it never reads
as an option, and `strahl farm slurm` quotes every value for the scripts or refuses it in
one line (docs/farm.md). The folder is never a temporary one: the nodes read the exported
scenes long after the operator has returned.

The farm renders the whole frame of the active view layer: a border is ignored, and
`--threads` becomes `--cpus` (each task gets that many CPUs from Slurm).
"""

import os
import subprocess

import bpy
from bpy.props import StringProperty

from . import engine, export

FRAME_NAME = "frame_%04d"


def farm_arguments(binary, gltf, exr, camera, scene, view_layer, submit):
    """`strahl farm slurm`'s command line for one frame: a list, each value its own argument."""
    settings = scene.strahl
    width, height = engine.frame_size(scene.render)
    args = [binary, "farm", "slurm", gltf, "-o", exr, "--tiles", str(min(settings.farm_tiles, height))]
    if settings.farm_partition:
        args += ["--partition", settings.farm_partition]
    if settings.farm_time:
        args += ["--time", settings.farm_time]
    if settings.threads > 0:
        args += ["--cpus", str(settings.threads)]
    extra = ()
    if settings.denoise:
        # The merge job denoises the merged frame from its beauty, albedo and normal.
        args.append("--denoise")
        extra = ("albedo", "normal")
    if submit:
        args.append("--submit")
    args.append("--")
    args += engine.render_options(camera, scene, view_layer, width, height, extra)
    return args


def write_jobs(context, directory, submit, report=print):
    """Exports every frame of the range and writes (and with `submit`, submits) its job;
    returns the frames' EXR paths. Raises engine.StrahlError or export.ExportError."""
    scene, view_layer = context.scene, context.view_layer
    binary = engine.find_strahl()
    folder = os.path.abspath(bpy.path.abspath(directory))
    os.makedirs(folder, exist_ok=True)
    frames = range(scene.frame_start, scene.frame_end + 1, max(1, scene.frame_step))
    current, written = scene.frame_current, []
    try:
        for frame in frames:
            scene.frame_set(frame)
            name = FRAME_NAME % frame
            frame_dir = os.path.join(folder, name)
            os.makedirs(frame_dir, exist_ok=True)
            depsgraph = context.evaluated_depsgraph_get()
            gltf, camera = export.export_frame(scene, view_layer, depsgraph, frame_dir)
            exr = os.path.join(folder, name + ".exr")
            args = farm_arguments(binary, gltf, exr, camera, scene, view_layer, submit)
            print("strahl: running %s" % " ".join(repr(a) for a in args), flush=True)
            out = subprocess.run(
                args, cwd=folder, stdin=subprocess.DEVNULL, capture_output=True, text=True, errors="replace"
            )
            print(out.stdout, end="", flush=True)
            if out.returncode != 0:
                lines = [l for l in out.stderr.splitlines() if l.strip()]
                error = next((l[len("error:") :].strip() for l in lines if l.startswith("error:")), None)
                raise engine.StrahlError(
                    "frame %d: %s" % (frame, error or (lines[-1] if lines else "status %d" % out.returncode))
                )
            written.append(exr)
            report("strahl: frame %d: wrote the job in %s.farm" % (frame, exr))
    finally:
        scene.frame_set(current)
    return written


class STRAHL_OT_write_farm_job(bpy.types.Operator):
    """Write the Slurm jobs (strahl farm slurm) of the scene's frame range into the job folder"""

    bl_idname = "strahl.write_farm_job"
    bl_label = "Write Farm Job"
    bl_options = {"REGISTER"}

    directory: StringProperty(
        name="Job Folder",
        description="Where the frames' scenes, jobs and images go; empty: the panel's job folder",
        subtype="DIR_PATH",
        default="",
    )

    def execute(self, context):
        settings = context.scene.strahl
        directory = self.directory or settings.farm_directory
        if not directory:
            self.report({"ERROR"}, "strahl: choose a job folder for the farm (not a temporary one)")
            return {"CANCELLED"}
        submit = settings.farm_submit
        try:
            written = write_jobs(context, directory, submit)
        except (engine.StrahlError, export.ExportError, OSError) as e:
            self.report({"ERROR"}, "strahl: %s" % e)
            return {"CANCELLED"}
        verb = "submitted" if submit else "wrote"
        self.report({"INFO"}, "strahl: %s the farm jobs of %d frames" % (verb, len(written)))
        return {"FINISHED"}
