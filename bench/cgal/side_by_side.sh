#!/bin/bash
# Interleaved side-by-side timing of portalfind and CGAL on identical points.
#
#   bench/cgal/side_by_side.sh CGAL_BINARY [RUNS] [N] [KINDS...]
#   bench/cgal/side_by_side.sh --summary RUNS_FILE
#
# CGAL_BINARY is delaunay_cgal built from delaunay_cgal.cpp (see README.md). For every kind
# (default: uniform grid boxes urot) it writes the case's points once
# (portalfind bench points), then alternates one fresh portalfind process
# (bench one: construction only) and one fresh CGAL process, RUNS times (default 8), and
# prints every pair and a Markdown table of best and median times. Run it on an otherwise
# idle machine; this VM's speed drifts by ±20% over minutes, which interleaving shares out.
set -euo pipefail

# The Markdown table of a runs file: lines "kind ours_seconds [ours_tets] cgal_seconds
# [cgal_tets]"; lines starting with # are skipped.
summary() {
  local kinds
  kinds=$(grep -v '^#' "$1" | awk '!seen[$1]++ { print $1 }')
  echo "| input | runs | ours: best | ours: median | CGAL: best | CGAL: median | runs where ours was faster |"
  echo "|---|---:|---:|---:|---:|---:|---|"
  for k in $kinds; do
    grep -v '^#' "$1" | awk -v k="$k" '
      function median(a, n,   i, j, t) {
        for (i = 1; i <= n; i++) for (j = i + 1; j <= n; j++) if (a[j] < a[i]) { t = a[i]; a[i] = a[j]; a[j] = t }
        return n % 2 ? a[(n + 1) / 2] : (a[n / 2] + a[n / 2 + 1]) / 2
      }
      $1 == k { n++; o[n] = $2; c[n] = (NF == 5 ? $4 : $3); if (o[n] < c[n]) w++ }
      END {
        om = median(o, n); cm = median(c, n)
        printf "| %s | %d | %.2f | %.2f | %.2f | %.2f | %d of %d |\n", k, n, o[1], om, c[1], cm, w, n
      }'
  done
}
if [ "${1:-}" = "--summary" ]; then
  summary "${2:?usage: side_by_side.sh --summary RUNS_FILE}"
  exit 0
fi

CGAL=${1:?usage: side_by_side.sh CGAL_BINARY [RUNS] [N] [KINDS...]}
RUNS=${2:-8}
N=${3:-1000000}
shift $(( $# < 3 ? $# : 3 ))
KINDS=${*:-uniform grid boxes urot}
PF=${PF:-target/release/portalfind}
DIR=${DIR:-target/side_by_side}
mkdir -p "$DIR"
[ -x "$PF" ] || cargo build --release
: > "$DIR/runs.txt"
for k in $KINDS; do
  [ -f "$DIR/$k.f64" ] || "$PF" bench points "$k" "$N" "$DIR/$k.f64" > /dev/null
  for _ in $(seq "$RUNS"); do
    o=$("$PF" bench one "$k" "$N" | sed -E 's/.*"seconds":([0-9.]+).*"tets":([0-9]+).*/\1 \2/')
    c=$("$CGAL" "$DIR/$k.f64" 1 | sed -E 's/.*"best": ([0-9.]+).*"finite_cells": ([0-9]+).*/\1 \2/')
    echo "$k $o $c" | tee -a "$DIR/runs.txt"
  done
done
echo
summary "$DIR/runs.txt"
echo "tetrahedra, ours / CGAL (must agree):"
awk '!seen[$1]++ { print "  " $1 ": " $3 " / " $5 }' "$DIR/runs.txt"
