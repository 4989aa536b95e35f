#!/usr/bin/env python3
# tools/quality-blur.py DEPTH.npy SIGMA_PX CUT_R OUT.npy — a normalised Gaussian of a dumped depth image over its
# fluid pixels (neighbours further than CUT_R particle radii in depth left out), for measuring screen-space
# smoothing of the iso surface with `meniscus quality` (docs/iso-surface.md). Needs numpy. Radius 0.0125 m
# (the shared dam break). Example:
#   meniscus render F --radius 0.0125 --camera 0,2.5,6:0,0.3,0:45 --surface iso --filter none --out i.png --dump smoothed
#   tools/quality-blur.py i.smoothed.npy 0.7 2 b.npy
#   meniscus quality F --radius 0.0125 --camera 0,2.5,6:0,0.3,0:45 --depth b.npy \
#       --reference ../shared/data/quality/dambreak59k_f20_smooth_ref_depth.npy
import sys

import numpy as np

src, sigma, cut, out = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), sys.argv[4]
r = 0.0125
d = np.load(src)
R = int(np.ceil(2.5 * sigma))
cov = np.isfinite(d)
dz = np.where(cov, d, 0.0)
num = np.zeros_like(dz)
den = np.zeros_like(dz)
for dy in range(-R, R + 1):
    for dx in range(-R, R + 1):
        w = np.exp(-(dx * dx + dy * dy) / (2 * sigma * sigma))
        s = np.roll(np.roll(dz, dy, 0), dx, 1)
        c = np.roll(np.roll(cov, dy, 0), dx, 1)
        ok = c & cov & (np.abs(s - dz) < cut * r)
        num += np.where(ok, w * s, 0)
        den += np.where(ok, w, 0)
np.save(out, np.where(cov, num / np.maximum(den, 1e-12), np.inf).astype(np.float32))
