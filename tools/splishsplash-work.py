"""How much solver work SPlisHSPlasH's own DFSPH does on a scene, beside Meniscus running the same scene file:
    target/python-venv/bin/python tools/splishsplash-work.py ../shared/data/splishsplash/dambreak_59k/scene.json \
        [--seconds 0.32] [--bin target/release/meniscus] [--settings S.toml]
SPlisHSPlasH (the `pysplishsplash` wheel, `pip install pysplishsplash`; its headless simulator, no exports) runs the
scene to --seconds; a callback after every step records the time, the step size and the constant-density and
divergence-free solves' iterations. Then `meniscus sim SCENE --frames N` (DFSPH and PBF, both with the file's
adaptive step) runs the same simulated time. Prints markdown: per exported frame (1/25 s) SPlisHSPlasH's steps and
iterations, and the totals of both — steps, corrections per step, corrections in all, wall seconds on this host
(SPlisHSPlasH natively on the CPU's cores, Meniscus on its Vulkan device). Loading the wheel and the scene's
copy: tools/splishsplash_common.py."""
import argparse
import pathlib
import re
import subprocess
import sys
import tempfile
import time

import splishsplash_common

ap = argparse.ArgumentParser()
ap.add_argument("scene")
ap.add_argument("--seconds", type=float, default=0.32)
ap.add_argument("--fps", type=float, default=25.0)
ap.add_argument("--bin", default=str(pathlib.Path(__file__).resolve().parents[1] / "target/release/meniscus"))
ap.add_argument("--settings", default=None, help="a Meniscus settings file for both Meniscus runs")
a = ap.parse_args()

sph = splishsplash_common.load()

scene = pathlib.Path(a.scene).resolve()
frame = 1.0 / a.fps
frames = round(a.seconds * a.fps)

with tempfile.TemporaryDirectory() as tmp:
    copy, _ = splishsplash_common.scene_copy(scene, tmp, a.seconds)
    rows = []

    def after_step():
        ts = sph.Simulation.getCurrent().getTimeStep()
        tm = sph.TimeManager.getCurrent()
        rows.append((tm.getTime(), tm.getTimeStepSize(), ts.getValueInt(ts.SOLVER_ITERATIONS),
                     ts.getValueInt(ts.SOLVER_ITERATIONS_V)))

    t0 = time.time()
    splishsplash_common.run(sph, copy, tmp, a.seconds, after_step)
    splash_wall = time.time() - t0


def meniscus(solver):
    cmd = [a.bin, "sim", str(scene), "--frames", str(frames + 1), "--solver", solver]
    if a.settings:
        cmd += ["--settings", a.settings]
    t0 = time.time()
    out = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.time() - t0
    if out.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{out.stderr}")
    text = out.stdout + out.stderr
    steps = int(re.search(r"of (\d+) steps at the iteration limit", text).group(1)) if solver == "dfsph" else None
    per = {k: float(m.group(1)) for k, m in (
        ("density", re.search(r"constant-density solve: ([\d.]+) corrections per step", text)),
        ("divergence", re.search(r"divergence-free solve: ([\d.]+) corrections per step", text))) if m}
    rng = re.search(r"adaptive step: (\d+)–(\d+) steps per frame", text)
    return wall, steps, per, rng.groups() if rng else None, cmd


print(f"# Solver work on {scene.parent.name}/{scene.name}, {frames} frames ({a.seconds} s simulated)\n")
print("SPlisHSPlasH (pysplishsplash, DFSPH as the file sets it), per frame:\n")
print("| frame | t (s) | steps | Δt (ms) | density iterations per step (most) | divergence iterations per step (most) |")
print("|---:|---:|---:|---|---|---|")
for f in range(frames):
    r = [x for x in rows if f * frame <= x[0] - 1e-9 < (f + 1) * frame]
    if r:
        dt = [x[1] * 1e3 for x in r]
        print(f"| {f + 1} | {f * frame:.2f} | {len(r)} | {min(dt):.2f}–{max(dt):.2f} | "
              f"{sum(x[2] for x in r) / len(r):.1f} ({max(x[2] for x in r)}) | "
              f"{sum(x[3] for x in r) / len(r):.1f} ({max(x[3] for x in r)}) |")
n = len(rows)
dens, div = sum(x[2] for x in rows), sum(x[3] for x in rows)
print("\nTotals:\n")
print("| run | steps | corrections per step: density + divergence | corrections | wall (s) |")
print("|---|---:|---|---:|---:|")
print(f"| SPlisHSPlasH DFSPH | {n} | {dens / n:.1f} + {div / n:.1f} | {dens + div} | {splash_wall:.1f} |")
for solver in ("dfsph", "pbf"):
    wall, steps, per, rng, cmd = meniscus(solver)
    if solver == "dfsph":
        c = per.get("density", 0) + per.get("divergence", 0)
        print(f"| Meniscus DFSPH | {steps} | {per.get('density', 0):.1f} + {per.get('divergence', 0):.1f} | "
              f"{round(c * steps)} | {wall:.1f} |")
    else:
        print(f"| Meniscus PBF (4 iterations) | {rng[0]}–{rng[1]} per frame | – | – | {wall:.1f} |")
print(f"\n(`{' '.join(cmd[:2])} SCENE --frames {frames + 1} --solver dfsph|pbf`: frame 1 is the initial state.)")
