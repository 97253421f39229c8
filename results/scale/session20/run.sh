#!/bin/bash
# Session 20 (issue 17) measurements, in one go on a quiet machine:
#  1. side by side at 1M: the session's base (0455725, /tmp/pf-base) and its final binary
#     (/tmp/pf-final, commit in binary.txt), interleaved fresh processes, two pairs;
#  2. `bench scale` over all sizes (growth exponents, run/tetra);
#  3. `bench scale` at 1M with 1 and 2 rayon threads, two runs each, interleaved.
# Model: portalfind gen rooms --nx 40 --ny 40 --tess 8 --out /tmp/rooms40.obj
cd "$(dirname "$0")/../../.."
O=results/scale/session20
for i in 1 2; do for b in base final; do
  rm -rf /tmp/cmp/s$b$i
  /usr/bin/time -v /tmp/pf-$b run /tmp/rooms40.obj --out /tmp/cmp/s$b$i > $O/side-by-side-$b$i.log 2> $O/side-by-side-$b$i.time
  rm -rf /tmp/cmp/s$b$i
done; done
/tmp/pf-final bench scale --out $O/full > $O/full.log 2>&1
/tmp/pf-final bench scale --min-triangles 900000 --threads 1,2 --repeat 2 --out $O/threads-1m > $O/threads-1m.log 2>&1
echo done > /tmp/s20.done
