"""Run a SPlisHSPlasH scene with Meniscus' solver and compare it with SPlisHSPlasH's own output, frame by frame:
    target/python-venv/bin/python tools/compare-splishsplash.py ../shared/data/splishsplash/doubledambreak_sphere_25k \
        [--frames N] [--solver pbf|dfsph] [--adaptive-step] [--bin target/release/meniscus]
The folder holds scene.json and SPlisHSPlasH's partio/ParticleData_Fluid_<n>.bgeo. `meniscus sim FOLDER/scene.json`
writes the same frames (file n at t = (n − 1)/fps); per frame the table gives, for both: the front (the largest
|x| or |z| of any particle: how far the water has spread from the centre), the centre of mass height, the mean
kinetic energy per unit mass (½|v|², J/kg; equal particle masses in each run), and the run-up (the highest
particle within 3 r of a side wall: SPlisHSPlasH's boundary particles keep the water about 2 r from them), with the ratios Meniscus ÷ SPlisHSPlasH. Prints markdown."""
import argparse
import json
import pathlib
import subprocess
import sys
import tempfile

import numpy as np

import meniscus

ap = argparse.ArgumentParser()
ap.add_argument("folder")
ap.add_argument("--frames", type=int, default=None)
ap.add_argument("--bin", default=str(pathlib.Path(__file__).resolve().parents[1] / "target/release/meniscus"))
ap.add_argument("--solver", choices=["pbf", "dfsph"], default="pbf")
ap.add_argument("--adaptive-step", action="store_true", help="re-choose the step every frame (meniscus sim --adaptive-step)")
a = ap.parse_args()
folder = pathlib.Path(a.folder)
scene = json.loads((folder / "scene.json").read_text())
r = scene["Configuration"]["particleRadius"]
walls = [b for b in scene["RigidBodies"] if b.get("isWall")][0]
half = np.array(walls["scale"]) / 2
centre = np.array(walls["translation"])
lo, hi = centre - half, centre + half


def metrics(d):
    p, v = d["positions"], d.get("velocity")
    spread = max(np.abs(p[:, 0]).max(), np.abs(p[:, 2]).max())
    com = p[:, 1].mean()
    ke = 0.5 * (v ** 2).sum(axis=1).mean() if v is not None else float("nan")
    near = (p[:, 0] < lo[0] + 3 * r) | (p[:, 0] > hi[0] - 3 * r) | (p[:, 2] < lo[2] + 3 * r) | (p[:, 2] > hi[2] - 3 * r)
    runup = p[near, 1].max() if near.any() else 0.0
    return spread, com, ke, runup


with tempfile.TemporaryDirectory() as tmp:
    cmd = [a.bin, "sim", str(folder / "scene.json"), "--solver", a.solver, "--export", f"{tmp}/f_{{}}.bgeo"]
    if a.frames:
        cmd += ["--frames", str(a.frames)]
    if a.adaptive_step:
        cmd += ["--adaptive-step"]
    run = subprocess.run(cmd, capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(run.stderr)
    print("<!-- " + " ".join(cmd) + " -->")
    print("\n".join(l for l in run.stderr.strip().splitlines() if l.startswith(("sim:", "DFSPH")) or "median GPU" in l))
    print()
    print("| frame | t (s) | front S / M | ratio | centre of mass y S / M | ratio | ½v² (J/kg) S / M | ratio | run-up S / M | ratio |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    n = 1
    fps = scene["Configuration"].get("dataExportFPS", 25.0)
    worst = {"front": 0.0, "ke": 0.0}
    while (pathlib.Path(tmp) / f"f_{n}.bgeo").exists() and (folder / "partio" / f"ParticleData_Fluid_{n}.bgeo").exists():
        s = metrics(meniscus.load(str(folder / "partio" / f"ParticleData_Fluid_{n}.bgeo")))
        m = metrics(meniscus.load(f"{tmp}/f_{n}.bgeo"))
        ratio = [mi / si if si else float("nan") for si, mi in zip(s, m)]
        if n > 1:
            worst["front"] = max(worst["front"], abs(ratio[0] - 1))
            if n > 3:
                worst["ke"] = max(worst["ke"], abs(ratio[2] - 1))
        if n % 5 == 1 or n <= 3:
            print(f"| {n} | {(n - 1) / fps:.2f} | {s[0]:.3f} / {m[0]:.3f} | {ratio[0]:.3f} | {s[1]:.3f} / {m[1]:.3f} | "
                  f"{ratio[1]:.3f} | {s[2]:.3f} / {m[2]:.3f} | {ratio[2]:.3f} | {s[3]:.3f} / {m[3]:.3f} | {ratio[3]:.3f} |")
        n += 1
    print()
    print(f"largest deviation over frames 2–{n - 1}: front {100 * worst['front']:.1f} % (target 2 %); kinetic energy "
          f"(frames 4–{n - 1}, once the water moves) {100 * worst['ke']:.1f} % (target 10 %)")
