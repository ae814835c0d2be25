"""Optional check (not run by .ci/run: Blender as a Python module is a ~400 MB download): a run's animation.glb
imported by Blender's own glTF importer plays the run.

    python3 -m venv /tmp/bpy && /tmp/bpy/bin/pip install bpy
    /tmp/bpy/bin/python .ci/optional/blender_check.py RUN_DIR

Checks that the cloth comes in with one shape key per later frame and the action "simulation", that the
obstacles come in, that the z-up world is restored, and that at the end of the timeline the cloth has the run's
final height range (summary.json). Exit status 1 on a failed check.
"""

import json
import sys

import bpy

run = sys.argv[-1]
summary = json.load(open(f"{run}/summary.json"))
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=f"{run}/animation.glb")
objects = {o.name: o for o in bpy.data.objects}
failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


cloth = objects.get("cloth")
check(cloth is not None, f"the cloth object is imported ({sorted(objects)})")
keys = cloth.data.shape_keys
frames = summary["frames"]
check(keys is not None and len(keys.key_blocks) == len(frames), f"{len(keys.key_blocks) if keys else 0} shape keys (Basis + one per later frame) for {len(frames)} frames")
action = keys.animation_data.action if keys and keys.animation_data else None
check(action is not None and action.name == "simulation", f"the shape keys are animated by {action.name if action else None}")
check(any(n.startswith("obstacle_") for n in objects), "the obstacles are imported")
check(len(cloth.data.uv_layers) == 1, "the cloth has its UV layer")
scene = bpy.context.scene
end = int(round(frames[-1]["time"] * scene.render.fps)) + 1
scene.frame_set(end + 5)
evaluated = cloth.evaluated_get(bpy.context.evaluated_depsgraph_get())
mesh = evaluated.to_mesh()
z = [(evaluated.matrix_world @ v.co).z for v in mesh.vertices]
final = summary["final"]
# The Coons mesh's bounding box: its z extent is that of the final frame.
check(abs(min(z) - final["bbox_min"][2]) < 1e-4 and abs(max(z) - final["bbox_max"][2]) < 1e-4,
      f"at the end the cloth spans z {min(z):.4f} .. {max(z):.4f} m (summary: {final['bbox_min'][2]:.4f} .. {final['bbox_max'][2]:.4f})")
sys.exit(1 if failures else 0)
