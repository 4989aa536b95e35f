"""No growth over long runs (what Genesis works around by running splashsurf in a subprocess): 10,000
`render` calls, 1,000 `reconstruct_surface` calls and 60 calls of one GPU `Reconstructor` keep the process's
resident memory flat (and the Reconstructor's device memory too)."""
import numpy as np

import meniscus


def rss_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096 / 1e6


def block(n: int, jitter: int) -> np.ndarray:
    g = np.stack(np.meshgrid(*[np.arange(n)] * 3, indexing="ij"), -1).reshape(-1, 3).astype(np.float32) * 0.02
    return g + np.float32(1e-4) * jitter


def test_ten_thousand_renders_keep_rss_flat():
    r = meniscus.Renderer(32, 24)
    samples = []
    for k in range(10_000):
        # New particles every call: the surface's grid and lattice are rebuilt each time.
        r.render(block(6, k % 7), particle_radius=0.01)
        if k in (1_000, 9_999):
            samples.append(rss_mb())
    print(f"render soak: RSS {samples[0]:.1f} MB after 1,000 calls, {samples[1]:.1f} MB after 10,000")
    assert samples[1] - samples[0] < 8.0, samples


def test_a_thousand_reconstructions_keep_rss_flat():
    samples = []
    for k in range(1_000):
        meniscus.reconstruct_surface(block(6, k % 5), particle_radius=0.01, gpu=False)
        if k in (100, 999):
            samples.append(rss_mb())
    print(f"reconstruct soak: RSS {samples[0]:.1f} MB after 100 calls, {samples[1]:.1f} MB after 1,000")
    assert samples[1] - samples[0] < 8.0, samples


def test_a_gpu_reconstructor_keeps_rss_and_device_memory_flat():
    rec = meniscus.Reconstructor(particle_radius=0.01, gpu=True)
    samples, kept = [], []
    for k in range(60):
        rec.reconstruct(block(6, k % 5))
        if k in (10, 59):
            samples.append(rss_mb())
            kept.append(rec.kept_bytes)
    print(f"Reconstructor soak: RSS {samples[0]:.1f} MB after 10 calls, {samples[1]:.1f} MB after 60; "
          f"device memory kept {kept[0]} → {kept[1]} bytes")
    assert samples[1] - samples[0] < 8.0 and kept[0] == kept[1], (samples, kept)
    # The gate's control: memory held (64 MB, what 250 calls leaking 256 kB each would hold; one fresh mapping,
    # so no freed heap hides it) is over it.
    before, held = rss_mb(), np.ones(16 << 20, np.float32)
    assert rss_mb() - before >= 8.0, "the RSS gate would not see 64 MB held"
    del held
