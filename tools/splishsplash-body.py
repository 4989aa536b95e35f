"""The dynamic rigid bodies' trajectories SPlisHSPlasH itself computes for a scene file, as the reference
Meniscus' bodies are tested against (tests/fixtures/splishsplash-doubledambreak-sphere.json):
    target/python-venv/bin/python tools/splishsplash-body.py ../shared/data/splishsplash/doubledambreak_sphere_25k/scene.json \
        [--seconds 1.0] [--fps 25] --out tests/fixtures/splishsplash-doubledambreak-sphere.json
SPlisHSPlasH (the `pysplishsplash` wheel, `pip install pysplishsplash==2.19.0`; its headless simulator, no exports)
runs the scene to --seconds; a callback after every step records each dynamic body's position and velocity at
the first step at or past every 1/fps s. The JSON (written whole, never over the scene) holds the scene's name,
the wheel's version, and per body its index in RigidBodies and the rows [t, x, y, z, vx, vy, vz]. Loading the
wheel and the scene's copy: tools/splishsplash_common.py."""
import argparse
import importlib.metadata
import json
import pathlib
import sys
import tempfile

import splishsplash_common

ap = argparse.ArgumentParser()
ap.add_argument("scene")
ap.add_argument("--seconds", type=float, default=1.0)
ap.add_argument("--fps", type=float, default=25.0)
ap.add_argument("--out", required=True)
a = ap.parse_args()

sph = splishsplash_common.load()

scene = pathlib.Path(a.scene).resolve()
out = pathlib.Path(a.out).resolve()
if out == scene:
    sys.exit(f"--out {out} is the scene itself")

with tempfile.TemporaryDirectory() as tmp:
    copy, s = splishsplash_common.scene_copy(scene, tmp, a.seconds)
    dynamic = [k for k, body in enumerate(s.get("RigidBodies", [])) if body.get("isDynamic")]
    rows = {k: [] for k in dynamic}
    nxt = [0.0]

    def after_step():
        t = sph.TimeManager.getCurrent().getTime()
        if t + 1e-9 < nxt[0]:
            return
        nxt[0] += 1.0 / a.fps
        sim = sph.Simulation.getCurrent()
        for k in dynamic:
            rb = sim.getBoundaryModel(k).getRigidBodyObject()
            p, v = rb.getPosition(), rb.getVelocity()
            rows[k].append([t, float(p[0]), float(p[1]), float(p[2]), float(v[0]), float(v[1]), float(v[2])])

    splishsplash_common.run(sph, copy, tmp, a.seconds, after_step)

doc = {
    "scene": f"{scene.parent.name}/{scene.name}",
    "pysplishsplash": importlib.metadata.version("pysplishsplash"),
    "seconds": a.seconds,
    "fps": a.fps,
    "columns": ["t", "x", "y", "z", "vx", "vy", "vz"],
    "bodies": [{"index": k, "rows": rows[k]} for k in dynamic],
}
tmp_out = out.with_suffix(out.suffix + ".partial")
tmp_out.write_text(json.dumps(doc, indent=1) + "\n")
tmp_out.replace(out)
print(f"wrote {out}: {', '.join(f'body {k}: {len(rows[k])} rows' for k in dynamic)}")
