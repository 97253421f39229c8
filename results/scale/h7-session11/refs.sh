#!/bin/bash
# usage: refs.sh BIN OUTDIR — `portalfind run` at defaults on the identity models
# (then: python3 cmp.py OUTDIR_A OUTDIR_B compares result.json without timings).
# rooms13.obj: portalfind gen rooms --nx 13 --ny 13 --tess 8 --out /tmp/h7/models/rooms13.obj
BIN=$1; OUT=$2; mkdir -p $OUT
for m in models/thesis/*.obj /work/shared/models/quake/e1m1.obj /tmp/h7/models/rooms13.obj; do
  n=$(basename $m .obj)
  $BIN run $m --out $OUT/$n > $OUT/$n.log 2>&1
done
