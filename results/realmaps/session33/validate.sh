#!/bin/bash
# validate.sh BIN OBJDIR OUT.csv [TIMEOUT]: `BIN complex MODEL` (the full exact validation)
# on every OBJDIR/*.obj in a fresh process; one row per map: validation, the tolerance level
# the complex was valid at (0: the model's own; more: the ladder rebuilt it), leaks,
# active cells, wall seconds and peak memory (GNU time).
BIN=${1:?binary}; DIR=${2:?objdir}; OUT=${3:?csv}; TO=${4:-1800}
L=$(mktemp -d)
echo "map,rc,validation,tolerance_level,leaks,active_cells,seconds,peak_mib" > "$OUT"
for f in "$DIR"/*.obj; do
  m=$(basename "$f" .obj)
  /usr/bin/time -f "%e %M" -o "$L/$m.time" timeout "$TO" "$BIN" complex "$f" > "$L/$m.log" 2>&1; rc=$?
  val=$(grep -E "^validate" "$L/$m.log" | head -1 | cut -d" " -f1-2)
  [ -z "$val" ] && val=$(grep -iE "error" "$L/$m.log" | head -1 | tr ',' ';' | cut -c1-100)
  lvl=$(grep -E "^tolerance level" "$L/$m.log" | awk '{print $7}')
  leaks=$(grep -E "^leaks " "$L/$m.log" | awk '{print $NF}' | head -1)
  act=$(grep -E "^active cells" "$L/$m.log" | awk '{print $3}' | head -1)
  read -r secs kb < <(tail -1 "$L/$m.time")
  echo "$m,$rc,$val,$lvl,$leaks,$act,$secs,$((kb / 1024))" >> "$OUT"
done
rm -rf "$L"
