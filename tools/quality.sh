#!/usr/bin/env bash
# Measure every surface, kernel and smoothing filter on the shared dam-break frame 20 (960×540, the reference
# camera) against BOTH splashsurf references in ../shared/data/quality/ with `meniscus quality`: the raw
# reconstruction (dambreak59k_f20_ref_depth.npy) and the smoothed one practitioners render
# (dambreak59k_f20_smooth_ref_depth.npy). Prints one markdown table per reference (the tables are produced by
# this script, never typed in). Each configuration is rendered once; its `filter`/`iso`/
# `anisotropy` GPU ms are this machine's (benchmarks: `meniscus bench`).
# Usage: tools/quality.sh [extra render args…]; CONFIGS="name|render args;…" replaces the list; SCENE picks the
# reference (dambreak59k_f20, the default; ddbs25k_f12 or ddbs25k_f16: the double dam break around a sphere,
# ../shared/data/quality/README.md gives their files, radii and cameras; custom: FRAME, RADIUS, CAMERA and
# REF_PREFIX (REF_PREFIX_ref_depth.npy and REF_PREFIX_smooth_ref_depth.npy, e.g. from tools/splash-references.py)).
set -euo pipefail
cd "$(dirname "$0")/.."
shared=${MENISCUS_SHARED:-../shared}
scene=${SCENE:-dambreak59k_f20}
case "$scene" in
    dambreak59k_f20) frame="$shared/data/splishsplash/dambreak_59k/partio/ParticleData_Fluid_20.bgeo"
        radius=0.0125; camera=0,2.5,6:0,0.3,0:45 ;;
    ddbs25k_f12 | ddbs25k_f16)
        frame="$shared/data/splishsplash/doubledambreak_sphere_25k/partio/ParticleData_Fluid_${scene##*_f}.bgeo"
        radius=0.02; camera=2.6,2.4,3.6:0,0.7,0:45 ;;
    custom) frame=${FRAME:?SCENE=custom needs FRAME}; radius=${RADIUS:?and RADIUS}; camera=${CAMERA:?and CAMERA} ;;
    *) echo "quality.sh: unknown SCENE $scene (dambreak59k_f20, ddbs25k_f12, ddbs25k_f16, custom)" >&2; exit 1 ;;
