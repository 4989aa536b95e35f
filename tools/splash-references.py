#!/usr/bin/env python3
"""Reference surfaces for a splash: splashsurf's raw and smoothed reconstructions of particle files, rasterised
to depth images at one camera, as ../shared/data/quality/ holds them for the shared frames (same parameters:
-r R -l 2.0 -c 0.5 -t 0.6; smoothed: --mesh-cleanup, --mesh-smoothing-weights, 25 mesh and 10 normal smoothing
iterations). Needs pysplashsurf (pip) and the meniscus package (`pip install ./python`) in the Python that runs
it (pysplashsurf's mesh output needs meshio: `pip install pysplashsurf meshio`), and the `meniscus` binary
(MENISCUS_BIN, default target/release/meniscus), whose `quality --depth MESH --depth-out NPY` ray-casts a mesh.

Usage: tools/splash-references.py OUTDIR RADIUS EYE TARGET FILE… — writes OUTDIR/<stem>_ref_depth.npy and
OUTDIR/<stem>_smooth_ref_depth.npy per file (960×540, 45°), for tools/quality.sh with SCENE=custom."""
import os
import subprocess
import sys

import meniscus
import numpy as np
import pysplashsurf

out, radius, eye, target = sys.argv[1], float(sys.argv[2]), sys.argv[3], sys.argv[4]
m = os.environ.get("MENISCUS_BIN", "target/release/meniscus")
os.makedirs(out, exist_ok=True)
for f in sys.argv[5:]:
    stem = os.path.splitext(os.path.basename(f))[0]
    pos = meniscus.load(f)["positions"].astype(np.float64)
    for kind, extra in (
        ("ref", {}),
        ("smooth_ref", dict(mesh_cleanup=True, mesh_smoothing_weights=True, mesh_smoothing_iters=25,
                            normals_smoothing_iters=10)),
    ):
        mesh, _ = pysplashsurf.reconstruction_pipeline(pos, particle_radius=radius, smoothing_length=2.0,
                                                       cube_size=0.5, iso_surface_threshold=0.6, **extra)
        obj = os.path.join(out, f"{stem}_{kind}.obj")
        mesh.write_to_file(obj)
        subprocess.run([m, "quality", f, "--radius", str(radius), "--camera", f"{eye}:{target}:45",
                        "--width", "960", "--height", "540", "--depth", obj,
                        "--depth-out", os.path.join(out, f"{stem}_{kind}_depth.npy")], check=True)
        print(f"{f}: {kind} → {out}/{stem}_{kind}_depth.npy")
