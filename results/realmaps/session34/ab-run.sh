#!/bin/bash
# ab-run.sh OLD NEW MODEL [OUT]: `run MODEL` at defaults with OLD then NEW (fresh processes,
# back to back); appends one line per binary to OUT (default ab.txt): initial weights,
# collapses and total seconds as `run` printed them, then GNU time's wall seconds and peak KB.
# Outputs stay in ${WORK:-/tmp}/ab-BINARYNAME for comparison.
OLD=${1:?old binary}; NEW=${2:?new binary}; MODEL=${3:?model}; OUT=${4:-ab.txt}
for b in "$OLD" "$NEW"; do
  n=$(basename "$b")
  d=${WORK:-/tmp}/ab-$n
  rm -rf "$d"
  /usr/bin/time -f "%e s %M KB" "$b" run "$MODEL" --out "$d" > "$d.log" 2>&1
  echo "$n $(grep -E 'collapses  |initial weights|^total' "$d.log" | awk '{print $NF}' | tr '\n' ' ') $(tail -1 "$d.log")" >> "$OUT"
done
