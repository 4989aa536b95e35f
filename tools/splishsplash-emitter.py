"""What SPlisHSPlasH's emitters do with a scene file, as the reference Meniscus' emitters are tested against
(tests/fixtures/splishsplash-emitter-reuse.json, from tests/fixtures/splishsplash-emitter-reuse.scene.json):
    target/python-venv/bin/python tools/splishsplash-emitter.py tests/fixtures/splishsplash-emitter-reuse.scene.json \
        [--seconds 1.6] [--fps 25] --out tests/fixtures/splishsplash-emitter-reuse.json
SPlisHSPlasH (the `pysplishsplash` wheel, `pip install pysplishsplash==2.19.0`; its headless simulator, no exports)
runs the scene to --seconds; a callback after every step records, at the first step at or past every 1/fps s, the
first fluid's active particles, the particles its emitters have emitted and reused in all, and the active particles
inside the recycling box (Materials[0].emitterBoxMin/Max; every active particle without one). The JSON (written
whole, never over the scene) holds the scene's name, the wheel's version and the rows [t, active, emitted, reused,
inside]. Loading the wheel, the scene's copy, the arguments and the writing: tools/splishsplash_common.py."""
import tempfile

import splishsplash_common

a, scene, out = splishsplash_common.recording_args(1.6)
sph = splishsplash_common.load()

with tempfile.TemporaryDirectory() as tmp:
    copy, s = splishsplash_common.scene_copy(scene, tmp, a.seconds)
    m = s["Materials"][0]
    lo = m.get("emitterBoxMin", [-float("inf")] * 3)
    hi = m.get("emitterBoxMax", [float("inf")] * 3)
    rows = []

    def record(t):
        fm = sph.Simulation.getCurrent().getFluidModel(0)
        es = fm.getEmitterSystem()
        n = fm.numActiveParticles()
        inside = 0
        for i in range(n):
            x = fm.getPosition(i)
            inside += all(lo[k] <= float(x[k]) <= hi[k] for k in range(3))
        rows.append([t, n, es.numEmittedParticles(), es.numReusedParticles(), inside])

    splishsplash_common.run_per_frame(sph, copy, tmp, a.seconds, a.fps, record)

splishsplash_common.write_record(out, scene.name, a, {"columns": ["t", "active", "emitted", "reused", "inside"], "rows": rows})
print(f"wrote {out}: {len(rows)} rows")
