"""Run a SPlisHSPlasH scene with Meniscus' solver and compare it with SPlisHSPlasH's own output, frame by frame:
    target/python-venv/bin/python tools/compare-splishsplash.py ../shared/data/splishsplash/doubledambreak_sphere_25k \
        [--frames N] [--solver pbf|dfsph] [--adaptive-step] [--bin target/release/meniscus]
The folder holds scene.json and SPlisHSPlasH's partio/ParticleData_Fluid_<n>.bgeo. `meniscus sim FOLDER/scene.json`
writes the same frames (file n at t = (n − 1)/fps); per frame the table gives the observables of
src/sim/observe.rs (docs/simulation.md, "Against SPlisHSPlasH on the shared double dam break"): occupancy IoU of a
grid of cell 2 r, the height field's RMS difference (radii), kinetic and potential energy per unit mass (relative
difference), the centres of mass's distance (radii), and the run-up (the highest particle within 3 r of a side
wall) of both. The gate is tests/sim.rs's. Prints markdown."""
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


G = 9.81
GATE = {"iou": 0.25, "height": 20.0, "ke": 0.10, "pe": 0.30, "centre": 5.0}  # tests/sim.rs's


def runup(p):
    near = (p[:, 0] < lo[0] + 3 * r) | (p[:, 0] > hi[0] - 3 * r) | (p[:, 2] < lo[2] + 3 * r) | (p[:, 2] > hi[2] - 3 * r)
    return p[near, 1].max() if near.any() else 0.0


def compare(a, b):
    """src/sim/observe.rs's compare(a, b): the grid of edge 2 r anchored at the tank's lower corner."""
    pa, pb = a["positions"].astype(np.float64), b["positions"].astype(np.float64)
    ca, cb = np.floor((pa - lo) / (2 * r)).astype(np.int64), np.floor((pb - lo) / (2 * r)).astype(np.int64)
    sa, sb = set(map(tuple, ca)), set(map(tuple, cb))
    iou = len(sa & sb) / max(len(sa | sb), 1)

    def heights(c, p):
        h = {}
        for (i, _, k), y in zip(c, p[:, 1]):
            h[(i, k)] = max(h.get((i, k), -np.inf), y)
        return h
    ha, hb = heights(ca, pa), heights(cb, pb)
    cols = set(ha) | set(hb)
    height = np.sqrt(np.mean([(ha.get(k, lo[1]) - hb.get(k, lo[1])) ** 2 for k in cols])) / r
    ke = lambda d: 0.5 * (d["velocity"].astype(np.float64) ** 2).sum(axis=1).mean()
    pe = lambda p: G * (p[:, 1].mean() - lo[1])
    return {"iou": iou, "height": height, "ke": abs(ke(a) - ke(b)) / ke(b) if ke(b) else float("nan"),
            "pe": abs(pe(pa) - pe(pb)) / pe(pb), "centre": np.linalg.norm(pa.mean(0) - pb.mean(0)) / r,
            "runup": (runup(pb), runup(pa))}


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
    print("| frame | t (s) | IoU | height field (r) | kinetic energy | potential energy | centres apart (r) | run-up S / M (m) |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")
    n = 1
    fps = scene["Configuration"].get("dataExportFPS", 25.0)
    worst = {"iou": 1.0, "height": 0.0, "ke": 0.0, "pe": 0.0, "centre": 0.0}
    while (pathlib.Path(tmp) / f"f_{n}.bgeo").exists() and (folder / "partio" / f"ParticleData_Fluid_{n}.bgeo").exists():
        x = compare(meniscus.load(f"{tmp}/f_{n}.bgeo"), meniscus.load(str(folder / "partio" / f"ParticleData_Fluid_{n}.bgeo")))
        if n > 1:
            worst["iou"] = min(worst["iou"], x["iou"])
            for k in ("height", "pe", "centre"):
                worst[k] = max(worst[k], x[k])
            if n > 3:
                worst["ke"] = max(worst["ke"], x["ke"])
        if n % 5 == 1 or n <= 3:
            print(f"| {n} | {(n - 1) / fps:.2f} | {x['iou']:.3f} | {x['height']:.1f} | {100 * x['ke']:.1f} % | "
                  f"{100 * x['pe']:.1f} % | {x['centre']:.1f} | {x['runup'][0]:.3f} / {x['runup'][1]:.3f} |")
        n += 1
    print()
    ok = worst["iou"] >= GATE["iou"] and all(worst[k] <= GATE[k] for k in ("height", "ke", "pe", "centre"))
    print(f"worst over frames 2–{n - 1}: IoU {worst['iou']:.3f} (gate ≥ {GATE['iou']}), height field "
          f"{worst['height']:.1f} r (≤ {GATE['height']}), kinetic energy {100 * worst['ke']:.1f} % (frames 4 on; "
          f"≤ {100 * GATE['ke']:.0f} %), potential energy {100 * worst['pe']:.1f} % (≤ {100 * GATE['pe']:.0f} %), "
          f"centres {worst['centre']:.1f} r apart (≤ {GATE['centre']}): {'within the gate' if ok else 'OUTSIDE the gate'}")
    sys.exit(0 if ok else 1)
