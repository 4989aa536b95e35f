"""No growth over long runs (what Genesis works around by running splashsurf in a subprocess): 10,000
`render` calls, 1,000 `reconstruct_surface` calls and 60 calls of one GPU `Reconstructor` keep the process's
resident memory flat (and the Reconstructor's device memory too).

Each soak runs in a fresh interpreter: in the test session Blender (`bpy`, imported by test_blender.py) brings
an allocator that keeps freed memory, which would hide a leak from the resident size. Each soak also measures
its gate's control there: 64 MB held must show (else the measurement could not see a leak)."""
import json
import pathlib
import subprocess
import sys

import numpy as np

import meniscus

HERE = pathlib.Path(__file__).resolve().parent
GATE_MB = 8.0


def rss_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096 / 1e6


def block(n: int, jitter: int) -> np.ndarray:
    g = np.stack(np.meshgrid(*[np.arange(n)] * 3, indexing="ij"), -1).reshape(-1, 3).astype(np.float32) * 0.02
    return g + np.float32(1e-4) * jitter


def control_mb() -> float:
    """What the resident size says of 64 MB held (the gate's control, in the soak's own process)."""
    before = rss_mb()
    held = np.ones(16 << 20, np.float32)
    grown = rss_mb() - before
    del held
    return grown


def _renders() -> dict:
    r = meniscus.Renderer(32, 24)
    samples = []
    for k in range(10_000):
        # New particles every call: the surface's grid and lattice are rebuilt each time.
        r.render(block(6, k % 7), particle_radius=0.01)
        if k in (1_000, 9_999):
            samples.append(rss_mb())
    return {"rss": samples, "control": control_mb()}


def _reconstructions() -> dict:
    samples = []
    for k in range(1_000):
        meniscus.reconstruct_surface(block(6, k % 5), particle_radius=0.01, gpu=False)
        if k in (100, 999):
            samples.append(rss_mb())
    return {"rss": samples, "control": control_mb()}


def _gpu_reconstructor() -> dict:
    rec = meniscus.Reconstructor(particle_radius=0.01, gpu=True)
    samples, kept = [], []
    for k in range(60):
        rec.reconstruct(block(6, k % 5))
        if k in (10, 59):
            samples.append(rss_mb())
            kept.append(rec.kept_bytes)
    return {"rss": samples, "kept": kept, "control": control_mb()}


def isolated(name: str) -> dict:
    """Run this module's soak `name` in a fresh interpreter (the package as installed here); its results."""
    code = f"import json, sys; sys.path.insert(0, {str(HERE)!r}); import test_soak; print(json.dumps(test_soak.{name}()))"
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout.strip().splitlines()[-1])


def assert_flat(got: dict) -> None:
    """The gate's control (64 MB held shows in the resident size), then the gate: the resident size between the
    soak's two samples grew by less than GATE_MB."""
    assert got["control"] >= GATE_MB, f"the RSS gate would not see 64 MB held: {got}"
    assert got["rss"][1] - got["rss"][0] < GATE_MB, got


def test_ten_thousand_renders_keep_rss_flat():
    got = isolated("_renders")
    rss = got["rss"]
    print(f"render soak: RSS {rss[0]:.1f} MB after 1,000 calls, {rss[1]:.1f} MB after 10,000")
    assert_flat(got)


def test_a_thousand_reconstructions_keep_rss_flat():
    got = isolated("_reconstructions")
    rss = got["rss"]
    print(f"reconstruct soak: RSS {rss[0]:.1f} MB after 100 calls, {rss[1]:.1f} MB after 1,000")
    assert_flat(got)


def test_a_gpu_reconstructor_keeps_rss_and_device_memory_flat():
    got = isolated("_gpu_reconstructor")
    rss, kept = got["rss"], got["kept"]
    print(f"Reconstructor soak: RSS {rss[0]:.1f} MB after 10 calls, {rss[1]:.1f} MB after 60; "
          f"device memory kept {kept[0]} → {kept[1]} bytes")
    assert_flat(got)
    assert kept[0] == kept[1], got
