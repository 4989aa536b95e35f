"""Render the README's Blender picture with the add-on (blender/meniscus_water), headless:
    target/python-venv/bin/python tools/blender-picture.py OUT.png [FRAME]
Blender as a Python module (`pip install bpy==5.0.*`, CPython 3.11) and the `meniscus` package must be
installed. The shared 59k dam break, the reference camera (0, 2.5, 6) → (0, 0.3, 0) in the files' y-up frame,
a sun, a grey floor, Cycles on the CPU."""
import pathlib
import sys

import bpy
import mathutils

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "blender"))
import meniscus_water  # noqa: E402

out = pathlib.Path(sys.argv[1]).resolve()
frame = int(sys.argv[2]) if len(sys.argv) > 2 else 20
bpy.ops.wm.read_factory_settings(use_empty=True)
meniscus_water.register()
scene = bpy.context.scene
s = scene.meniscus_water
s.source = str(ROOT.parent / "shared/data/splishsplash/dambreak_59k/partio/ParticleData_Fluid_1.bgeo")
s.use_gpu = False
scene.frame_set(frame)
assert bpy.ops.meniscus.import_sequence() == {"FINISHED"}
scene.frame_set(frame)
cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
scene.collection.objects.link(cam)
cam.location = (0.0, -6.0, 2.5)
cam.rotation_euler = (mathutils.Vector((0.0, 0.0, 0.3)) - cam.location).to_track_quat("-Z", "Y").to_euler()
cam.data.angle = 0.785  # 45° horizontal
scene.camera = cam
sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
sun.data.energy = 3.0
scene.collection.objects.link(sun)
sun.rotation_euler = (0.7, 0.3, 0.4)
bpy.ops.mesh.primitive_plane_add(size=12.0, location=(0.0, 0.0, 0.0))
floor = bpy.context.active_object
mat = bpy.data.materials.new("floor")
if mat.node_tree is None:
    mat.use_nodes = True
bsdf = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
tex = mat.node_tree.nodes.new("ShaderNodeTexChecker")
tex.inputs["Scale"].default_value = 24.0
tex.inputs["Color1"].default_value = (0.55, 0.55, 0.55, 1.0)
tex.inputs["Color2"].default_value = (0.3, 0.3, 0.32, 1.0)
mat.node_tree.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
floor.data.materials.append(mat)
world = scene.world or bpy.data.worlds.new("world")
scene.world = world
if world.node_tree is None:
    world.use_nodes = True
bg = next(n for n in world.node_tree.nodes if n.type == "BACKGROUND")
bg.inputs["Color"].default_value = (0.6, 0.7, 0.85, 1.0)
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = 48
scene.cycles.use_denoising = True
scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 960, 540, 100
scene.render.filepath = str(out)
bpy.ops.render.render(write_still=True)
print(f"wrote {out}")
