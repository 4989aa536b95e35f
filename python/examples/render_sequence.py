"""Render a SPlisHSPlasH sequence to PNGs (usage: python render_sequence.py 'dir/ParticleData_Fluid_{}.bgeo' out/)."""
import pathlib, sys
import meniscus
from PIL import Image

pattern, out = sys.argv[1], pathlib.Path(sys.argv[2])
out.mkdir(parents=True, exist_ok=True)
r = meniscus.Renderer(960, 540)
camera = ((0.0, 2.5, 6.0), (0.0, 0.3, 0.0), 45.0)   # one camera for the whole sequence
for n in range(1, 52):
    frame = meniscus.load(pattern.replace("{}", str(n)))
    Image.fromarray(r.render(frame["positions"], particle_radius=0.0125, camera=camera)).save(out / f"f_{n:04}.png")
