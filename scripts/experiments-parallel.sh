#!/bin/sh
# A sharded `portalfind experiment` sweep on one machine with GNU parallel (Debian
# `parallel`), then the merge (issue 17).
#
#   scripts/experiments-parallel.sh [N [DEFS [OUT]]]     # default: N = cores, experiments/, results/
#
# Each job is one fresh process (`--shard I/N`); a failing shard does not stop the others
# (`parallel` exits non-zero, and the merge then reports the missing or failed shard).
set -eu
N=${1:-$(nproc)}
DEFS=${2:-experiments}
OUT=${3:-results}
PORTALFIND=${PORTALFIND:-./target/release/portalfind}
status=0
parallel --jobs "$N" --line-buffer --tagstring 'shard {}' \
    "$PORTALFIND" experiment "$DEFS" --out "$OUT" --shard "{}/$N" ::: $(seq 1 "$N") || status=$?
"$PORTALFIND" experiment "$DEFS" --out "$OUT" --merge
exit "$status"
