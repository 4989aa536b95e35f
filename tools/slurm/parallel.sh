#!/usr/bin/env bash
# The same split on one machine without a scheduler: N processes, one shard each (xargs -P), then the encode.
#   tools/slurm/parallel.sh N SEQUENCE OUTDIR MOVIE [render flags…]
# With GNU parallel (-I % keeps its hands off the frame pattern's {}):
#   parallel -I % -j N meniscus render SEQUENCE --shard %/N --resume --out 'OUTDIR/frame_{}.png' ::: $(seq N)
set -euo pipefail
n=${1:?usage: parallel.sh N SEQUENCE OUTDIR MOVIE [render flags…]}
seq=$2 out=$3 movie=$4
shift 4
bin=${MENISCUS:-meniscus}
seq 1 "$n" | xargs -P "$n" -I % "$bin" render "$seq" --shard "%/$n" --resume --out "$out/frame_{}.png" "$@"
"$bin" encode "$out/frame_{}.png" --out "$movie"
