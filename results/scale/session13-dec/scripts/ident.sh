#!/bin/bash
# usage: ident.sh NEWBIN [models...]; compares result.json (timings stripped) and weight_curve.csv with /tmp/pf-base
NEW=$1; shift
MODELS=${@:-"/work/main/models/thesis/*.obj /work/main/models/doors/nonaligned_doors.obj /work/main/models/quake/e1m1.obj /tmp/m/rooms5.obj /tmp/m/rooms13.obj"}
fail=0
for m in $MODELS; do
  n=$(basename $m .obj)
  for b in base new; do
    bin=/tmp/pf-base; [ $b = new ] && bin=$NEW
    rm -rf /tmp/id/$b/$n; mkdir -p /tmp/id/$b
    $bin run $m --out /tmp/id/$b/$n > /tmp/id/$b/$n.log 2>&1 || echo "RUN FAIL $b $n"
  done
  for b in base new; do
    python3 -c "
import json,sys
d=json.load(open('/tmp/id/$b/$n/result.json'))
def strip(x):
  if isinstance(x,dict): return {k:strip(v) for k,v in x.items() if not any(w in k for w in ('seconds','timings','peak','mib','memory'))}
  if isinstance(x,list): return [strip(v) for v in x]
  return x
json.dump(strip(d),open('/tmp/id/$b/$n.stripped.json','w'),sort_keys=True)"
  done
  if cmp -s /tmp/id/base/$n.stripped.json /tmp/id/new/$n.stripped.json && cmp -s /tmp/id/base/$n/weight_curve.csv /tmp/id/new/$n/weight_curve.csv; then
    echo "IDENTICAL $n ($(wc -l < /tmp/id/new/$n/weight_curve.csv) curve lines)"
  else
    echo "DIFFERENT $n"; fail=1
  fi
done
exit $fail
