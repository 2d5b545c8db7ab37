"""Submit to Farm (tussock.farm_submit), in the Bake panel: the farm command (cli.py) for the
saved .blend, with the back end, the number of tasks and the frames to render chosen in
Blender. The job script is written beside the .blend before anything starts, so the
artist can read and reuse it; the local back end then runs detached from Blender (its
progress in <name>_farm/logs/farm.out), the Slurm one submits with sbatch and returns."""

import os
import shutil
import subprocess
import sys

import bpy

from .. import errors
from . import plan as farm_plan

HERE = os.path.dirname(os.path.abspath(__file__))


def python():
    """A Python 3 to run the farm command with (it needs no bpy): the system's first, as a
    version manager's shim (pyenv) that Blender may have found changes the environment of
    what it starts, and the farm's Blenders would inherit that; else Blender's own."""
    for exe in ("/usr/bin/python3", sys.executable or "", shutil.which("python3") or ""):
        if os.path.basename(exe).startswith("python") and os.access(exe, os.X_OK):
            return exe
    raise OSError("no python3 found to run the farm command: install Python 3")


class TUSSOCK_OT_farm_submit(bpy.types.Operator):
    """Bake and render the saved .blend on a farm: the bake split into tasks, the caches
    assembled once, the render split into tasks. Writes the job script beside the .blend"""
    bl_idname = "tussock.farm_submit"
    bl_label = "Submit to Farm"
    bl_options = {"REGISTER"}

    backend: bpy.props.EnumProperty(
        name="Back End", default="LOCAL",
        description="Where the tasks run: background Blenders on this machine, or a Slurm "
                    "cluster this machine submits to",
        items=(("LOCAL", "This Machine", "Background Blenders on this machine, one per task"),
               ("SLURM", "Slurm", "Array jobs submitted with sbatch, one step after the other")))
    tasks: bpy.props.IntProperty(
        name="Tasks", default=4, min=1, soft_max=64,
        description="The bake and the render are each split into this many frame ranges")
    frame_start: bpy.props.IntProperty(name="From", default=0,
                                       description="First frame to render (0: the scene's)")
    frame_end: bpy.props.IntProperty(name="To", default=0,
                                     description="Last frame to render (0: the scene's)")

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self)

    def draw(self, context):
        col = self.layout.column()
        col.prop(self, "backend")
        col.prop(self, "tasks")
        row = col.row(align=True)
        row.prop(self, "frame_start")
        row.prop(self, "frame_end")

    def execute(self, context):
        return errors.run(self, self._submit, context)

    def _submit(self, context):
        if not bpy.data.filepath:
            raise ValueError("save the .blend first: the farm bakes and renders the file on "
                             "disk, and writes everything beside it")
        scene = context.scene
        r = scene.render
        size = (r.resolution_x * r.resolution_percentage // 100,
                r.resolution_y * r.resolution_percentage // 100)
        frames = (self.frame_start or scene.frame_start, self.frame_end or scene.frame_end)
        p = farm_plan.Plan(bpy.data.filepath, (scene.frame_start, scene.frame_end), frames,
                           self.tasks, size, bpy.app.binary_path or "blender")
        script = p.write(p.todo())  # readable even if what follows fails
        cmd = [python(), HERE, "run", p.blend, "--backend", self.backend.lower(),
               "--tasks", str(self.tasks), "--frames", f"{frames[0]}-{frames[1]}",
               "--blender", p.blender,
               "--scene", f"{scene.frame_start}-{scene.frame_end}:{size[0]}x{size[1]}"]
        log = p.path(p.farm, "logs", "farm.out")
        if bpy.data.is_dirty:  # a warning, not a refusal: Blender 4.3 reports a file as
            # changed right after saving it (seen in test_farm), which would block a saved file
            self.report({"WARNING"}, "The farm bakes and renders the .blend as saved on disk: "
                                     "changes since the last save are not in it")
        if self.backend == "SLURM":
            if shutil.which("sbatch") is None:
                raise ValueError("sbatch is not found on this machine: submit from a machine "
                                 f"of the Slurm cluster, with the job script {script}")
            proc = subprocess.run(cmd + ["--no-wait"], stdout=subprocess.PIPE,
                                  stderr=subprocess.STDOUT, text=True, errors="replace")
            with open(log, "w") as f:
                f.write(proc.stdout)
            if proc.returncode != 0:
                raise ValueError(f"the farm submission failed: {proc.stdout.strip()[-600:]}")
            self.report({"INFO"}, f"Submitted to Slurm ({script}); follow it with: "
                                  f"{cmd[0]} {HERE} watch {p.blend}")
            return {"FINISHED"}
        with open(log, "w") as f:  # detached: it outlives this Blender
            subprocess.Popen(cmd, stdout=f, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                             cwd=p.dir, start_new_session=True)
        self.report({"INFO"}, f"Farm started on this machine: {len(p.steps['bake'])} bake and "
                              f"{len(p.steps['render'])} render tasks; progress in {log}")
        return {"FINISHED"}


classes = (TUSSOCK_OT_farm_submit,)
