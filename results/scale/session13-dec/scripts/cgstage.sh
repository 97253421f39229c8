#!/bin/bash
# usage: cgstage.sh BIN TAG MODEL -> per-stage instruction counts (RAYON_NUM_THREADS=1)
BIN=$1; TAG=$2; M=$3
out=/tmp/cgs/$TAG
rm -f $out $out.*
RAYON_NUM_THREADS=1 valgrind --tool=callgrind --callgrind-out-file=$out \
  --dump-before='portalfind::decimate::clearance::CellField::new' --dump-after='portalfind::decimate::clearance::CellField::new' \
  --dump-after='portalfind::decimate::clearance::run_inner' $BIN run $M --out /tmp/cgout-$TAG > $out.log 2>&1
s() { grep -h '^summary' $1 | awk '{print $2}'; }
tot=$(( $(s $out.1) + $(s $out.2) + $(s $out.3) + $(s $out.4) + $(s $out) ))
echo "$TAG before-field=$(s $out.1) field=$(s $out.2) pass1=$(s $out.3) labels+pass2=$(s $out.4) after=$(s $out) total=$tot"
