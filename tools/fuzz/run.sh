#!/usr/bin/env bash
# Fuzz every particle parser: tools/fuzz/run.sh [SECONDS]  (default 600 s). One target, `parse`, covers every
# format of the registry (meniscus::scene::FORMATS): the first input byte picks the parser.
# Needs cargo-fuzz (`cargo install cargo-fuzz`); runs on the stable toolchain through RUSTC_BOOTSTRAP=1.
# Seeds come from `cargo run --example fuzz_seeds` plus the shared SPlisHSPlasH frames when present.
# Crashes land in tools/fuzz/artifacts/TARGET/; the summary (runs, crashes) is printed per target.
set -euo pipefail
cd "$(dirname "$0")/../.."
secs=${1:-600}
shift || true
targets=(parse)
cargo run --quiet --release --example fuzz_seeds -- tools/fuzz/corpus
# Real frames as seeds too, behind their format's index byte (bgeo = 0, vtk = 1: the registry's order).
f=../shared/data/splishsplash/dambreak_6859/partio/ParticleData_Fluid_1.bgeo
[ -f "$f" ] && { printf '\x00'; cat "$f"; } > tools/fuzz/corpus/parse/shared_bgeo
# Files written by VTK itself and meshio (every VTU/VTP layout and compressor), behind the VTU index byte 2.
for f in tests/fixtures/vtk/*.vt[up]; do { printf '\x02'; cat "$f"; } > "tools/fuzz/corpus/parse/vtk_$(basename "$f")"; done
f=../shared/data/splishsplash/dambreak_6859/vtk/ParticleData_Fluid_1.vtk
[ -f "$f" ] && { printf '\x01'; cat "$f"; } > tools/fuzz/corpus/parse/shared_vtk
export RUSTC_BOOTSTRAP=1
for t in "${targets[@]}"; do
    mkdir -p "tools/fuzz/artifacts/$t"
    log="tools/fuzz/artifacts/$t/fuzz.log"
    cargo fuzz run --fuzz-dir tools/fuzz "$t" "tools/fuzz/corpus/$t" -- \
        -max_total_time="$secs" -rss_limit_mb=2048 -max_len=65536 -print_final_stats=1 \
        -artifact_prefix="tools/fuzz/artifacts/$t/" >"$log" 2>&1 || true
    runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo '?')
    crashes=$(ls "tools/fuzz/artifacts/$t" | grep -c -E '^(crash|oom|timeout|leak)-' || true)
    echo "$t: $runs runs in ${secs}s, $crashes crash/oom/timeout artifacts (log: $log)"
done
