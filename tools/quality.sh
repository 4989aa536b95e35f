#!/usr/bin/env bash
# Measure every smoothing filter on the shared dam-break frame against the reference surface
# (../shared/tools/quality). Usage: tools/quality.sh [extra render args…]
set -euo pipefail
cd "$(dirname "$0")/.."
shared=${MENISCUS_SHARED:-../shared}
q=${QUALITY_BIN:-/tmp/meniscus-quality/release/quality}
if [ ! -x "$q" ]; then
    CARGO_TARGET_DIR=/tmp/meniscus-quality cargo build --release --quiet --manifest-path "$shared/tools/quality/Cargo.toml"
    q=/tmp/meniscus-quality/release/quality
fi
frame="$shared/data/splishsplash/dambreak_59k/partio/ParticleData_Fluid_20.bgeo"
out=$(mktemp -d)
printf '| filter | IoU | depth median (r) | depth p90 (r) | normal median (°) | normal p90 (°) | smooth ms |\n|---|---:|---:|---:|---:|---:|---:|\n'
for f in ${FILTERS:-none gaussian bilateral bilateral2d curvature-flow narrow-range}; do
    ms=$(target/release/meniscus render "$frame" --radius 0.0125 --camera 0,2.5,6:0,0.3,0:45 --width 960 --height 540 \
        --filter "$f" --out "$out/$f.png" --dump smoothed --timings "$@" 2>/dev/null | awk -F'|' '$2 ~ /smooth/ {gsub(/ /,"",$3); print $3}')
    "$q" compare --ref-depth "$shared/data/quality/dambreak59k_f20_ref_depth.npy" --depth "$out/$f.smoothed.npy" \
        --normals-from-depth --ref-normals-from-depth --radius 0.0125 | tail -n 1 |
        python3 -c "import json,sys; d=json.load(sys.stdin); print('| $f | %.3f | %.2f | %.2f | %.1f | %.1f | $ms |' % (d['iou'], d['depth_median_abs']/0.0125, d['depth_p90_abs']/0.0125, d['normal_median_deg'], d['normal_p90_deg']))"
done
