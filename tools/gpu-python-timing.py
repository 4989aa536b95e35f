"""The Python package's per-call cost on a device (#46: `Renderer.render` at 1080p ≤ 6 ms per call): renders the
59k dam-break frame through `meniscus.Renderer` and prints the wall time per call beside the GPU passes' times,
then the live simulation's step + render and the positions read-back at 1M particles, and (#72) the surface
mesher for simulators: a `Reconstructor` on the device meshing the 59k frame and the 1M-particle simulation's
positions at 1 r, per call including the read-back, beside one-shot `reconstruct_surface` calls.

Usage: python3 tools/gpu-python-timing.py FRAME.bgeo [--calls N] [--no-sim] [--sizes 1920x1080,960x540]
(the GPU bundle's `python` step runs it; on lavapipe `--no-sim --sizes 960x540` leaves out the 1M simulation)
"""
import argparse
import sys
import time

import numpy as np

import meniscus


def per_call(fn, calls):
    fn()  # the first call creates pipelines and images
    fn()
    t = []
    for _ in range(calls):
        t0 = time.perf_counter()
        fn()
        t.append(time.perf_counter() - t0)
    return 1e3 * float(np.median(t))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("frame")
    ap.add_argument("--calls", type=int, default=20)
    ap.add_argument("--no-sim", action="store_true", help="leave out the 1M-particle simulation")
    ap.add_argument("--sizes", default="1920x1080,960x540", help="output sizes, WxH,…")
    a = ap.parse_args()
    print("device:", meniscus.device_info())
    d = meniscus.load(a.frame)
    pts = d["positions"]
    attrs = {"id": d["id"]} if "id" in d else None
    cam = ((0.0, 2.5, 6.0), (0.0, 0.3, 0.0), 45.0)
    for preset in ("default", "fast"):
        for w, h in (tuple(int(x) for x in s.split("x")) for s in a.sizes.split(",")):
            r = meniscus.Renderer(w, h, preset=preset)
            ms = per_call(lambda: r.render(pts, particle_radius=0.0125, camera=cam, attributes=attrs), a.calls)
            gpu = sum(r.timings().values())
            print(f"render 59k {preset} {w}x{h}, the same particles each call: {ms:.2f} ms/call wall (median of "
                  f"{a.calls}), GPU passes {gpu:.2f} ms, host share {ms - gpu:.2f} ms")
            print("    host:", {k: round(v, 3) for k, v in r.host_timings().items()})
            # New particles every call (two arrays alternated): uploaded and prepared each time.
            both = [pts, pts + np.float32(1e-6)]
            k = [0]

            def alternate():
                k[0] ^= 1
                r.render(both[k[0]], particle_radius=0.0125, camera=cam, attributes=attrs)
            ms = per_call(alternate, a.calls)
            gpu = sum(r.timings().values())
            print(f"render 59k {preset} {w}x{h}, new particles each call: {ms:.2f} ms/call wall, GPU passes "
                  f"{gpu:.2f} ms, host share {ms - gpu:.2f} ms")
            print("    GPU:", {k: round(v, 3) for k, v in r.timings().items()})
            print("    host:", {k: round(v, 3) for k, v in r.host_timings().items()})
    if a.no_sim:
        return 0
    sim = meniscus.Simulation("dambreak", particles=1_000_000)
    r = meniscus.Renderer(1920, 1080)
    ms = per_call(lambda: (sim.step(1), r.render(sim)), 10)
    print(f"sim 1M step+render (default, 1080p): {ms:.2f} ms per frame; render passes {sum(r.timings().values()):.2f} ms")
    ms = per_call(lambda: sim.positions(), 10)
    print(f"positions() 1M read-back: {ms:.2f} ms")
    # The mesher for simulators: device, pipelines and buffers kept between calls (target: 1M at 1 r ≤ 20 ms).
    million = sim.positions()
    for label, p, radius in (("59k frame", pts, 0.0125), ("1M sim", million, sim.particle_radius)):
        rec = meniscus.Reconstructor(particle_radius=radius, cube_size=1.0, gpu=True)
        ms = per_call(lambda: rec.reconstruct(p), 10)
        v, t, _ = rec.reconstruct(p)
        once = per_call(lambda: meniscus.reconstruct_surface(p, particle_radius=radius, cube_size=1.0, gpu=True), 3)
        cpu = per_call(lambda: meniscus.reconstruct_surface(p, particle_radius=radius, cube_size=1.0, gpu=False), 3)
        print(f"Reconstructor {label} ({len(p)} particles) at 1 r on {rec.device}: {ms:.2f} ms/call with the "
              f"read-back ({len(v)} vertices, {len(t)} triangles; {rec.kept_bytes >> 20} MiB kept); one-shot "
              f"reconstruct_surface(gpu=True) {once:.2f} ms, the CPU path {cpu:.2f} ms")
    return 0


if __name__ == "__main__":
    sys.exit(main())
