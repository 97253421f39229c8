#!/bin/bash
# seal.sh BIN DIR CSV SIZE: for every map whose `complex` leaked in batch.sh's CSV, `complex
# --no-validate --seal-holes SIZE` (e.g. 1%): leaks left, openings sealed, active cells.
BIN=${1:?binary}; W=${2:-/tmp/oa}; CSV=${3:-$W/realmaps.csv}; SIZE=${4:-1%}
echo "map,leaks_before,active_before,seal_holes,openings_sealed,widest_sealed,leaks_after,active_after"
tail -n +2 "$CSV" | while IFS=, read -r m tris crc val leaks actb rest; do
  [ "$leaks" = "0" ] && continue
  log=$W/logs/seal_$m.log
  "$BIN" complex "$W/obj/$m.obj" --no-validate --seal-holes "$SIZE" > "$log" 2>&1
  sealed=$(grep -E "^openings sealed" "$log" | awk '{print $NF}')
  widest=$(grep -E "^sealed opening" "$log" | sed 's/.*width \([0-9.e+-]*\).*/\1/' | sort -g | tail -1)
  after=$(grep -E "^leaks " "$log" | awk '{print $NF}')
  act=$(grep -E "^active cells" "$log" | awk '{print $3}')
  echo "$m,$leaks,$actb,$SIZE,$sealed,$widest,$after,$act"
done
