#!/usr/bin/env python3
"""Prototype (issue #15, commit df4de40): the SPH colour field smoothed in 3D where the water is bulk, measured on the
shared dam-break frame 20 against both splashsurf references. A CPU/numpy experiment to decide what to build on
the GPU; nothing in meniscus uses it.

What it does, as splashsurf's mesh smoothing does on a mesh but on the field instead:
1. φ(x) = Σ_j W(|x − x_j| / h) / n_j (the iso pass's field: cubic spline W, W(0) = 1, support h = 4 r,
   n_j = Σ_k W(|x_j − x_k| / h)) on a voxel lattice of spacing `--voxel` r, scattered particle by particle;
2. each particle's neighbour count c_j = Σ_k (1 − d²/h²) (splashsurf's feature weight), interpolated to the
   voxels Shepard-style with the same kernel (c̄);
3. F = φ + w(c̄) (G_σ ∗ φ − φ), w = smoothstep((c̄ − c0) / (c1 − c0)): a Gaussian blur of the field where the
   particles' neighbourhoods are full (calm water), none where they are sparse (spray keeps its droplets);
4. a ray cast of F = 0.6 (trilinear samples every ¼ r, linear interpolation at the crossing) through every pixel
   the exact `iso` render covers or that lies within 2 px of one, from 4 r in front of its (or its nearest
   covered neighbour's) depth to 8 r behind it (the smoothed surface cannot grow further than that);
5. `../shared/tools/quality compare` (normals from depth) against the raw and the smoothed reference.

Usage: tools/quality-volume.py [--voxel 1.0] [--configs "σ,c0,c1;…"] [--png P]   (σ in r; σ 0 = no blur)
Needs numpy and scipy (pip install numpy scipy; --png also pillow), a release build (target/release/meniscus)
and ../shared. --png writes the calm-water crop shaded from depth: smoothed reference, exact cast, last config.
Prints one markdown table per reference.
"""
import argparse
import gzip
import json
import os
import struct
import subprocess
import sys
import tempfile

try:
    import numpy as np
    from scipy.ndimage import gaussian_filter, grey_erosion, map_coordinates
    from scipy.spatial import cKDTree
except ImportError as e:
    sys.exit(f"quality-volume.py: {e}: pip install numpy scipy")

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
SHARED = os.environ.get("MENISCUS_SHARED", os.path.join(ROOT, "..", "shared"))
FRAME = os.path.join(SHARED, "data/splishsplash/dambreak_59k/partio/ParticleData_Fluid_20.bgeo")
CAMERA = ("0,2.5,6", "0,0.3,0", 45.0)
WIDTH, HEIGHT, R, THRESHOLD = 960, 540, 0.0125, 0.6


