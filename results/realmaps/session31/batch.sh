#!/bin/bash
# batch.sh BIN WORKDIR OUT.csv: on every WORKDIR/obj/*.obj, `BIN complex MODEL` (the full exact
# validation) and `BIN run MODEL` (defaults), each in a fresh process; one CSV row per map.
BIN=${1:?binary}; W=${2:-/tmp/oa}; OUT=${3:-$W/realmaps.csv}
echo "map,triangles,complex_rc,validation,leaks,active_cells,complex_seconds,run_rc,final_cells,final_portals,stop,initial_weights_s,collapses_s,run_seconds" > "$OUT"
for f in "$W"/obj/*.obj; do
  m=$(basename "$f" .obj)
  L=$W/logs; mkdir -p "$L"
  t0=$(date +%s.%N); timeout 1800 "$BIN" complex "$f" > "$L/complex_$m.log" 2>&1; crc=$?; t1=$(date +%s.%N)
  val=$(grep -E "^validate" "$L/complex_$m.log" | head -1 | cut -d" " -f1-2)
  [ -z "$val" ] && val=$(grep -iE "error" "$L/complex_$m.log" | head -1 | tr ',' ';' | cut -c1-100)
  leaks=$(grep -E "^leaks " "$L/complex_$m.log" | awk '{print $NF}' | head -1)
  act=$(grep -E "^active cells" "$L/complex_$m.log" | awk '{print $3}' | head -1)
  rm -rf "$W/out/$m"
  timeout 1800 "$BIN" run "$f" --out "$W/out/$m" > "$L/run_$m.log" 2>&1; rrc=$?
  g() { grep -E "^$1" "$L/run_$m.log" | head -1 | awk '{print $NF}'; }
  stop=$(grep -E "^stop rule" "$L/run_$m.log" | sed 's/.*\/ //' | cut -c1-40 | tr ',' ';')
  echo "$m,$(grep -c '^f ' "$f"),$crc,$val,$leaks,$act,$(echo "$t1 - $t0" | bc),$rrc,$(g 'final cells'),$(g 'final portal pairs'),$stop,$(g 'decimation: initial weights'),$(g 'decimation: collapses'),$(g 'total')" >> "$OUT"
done