esac
refs=${REF_PREFIX:-$shared/data/quality/$scene}
[ -f "$frame" ] || { echo "quality.sh: missing $frame" >&2; exit 1; }
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
default_configs="spheres + none|--surface spheres --filter none;spheres + gaussian|--surface spheres --filter gaussian;\
spheres + bilateral|--surface spheres --filter bilateral;spheres + bilateral2d|--surface spheres --filter bilateral2d;\
spheres + curvature-flow|--surface spheres --filter curvature-flow;\
spheres + narrow-range (--preset fast)|--surface spheres --filter narrow-range;\
ellipsoids + none|--surface spheres --filter none --kernel anisotropic;\
ellipsoids + narrow-range|--surface spheres --filter narrow-range --kernel anisotropic;\
ellipsoids + curvature-flow|--surface spheres --filter curvature-flow --kernel anisotropic;\
iso smoothed σ 1.1 r (2 r on a lattice), bulk c̄ 4…9 (default)|;iso smoothed, one blur for all (no lattice widening)|--settings $out/onewidth.toml;iso smoothed, bulk c̄ 5…9|--settings $out/bulk59.toml;\
iso smoothed σ 1.25 r|--settings $out/sigma125.toml;iso smoothed everywhere (no bulk weight)|--settings $out/everywhere.toml;\
iso exact (--preset quality)|--preset quality;iso exact, anisotropic|--preset quality --kernel anisotropic;\
iso exact, anisotropic stretch 1.5|--preset quality --kernel anisotropic --settings $out/stretch.toml;\
iso exact, anisotropic centres 0.3|--preset quality --kernel anisotropic --settings $out/centres.toml;\
iso exact + narrow-range|--preset quality --filter narrow-range;iso exact + bilateral|--preset quality --filter bilateral;\
iso exact + curvature-flow|--preset quality --filter curvature-flow;mesh (cubes 0.5 r)|--surface mesh --filter none;\
mesh + 10 smoothing iterations|--surface mesh --filter none --settings $out/smooth10.toml;\
mesh + 25 smoothing iterations (as the smoothed reference)|--surface mesh --filter none --settings $out/smooth25.toml"
printf '[iso]\nbulk = [5.0, 9.0]\n' > "$out/bulk59.toml"
printf '[iso]\nsmoothing = 1.25\n' > "$out/sigma125.toml"
printf '[iso]\nlattice_smoothing = 1.1\n' > "$out/onewidth.toml"
printf '[iso]\nbulk = [0.0, 0.0]\n' > "$out/everywhere.toml"
printf '[anisotropy]\nstretch = 1.5\n' > "$out/stretch.toml"
printf '[anisotropy]\ncentre_blend = 0.3\n' > "$out/centres.toml"
printf '[mesh]\nsmoothing_iters = 10\n' > "$out/smooth10.toml"
printf '[mesh]\nsmoothing_iters = 25\n' > "$out/smooth25.toml"
IFS=';' read -ra configs <<< "${CONFIGS:-$default_configs}"
declare -A rows
for c in "${configs[@]}"; do
    name=${c%%|*}
    args=${c#*|}
    # shellcheck disable=SC2086
    rm -f "$out/c.smoothed.npy"
    if ! timings=$(target/release/meniscus render "$frame" --radius "$radius" --camera "$camera" --width 960 \
        --height 540 $args --out "$out/c.png" --dump smoothed --timings "$@" 2>"$out/err"); then
        echo "quality.sh: the render of \"$name\" ($args) failed:" >&2
        cat "$out/err" >&2
        exit 1
    fi
    ms=$(awk -F'|' '$2 ~ /^ (splat|filter|iso|anisotropy|mesh) $/ {gsub(/ /,"",$2); gsub(/ /,"",$3); printf "%s%s %s", sep, $2, $3; sep=", "}' <<< "$timings")
    target/release/meniscus quality "$frame" --radius "$radius" --camera "$camera" --width 960 --height 540 \
        --depth "$out/c.smoothed.npy" --reference "${refs}_ref_depth.npy" --reference "${refs}_smooth_ref_depth.npy" \
        --json "$out/q.json" >/dev/null 2>"$out/err" || { cat "$out/err" >&2; exit 1; }
    for k in 0 1; do
        ref=$([ $k = 0 ] && echo ref || echo smooth_ref)
        rows[$ref]+=$(python3 -c "import json; c=json.load(open('$out/q.json'))['frames'][0]['references'][$k][1]; print('| $name | %.3f | %.2f | %.2f | %.1f | %.1f | ${ms:-–} |' % (c['iou'], c['depth_median_r'], c['depth_p90_r'], c['normal_median_deg'], c['normal_p90_deg']))")$'\n'
    done
done
# The yardstick: splashsurf's own unsmoothed surface (the raw reference) measured against its smoothed one — the
# same reconstruction without the mesh smoothing, i.e. what any unsmoothed surface of the field can reach.
target/release/meniscus quality "$frame" --radius "$radius" --camera "$camera" --width 960 --height 540 \
    --depth "${refs}_ref_depth.npy" --reference "${refs}_smooth_ref_depth.npy" --json "$out/y.json" >/dev/null 2>&1
rows[smooth_ref]+=$(python3 -c "import json; c=json.load(open('$out/y.json'))['frames'][0]['references'][0][1]; print('| splashsurf raw reference (yardstick) | %.3f | %.2f | %.2f | %.1f | %.1f | – |' % (c['iou'], c['depth_median_r'], c['depth_p90_r'], c['normal_median_deg'], c['normal_p90_deg']))")$'\n'
for ref in ref smooth_ref; do
    printf '\n### against %s_%s_depth.npy\n\n' "$scene" "$ref"
    printf '| surface + filter | IoU | depth median (r) | depth p90 (r) | normal median (°) | normal p90 (°) | GPU ms |\n|---|---:|---:|---:|---:|---:|---|\n'
    printf '%s' "${rows[$ref]}"
done
