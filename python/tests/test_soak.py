"""No growth over long runs (what Genesis works around by running splashsurf in a subprocess): 10,000
`render` calls and 1,000 `reconstruct_surface` calls keep the process's resident memory flat."""
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
