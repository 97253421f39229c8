#!/bin/bash
# usage: ab.sh MODEL N BIN... : interleaved fresh runs; prints wall, user, peak and stage lines of interest
M=$1; N=$2; shift 2
for i in $(seq $N); do for b in "$@"; do
  rm -rf /tmp/ab-out; /usr/bin/time -f "%e %U %M" -o /tmp/ab.time $b run $M --out /tmp/ab-out > /tmp/ab.log 2>&1
  echo "$(basename $b) $(cat /tmp/ab.time) | $(grep -E '^(decimation: initial|decimation: collapses|write outputs|total)' /tmp/ab.log | awk '{print $NF}' | tr '\n' ' ')"
done; done
