#!/usr/bin/env bash
# tools/rss-sample.sh OUT.txt COMMAND… — run COMMAND and sample its resident memory (VmRSS) every
# ${RSS_EVERY:-15} s into OUT.txt as "t_s rss_mb" lines, then its exit status (issue #17's measurement).
set -uo pipefail
out=$1; shift
"$@" &
pid=$!
t0=$(date +%s)
echo "t_s rss_mb" > "$out"
while kill -0 "$pid" 2>/dev/null; do
    r=$(awk '/VmRSS/{print $2}' "/proc/$pid/status" 2>/dev/null)
    [ -n "$r" ] && echo "$(( $(date +%s) - t0 )) $(( r / 1024 ))" >> "$out"
    sleep "${RSS_EVERY:-15}"
done
wait "$pid"; rc=$?
echo "exit $rc" >> "$out"
exit $rc
