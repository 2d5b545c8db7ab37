"""Render farms: one command bakes and renders a saved .blend as a plan of tasks (the bake
split into frame ranges, one assembly of the caches, the render split into frame ranges),
run by N local `blender -b` processes or by Slurm array jobs. Everything here but
submit.py is plain Python without bpy, so it runs outside Blender:

    python3 <add-on folder>/farm run scene.blend [--backend local|slurm] [--tasks N] ...

(see docs/farm.md and cli.py)."""