def read_bgeo(path):
    """Positions of a classic BGEO v5 file (gzip or plain; src/scene/bgeo.rs has the checked reader)."""
    d = open(path, "rb").read()
    if d[:2] == b"\x1f\x8b":
        d = gzip.decompress(d)
    if d[:5] != b"BgeoV":
        sys.exit(f"quality-volume.py: {path}: not a classic BGEO file")
    h = struct.unpack(">9i", d[5:41])
    pos, n, components = 41, h[1], 0
    for _ in range(h[5]):
        (length,) = struct.unpack(">H", d[pos : pos + 2])
        pos += 2 + length
        size, kind = struct.unpack(">Hi", d[pos : pos + 6])
        pos += 6
        if kind == 4:  # indexed strings: a string table instead of defaults
            (count,) = struct.unpack(">i", d[pos : pos + 4])
            pos += 4
            for _ in range(count):
                (length,) = struct.unpack(">H", d[pos : pos + 2])
                pos += 2 + length
        else:
            pos += 4 * size
        components += size
    record = 16 + 4 * components
    return np.frombuffer(d[pos : pos + n * record], dtype=">f4").reshape(n, record // 4)[:, :3].astype(np.float64)


def kernel(q):
    return np.where(q <= 0.5, 1 - 6 * q * q + 6 * q**3, np.where(q < 1, 2 * (1 - q) ** 3, 0.0))


def volumes(x, h, v):
    """φ and c̄ on the lattice (origin lo, spacing v), scattered over each particle's support."""
    tree = cKDTree(x)
    pairs = tree.query_pairs(h, output_type="ndarray")
    i, j = pairs[:, 0], pairs[:, 1]
    d = np.linalg.norm(x[i] - x[j], axis=1)
    n = len(x)
    w = kernel(d / h)
    nj = 1 + np.bincount(i, w, n) + np.bincount(j, w, n)
    c = np.bincount(i, 1 - d * d / (h * h), n) + np.bincount(j, 1 - d * d / (h * h), n)
    lo = x.min(0) - h - 2 * v
    dims = np.ceil((x.max(0) + h + 2 * v - lo) / v).astype(int) + 1
    size = int(dims.prod())
    phi, cw, ww = np.zeros(size), np.zeros(size), np.zeros(size)
    base = np.floor((x - lo) / v).astype(int)
    k = int(np.ceil(h / v))
    for dz in range(-k, k + 2):
        for dy in range(-k, k + 2):
            for dx in range(-k, k + 2):
                idx = base + np.array([dx, dy, dz])
                q = np.linalg.norm(idx * v + lo - x, axis=1) / h
                m = q < 1
                flat = (idx[m, 0] * dims[1] + idx[m, 1]) * dims[2] + idx[m, 2]
                wk = kernel(q[m])
                phi += np.bincount(flat, wk / nj[m], size)
                cw += np.bincount(flat, wk * c[m], size)
                ww += np.bincount(flat, wk, size)
    cbar = np.where(ww > 0, cw / np.maximum(ww, 1e-30), 0.0)
    return lo, phi.reshape(dims), cbar.reshape(dims)


def cast(lo, v, field, start):
    """Depth of field = THRESHOLD along each pixel's ray, from 4 r before `start` to 8 r behind it."""
    eye = np.array([float(s) for s in CAMERA[0].split(",")])
    target = np.array([float(s) for s in CAMERA[1].split(",")])
    fwd = (target - eye) / np.linalg.norm(target - eye)
    right = np.cross(fwd, [0, 1, 0])
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    f = (HEIGHT / 2) / np.tan(np.radians(CAMERA[2]) / 2)
    covered = np.isfinite(start) & (start > 0) & (start < 1e3)
    # Pixels up to 2 px outside the exact silhouette start from their nearest covered neighbour's depth, so the
    # smoothed surface may also grow there.
    nearest = grey_erosion(np.where(covered, start, np.inf), size=5)
    start = np.where(covered, start, nearest)
    ys, xs = np.nonzero(np.isfinite(start) & (start > 0) & (start < 1e3))
    ray = fwd[None] + ((xs + 0.5 - WIDTH / 2) / f)[:, None] * right[None] - ((ys + 0.5 - HEIGHT / 2) / f)[:, None] * up[None]
    d0 = start[ys, xs]
    out = np.full(len(xs), np.nan)
    step = 0.25 * R
    prev = None
    for t in np.arange(-4 * R, 8 * R, step):
        depth = d0 + t
        val = map_coordinates(field, ((eye[None] + ray * depth[:, None] - lo) / v).T, order=1, mode="constant")
        if prev is not None:
            hit = np.isnan(out) & (prev < THRESHOLD) & (val >= THRESHOLD)
            out[hit] = depth[hit] - step + (THRESHOLD - prev[hit]) / (val[hit] - prev[hit]) * step
        prev = val
    res = np.full((HEIGHT, WIDTH), np.inf, dtype=np.float32)
    res[ys, xs] = np.where(np.isnan(out), np.inf, out)
    return res


def shade(depth):
    """Grey Lambert shading of normals from depth (as the quality tool derives them, central differences here)."""
    f = HEIGHT / (2 * np.tan(np.radians(CAMERA[2]) / 2))
    d = np.where(np.isfinite(depth) & (depth > 0) & (depth < 1e3), depth, np.nan)
    ys, xs = np.mgrid[0:HEIGHT, 0:WIDTH]
    p = np.stack([(xs + 0.5 - WIDTH / 2) / f * d, -(ys + 0.5 - HEIGHT / 2) / f * d, -d], -1)
    n = np.cross(np.gradient(p, axis=1), np.gradient(p, axis=0))
    n /= np.linalg.norm(n, axis=-1, keepdims=True) + 1e-30
    n *= np.sign(n[..., 2:3] + 1e-12)
    light = np.array([0.3, 0.5, 0.8]) / np.linalg.norm([0.3, 0.5, 0.8])
    s = np.nan_to_num(np.clip(0.2 + 0.8 * (n * light).sum(-1), 0, 1))
    return (s[150:330, 250:650] * 255).astype(np.uint8)


def compare(quality, depth_npy, ref):
    out = subprocess.run(
        [quality, "compare", "--ref-depth", os.path.join(SHARED, f"data/quality/dambreak59k_f20_{ref}_depth.npy"),
         "--depth", depth_npy, "--normals-from-depth", "--ref-normals-from-depth", "--radius", str(R)],
        check=True, capture_output=True, text=True).stdout.strip().splitlines()[-1]
    d = json.loads(out)
    return "%.3f | %.2f | %.2f | %.1f | %.1f" % (d["iou"], d["depth_median_abs"] / R, d["depth_p90_abs"] / R,
                                                 d["normal_median_deg"], d["normal_p90_deg"])


def main():
    ap = argparse.ArgumentParser(description="#15 prototype: the colour field smoothed in 3D where the water is bulk, measured against both splashsurf references (see the file header).")
    ap.add_argument("--voxel", type=float, default=1.0, help="lattice spacing in particle radii")
    ap.add_argument("--configs", default="0,0,0;1.5,0,0;1.5,4,9;1.5,5,9;1.25,5,9;1.5,5,10",
                    help="σ (r), c0, c1 per configuration; c1 0: blur everywhere")
    ap.add_argument("--png", help="write the shaded calm-water crop (pillow): smoothed reference, exact, last config")
    a = ap.parse_args()
    if not os.path.isfile(FRAME):
        sys.exit(f"quality-volume.py: missing {FRAME}")
    quality = os.environ.get("QUALITY_BIN", "/tmp/meniscus-quality/release/quality")
    if not os.access(quality, os.X_OK):
        subprocess.run(["cargo", "build", "--release", "--quiet", "--manifest-path",
                        os.path.join(SHARED, "tools/quality/Cargo.toml")],
                       check=True, env=dict(os.environ, CARGO_TARGET_DIR="/tmp/meniscus-quality"))
    meniscus = os.path.join(ROOT, "target/release/meniscus")
    if not os.access(meniscus, os.X_OK):
        sys.exit(f"quality-volume.py: {meniscus} is missing: cargo build --release first")
    tmp = tempfile.mkdtemp()
    exact = os.path.join(tmp, "iso")
    subprocess.run([meniscus, "render", FRAME, "--radius", str(R), "--camera",
                    ":".join([CAMERA[0], CAMERA[1], str(int(CAMERA[2]))]), "--width", str(WIDTH), "--height",
                    str(HEIGHT), "--preset", "quality", "--out", exact + ".png", "--dump", "smoothed"],
                   check=True, capture_output=True)
    start = np.load(exact + ".smoothed.npy").astype(np.float64).reshape(HEIGHT, WIDTH)
    rows = {"ref": [], "smooth_ref": []}
    for ref in rows:
        rows[ref].append(f"| exact iso cast (meniscus `--surface iso`) | {compare(quality, exact + '.smoothed.npy', ref)} |")
    lo, phi, cbar = volumes(read_bgeo(FRAME), 4 * R, a.voxel * R)
    for spec in a.configs.split(";"):
        sigma, c0, c1 = (float(s) for s in spec.split(","))
        field = phi if sigma == 0 else gaussian_filter(phi, sigma / a.voxel)
        if sigma > 0 and c1 > 0:
            w = np.clip((cbar - c0) / (c1 - c0), 0, 1)
            field = phi + w * w * (3 - 2 * w) * (field - phi)
        path = os.path.join(tmp, "v.npy")
        np.save(path, cast(lo, a.voxel * R, field, start))
        name = ("voxels %g r, no blur" % a.voxel if sigma == 0 else
                "voxels %g r, σ %g r %s" % (a.voxel, sigma, "everywhere" if c1 <= 0 else "where c̄ ∈ %g…%g" % (c0, c1)))
        for ref in rows:
            rows[ref].append(f"| {name} | {compare(quality, path, ref)} |")
        print(name, "done", file=sys.stderr, flush=True)
    if a.png:
        from PIL import Image

        smooth_ref = np.load(os.path.join(SHARED, "data/quality/dambreak59k_f20_smooth_ref_depth.npy")).astype(np.float64)
        rows_png = [shade(smooth_ref), shade(start), shade(np.load(path).astype(np.float64))]
        im = np.concatenate(rows_png, axis=0)
        Image.fromarray(im).resize((im.shape[1] * 2, im.shape[0] * 2), Image.NEAREST).save(a.png)
    for ref, lines in rows.items():
        print(f"\n### against dambreak59k_f20_{ref}_depth.npy\n")
        print("| field | IoU | depth median (r) | depth p90 (r) | normal median (°) | normal p90 (°) |")
        print("|---|---:|---:|---:|---:|---:|")
        print("\n".join(lines))


if __name__ == "__main__":
    main()
