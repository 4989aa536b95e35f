"""Run the GPU simulation of a dam break and write frames rendered from the particles on the GPU (no copy
through the host) plus a particle count per frame (usage: python simulate.py out/)."""
import pathlib, sys
import meniscus
from PIL import Image

out = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "sim-frames")
out.mkdir(parents=True, exist_ok=True)
sim = meniscus.Simulation("dambreak", particles=20_000)
r = meniscus.Renderer(640, 360)
for n in range(50):
    sim.step()
    Image.fromarray(r.render(sim)).save(out / f"f_{n:04}.png")
    print(f"frame {n}: {sim.count} particles, highest at y = {sim.positions()[:, 1].max():.3f} m")
