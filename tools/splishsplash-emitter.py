"""What SPlisHSPlasH's emitters do with a scene file, as the reference Meniscus' emitters are tested against
(tests/fixtures/splishsplash-emitter-reuse.json, from tests/fixtures/splishsplash-emitter-reuse.scene.json):
    target/python-venv/bin/python tools/splishsplash-emitter.py tests/fixtures/splishsplash-emitter-reuse.scene.json \
        [--seconds 1.6] [--fps 25] --out tests/fixtures/splishsplash-emitter-reuse.json
SPlisHSPlasH (the `pysplishsplash` wheel, `pip install pysplishsplash==2.19.0`; its headless simulator, no exports)
runs the scene to --seconds; a callback after every step records, at the first step at or past every 1/fps s, the
first fluid's active particles, the particles its emitters have emitted and reused in all, and the active particles
inside the recycling box (Materials[0].emitterBoxMin/Max; every active particle without one). The JSON (written
whole, never over the scene) holds the scene's name, the wheel's version and the rows [t, active, emitted, reused,
inside]. Loading the wheel and the scene's copy: tools/splishsplash_common.py."""
import argparse
import importlib.metadata
import json
import pathlib
import sys
import tempfile

import splishsplash_common

ap = argparse.ArgumentParser()
ap.add_argument("scene")
ap.add_argument("--seconds", type=float, default=1.6)
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
    m = s["Materials"][0]
    lo = m.get("emitterBoxMin", [-float("inf")] * 3)
    hi = m.get("emitterBoxMax", [float("inf")] * 3)
    rows = []
    nxt = [0.0]

    def after_step():
        t = sph.TimeManager.getCurrent().getTime()
        if t + 1e-9 < nxt[0]:
            return
        nxt[0] += 1.0 / a.fps
        fm = sph.Simulation.getCurrent().getFluidModel(0)
        es = fm.getEmitterSystem()
        n = fm.numActiveParticles()
        inside = 0
        for i in range(n):
            x = fm.getPosition(i)
            inside += all(lo[k] <= float(x[k]) <= hi[k] for k in range(3))
        rows.append([t, n, es.numEmittedParticles(), es.numReusedParticles(), inside])

    splishsplash_common.run(sph, copy, tmp, a.seconds, after_step)

doc = {
    "scene": scene.name,
    "pysplishsplash": importlib.metadata.version("pysplishsplash"),
    "seconds": a.seconds,
    "fps": a.fps,
    "columns": ["t", "active", "emitted", "reused", "inside"],
    "rows": rows,
}
tmp_out = out.with_suffix(out.suffix + ".partial")
tmp_out.write_text(json.dumps(doc, indent=1) + "\n")
tmp_out.replace(out)
print(f"wrote {out}: {len(rows)} rows")
