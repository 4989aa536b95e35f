"""The dynamic rigid bodies' trajectories SPlisHSPlasH itself computes for a scene file, as the reference
Meniscus' bodies are tested against (tests/fixtures/splishsplash-doubledambreak-sphere.json):
    target/python-venv/bin/python tools/splishsplash-body.py ../shared/data/splishsplash/doubledambreak_sphere_25k/scene.json \
        [--seconds 1.0] [--fps 25] --out tests/fixtures/splishsplash-doubledambreak-sphere.json
SPlisHSPlasH (the `pysplishsplash` wheel, `pip install pysplishsplash==2.19.0`; its headless simulator, no exports)
runs the scene to --seconds; a callback after every step records each dynamic body's position and velocity at
the first step at or past every 1/fps s. The JSON (written whole, never over the scene) holds the scene's name,
the wheel's version, and per body its index in RigidBodies and the rows [t, x, y, z, vx, vy, vz]. The wheel
bundles its own libGLdispatch/libGLX, which crash beside the system's libGLX at import: the script re-runs
itself with them preloaded (as tools/splishsplash-work.py does)."""
import argparse
import importlib.metadata
import importlib.util
import json
import os
import pathlib
import subprocess
import sys
import tempfile

ap = argparse.ArgumentParser()
ap.add_argument("scene")
ap.add_argument("--seconds", type=float, default=1.0)
ap.add_argument("--fps", type=float, default=25.0)
ap.add_argument("--out", required=True)
a = ap.parse_args()

spec = importlib.util.find_spec("pysplishsplash")
if spec is None:
    sys.exit("pysplishsplash is not installed: pip install pysplishsplash==2.19.0")
libs = pathlib.Path(spec.origin).parent / "pysplishsplash.libs"
if "MENISCUS_SPLASH_PRELOADED" not in os.environ and libs.is_dir():
    pre = [str(p) for n in ("libGLdispatch", "libGLX") for p in sorted(libs.glob(n + "-*"))]
    env = dict(os.environ, MENISCUS_SPLASH_PRELOADED="1", LD_PRELOAD=" ".join(pre))
    sys.exit(subprocess.run([sys.executable] + sys.argv, env=env).returncode)

import pysplishsplash as sph  # noqa: E402  (after the preload above)

scene = pathlib.Path(a.scene).resolve()
out = pathlib.Path(a.out).resolve()
if out == scene:
    sys.exit(f"--out {out} is the scene itself")

with tempfile.TemporaryDirectory() as tmp:
    s = json.loads(scene.read_text())
    s["Configuration"].update(stopAt=a.seconds, enablePartioExport=False, enableVTKExport=False)
    dynamic = []
    for k, body in enumerate(s.get("RigidBodies", [])):
        if "geometryFile" in body:
            body["geometryFile"] = str((scene.parent / body["geometryFile"]).resolve())
        body.pop("particleFile", None)
        if body.get("isDynamic"):
            dynamic.append(k)
    copy = pathlib.Path(tmp) / "scene.json"
    copy.write_text(json.dumps(s))
    rows = {k: [] for k in dynamic}
    base = sph.Exec.SimulatorBase()
    base.init(useGui=False, outputDir=str(pathlib.Path(tmp) / "out"), sceneFile=str(copy))
    base.setValueFloat(base.STOP_AT, a.seconds)
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

    base.setTimeStepCB(after_step)
    base.run()

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
