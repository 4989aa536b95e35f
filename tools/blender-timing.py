"""The Blender add-on's time per frame against `meniscus mesh`'s, interleaved:
    target/python-venv/bin/python tools/blender-timing.py [REPEATS]
For frames 20 and 21 of the shared 59k dam break (0.5 r, CPU extraction, all cores in both): the add-on's whole
frame change (load, mesh, velocities, filling the Blender mesh) and a `meniscus mesh FILE --out f.ply` process
(load, mesh, write). Prints each pair and the median ratio. Needs bpy 5.0 and the `meniscus` package."""
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

import bpy

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "blender"))
import meniscus_water  # noqa: E402

repeats = int(sys.argv[1]) if len(sys.argv) > 1 else 3
cli = ROOT / "target/release/meniscus"
seq = ROOT.parent / "shared/data/splishsplash/dambreak_59k/partio"
bpy.ops.wm.read_factory_settings(use_empty=True)
meniscus_water.register()
scene = bpy.context.scene
s = scene.meniscus_water
s.source = str(seq / "ParticleData_Fluid_20.bgeo")
s.use_gpu = False
s.cache_frames = 0
scene.frame_set(20)
bpy.ops.meniscus.import_sequence()
ratios = []
with tempfile.TemporaryDirectory() as tmp:
    for rep in range(repeats):
        for n in (20, 21):
            t0 = time.perf_counter()
            scene.frame_set(n)
            t_blender = time.perf_counter() - t0
            t0 = time.perf_counter()
            subprocess.run([str(cli), "mesh", str(seq / f"ParticleData_Fluid_{n}.bgeo"), "--out",
                            f"{tmp}/f{rep}_{n}.ply"], check=True, capture_output=True)
            t_cli = time.perf_counter() - t0
            ratios.append(t_blender / t_cli)
            print(f"frame {n}: add-on {t_blender:.3f} s, meniscus mesh {t_cli:.3f} s, ratio {ratios[-1]:.2f}")
print(f"median ratio {statistics.median(ratios):.2f} over {len(ratios)} pairs")
