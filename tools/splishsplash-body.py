"""The dynamic rigid bodies' trajectories SPlisHSPlasH itself computes for a scene file, as the reference
Meniscus' bodies are tested against (tests/fixtures/splishsplash-doubledambreak-sphere.json):
    target/python-venv/bin/python tools/splishsplash-body.py ../shared/data/splishsplash/doubledambreak_sphere_25k/scene.json \
        [--seconds 1.0] [--fps 25] --out tests/fixtures/splishsplash-doubledambreak-sphere.json
SPlisHSPlasH (the `pysplishsplash` wheel, `pip install pysplishsplash==2.19.0`; its headless simulator, no exports)
runs the scene to --seconds; a callback after every step records each dynamic body's position and velocity at
the first step at or past every 1/fps s. The JSON (written whole, never over the scene) holds the scene's name,
the wheel's version, and per body its index in RigidBodies and the rows [t, x, y, z, vx, vy, vz]. Loading the
wheel, the scene's copy, the arguments and the writing: tools/splishsplash_common.py."""
import tempfile

import splishsplash_common

a, scene, out = splishsplash_common.recording_args(1.0)
sph = splishsplash_common.load()

with tempfile.TemporaryDirectory() as tmp:
    copy, s = splishsplash_common.scene_copy(scene, tmp, a.seconds)
    dynamic = [k for k, body in enumerate(s.get("RigidBodies", [])) if body.get("isDynamic")]
    rows = {k: [] for k in dynamic}

    def record(t):
        sim = sph.Simulation.getCurrent()
        for k in dynamic:
            rb = sim.getBoundaryModel(k).getRigidBodyObject()
            p, v = rb.getPosition(), rb.getVelocity()
            rows[k].append([t, float(p[0]), float(p[1]), float(p[2]), float(v[0]), float(v[1]), float(v[2])])

    splishsplash_common.run_per_frame(sph, copy, tmp, a.seconds, a.fps, record)

splishsplash_common.write_record(out, f"{scene.parent.name}/{scene.name}", a, {
    "columns": ["t", "x", "y", "z", "vx", "vy", "vz"],
    "bodies": [{"index": k, "rows": rows[k]} for k in dynamic],
})
print(f"wrote {out}: {', '.join(f'body {k}: {len(rows[k])} rows' for k in dynamic)}")
