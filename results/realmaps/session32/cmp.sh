#!/bin/bash
# usage: cmp.sh OLD NEW OBJDIR OUTCSV
# For each map in OBJDIR (from ../session31/fetch.sh), `run` at defaults with OLD then NEW
# (fresh processes, back to back, so both see the same machine load); records the
# collapses' and the whole run's seconds as each printed them, and whether the two runs'
# result.json (timings and memory stripped) and weight_curve.csv are identical.
OLD=$1; NEW=$2; OBJ=$3; CSV=$4
WORK=$(mktemp -d)
echo "map,old_collapses,new_collapses,old_total,new_total,identical" > "$CSV"
for m in "$OBJ"/*.obj; do
  n=$(basename "$m" .obj)
  for b in old new; do
    bin=$OLD; [ $b = new ] && bin=$NEW
    rm -rf "$WORK/$b/$n"; mkdir -p "$WORK/$b"
    "$bin" run "$m" --out "$WORK/$b/$n" > "$WORK/$b/$n.log" 2>&1
  done
  same=$(python3 - "$WORK" "$n" <<'PY'
import json, sys
w, n = sys.argv[1], sys.argv[2]
def strip(x):
    if isinstance(x, dict):
        return {k: strip(v) for k, v in x.items()
                if not any(s in k for s in ('seconds', 'timings', 'peak', 'mib', 'memory', 'stages'))}
    if isinstance(x, list):
        return [strip(v) for v in x]
    return x
try:
    a = [strip(json.load(open(f'{w}/{b}/{n}/result.json'))) for b in ('old', 'new')]
    c = [open(f'{w}/{b}/{n}/weight_curve.csv').read() for b in ('old', 'new')]
    print('yes' if a[0] == a[1] and c[0] == c[1] else 'NO')
except OSError as e:
    print('missing')
PY
)
  g() { grep -E "^$2 " "$WORK/$1/$n.log" | awk '{print $NF}'; }
  echo "$n,$(g old 'decimation: collapses'),$(g new 'decimation: collapses'),$(g old total),$(g new total),$same" >> "$CSV"
  rm -rf "$WORK/old/$n" "$WORK/new/$n"
done
rm -rf "$WORK"
