#!/usr/bin/env bash
# Checks portalfind's exports (`run --export prt,obj,gltf,dot`) with real consumers:
#   glTF  the Khronos glTF-Validator (npm package gltf-validator; it is a library, so a
#         few lines of node call its validateBytes) on cells.glb: no errors allowed
#   DOT   Graphviz `dot -Tsvg` renders portals.dot (Debian graphviz, installed if missing
#         and we are root)
#   OBJ   portalfind's own reader (`portalfind info`) reads cells.obj; object counts match
#         the run's cells and portal pairs
#   PRT1  header and limits checked here; re-read and checked against qbsp's e1m1.prt
#         conventions by `cargo test --test exports`
#   Blender (optional): if `blender` is on PATH, imports cells.obj and cells.glb headless and
#         counts the Cell_/Portal_ and Room_ objects (the glTF importer needs python3-numpy;
#         no counts printed is a failure)
#   HTML  scripts/check-viewer.sh: viewer.html in headless Chromium (slider, click,
#         screenshots, no console errors); SKIP_VIEWER=1 skips it
#
# Usage: scripts/check-exports.sh [MODEL [RUN OPTIONS...]]
#   default: the thesis's four_room_optimized with --heuristic refined --estimator hull
#   --stop cells:4. Outputs go to target/check-exports/. PORTALFIND=path picks the binary
#   (default target/release/portalfind, built if missing).
set -euo pipefail
cd "$(dirname "$0")/.."
work=target/check-exports
bin=${PORTALFIND:-target/release/portalfind}
mkdir -p "$work"
[ -x "$bin" ] || cargo build --release
fail=0
pass() { echo "PASS  $*"; }
bad() { echo "FAIL  $*"; fail=1; }

if [ $# -ge 1 ]; then
  model=$1
  shift
  opts=("$@")
else
  "$bin" gen thesis four_room_optimized --out "$work/model" >/dev/null
  model=$work/model/four_room_optimized.obj
  opts=(--heuristic refined --estimator hull --stop cells:4)
fi
out=$work/run
rm -rf "$out"
"$bin" run "$model" "${opts[@]}" --out "$out" --export prt,obj,gltf,dot >"$work/run.log"
cells=$(awk '/^final cells /{print $NF}' "$work/run.log")
pairs=$(awk '/^final portal pairs /{print $NF}' "$work/run.log")
echo "run: $model: $cells cells, $pairs portal pairs -> $out"

# --- glTF: Khronos glTF-Validator ------------------------------------------------------
val=$work/node
if [ ! -d "$val/node_modules/gltf-validator" ]; then
  npm install --silent --no-audit --no-fund --prefix "$val" gltf-validator@2.0.0-dev.3.10 >/dev/null
fi
if NODE_PATH="$val/node_modules" node - "$out/cells.glb" >"$work/gltf-report.txt" <<'EOF'
const fs = require('fs');
const validator = require('gltf-validator');
const file = process.argv[2];
validator.validateBytes(new Uint8Array(fs.readFileSync(file)), { maxIssues: 100 }).then((r) => {
  const i = r.issues;
  console.log(`${r.validatorVersion}: ${file}: ${i.numErrors} errors, ${i.numWarnings} warnings, ` +
    `${i.numInfos} infos, ${i.numHints} hints; ` +
    `${r.info.materialCount ?? '?'} materials, ` +
    `${r.info.totalVertexCount ?? '?'} vertices, ${r.info.totalTriangleCount ?? '?'} triangles`);
  for (const m of i.messages) console.log(`  ${['error', 'warning', 'info', 'hint'][m.severity]} ${m.code} ${m.pointer ?? ''}: ${m.message}`);
  process.exit(i.numErrors > 0 ? 1 : 0);
}, (e) => { console.log(`validator failed: ${e}`); process.exit(1); });
EOF
then
  pass "gltf-validator: $(head -1 "$work/gltf-report.txt")"
else
  bad "gltf-validator: $(cat "$work/gltf-report.txt")"
fi
[ "$(wc -l <"$work/gltf-report.txt")" -gt 1 ] && sed 1d "$work/gltf-report.txt"

# --- DOT: Graphviz ------------------------------------------------------------------------
if ! command -v dot >/dev/null; then
  if [ "$(id -u)" = 0 ]; then
    (apt-get update -qq && apt-get install -y -qq graphviz) >/dev/null 2>&1 || true
  fi
fi
if command -v dot >/dev/null; then
  if dot -Tsvg "$out/portals.dot" -o "$out/portals.svg" 2>"$work/dot.err" && [ ! -s "$work/dot.err" ]; then
    nodes=$(grep -c '<g id="node' "$out/portals.svg" || true)
    edges=$(grep -c '<g id="edge' "$out/portals.svg" || true)
    if [ "$nodes" = "$cells" ] && [ "$edges" = "$pairs" ]; then
      pass "dot -Tsvg ($(dot -V 2>&1)): $nodes nodes, $edges edges -> $out/portals.svg"
    else
      bad "dot -Tsvg: $nodes nodes (want $cells), $edges edges (want $pairs)"
    fi
  else
    bad "dot -Tsvg: $(cat "$work/dot.err")"
  fi
else
  bad "dot: Graphviz not installed (apt-get install graphviz)"
fi

# --- OBJ: portalfind's own reader, object counts ------------------------------------------
if "$bin" info "$out/cells.obj" >"$work/obj-info.txt" 2>&1; then
  ocells=$(grep -c '^o Cell_' "$out/cells.obj" || true)
  oportals=$(grep -c '^o Portal_[0-9]*_[0-9]*$' "$out/cells.obj" || true)
  ohulls=$(grep -c '^o Portal_[0-9]*_[0-9]*_hull$' "$out/cells.obj" || true)
  faces=$(grep -c '^f ' "$out/cells.obj" || true)
  if [ "$ocells" = "$cells" ] && [ "$oportals" = "$pairs" ] && [ "$ohulls" = "$pairs" ]; then
    pass "OBJ read back by portalfind info: $faces faces; $ocells Cell_, $oportals Portal_ and $ohulls Portal_*_hull objects"
  else
    bad "OBJ: $ocells Cell_ objects (want $cells), $oportals Portal_ and $ohulls Portal_*_hull objects (want $pairs each)"
  fi
else
  bad "OBJ: portalfind info failed: $(tail -3 "$work/obj-info.txt")"
fi

# --- PRT1: header, line count, vis's limits ----------------------------------------------
if awk -v cells="$cells" '
  NR == 1 { if ($0 != "PRT1") { print "line 1 is not PRT1"; exit 1 } next }
  NR == 2 { leaves = $1; next }
  NR == 3 { n = $1; next }
  NF > 0 {
    lines++
    if ($1 > 64) { print "line " NR ": " $1 " points"; exit 1 }
    if ($2 >= leaves || $3 >= leaves) { print "line " NR ": leaf out of range"; exit 1 }
    per[$2]++; per[$3]++
    if (NF != 3 + 4 * $1) { print "line " NR ": " NF " fields for " $1 " points"; exit 1 }
  }
  END {
    if (lines != n) { print "header says " n " portals, " lines " lines"; exit 1 }
    for (l in per) if (per[l] > 128) { print "leaf " l ": " per[l] " portals"; exit 1 }
    if (leaves < cells) { print leaves " leaves for " cells " cells"; exit 1 }
    print leaves " leaves, " n " portal lines"
  }' "$out/cells.prt" >"$work/prt.txt"; then
  pass "PRT1: $(cat "$work/prt.txt") (re-read and checked against e1m1.prt by cargo test --test exports)"
else
  bad "PRT1: $(cat "$work/prt.txt")"
fi

# --- Blender (optional) --------------------------------------------------------------------
if command -v blender >/dev/null; then
  for f in cells.obj cells.glb; do
    if [ "$f" = cells.obj ]; then imp="bpy.ops.wm.obj_import(filepath='$out/$f')"; else imp="bpy.ops.import_scene.gltf(filepath='$out/$f')"; fi
    blender -b --factory-startup --python-expr "
import bpy
try:  # Debian's Blender 3.4 glTF importer still uses np.bool, which NumPy 1.24 removed
    import numpy
    if not hasattr(numpy, 'bool'):
        numpy.bool = bool
except ImportError:
    pass
bpy.ops.wm.read_factory_settings(use_empty=True)
$imp
names = [o.name for o in bpy.data.objects]
print('BLENDER', sum(n.startswith('Cell_') for n in names), 'Cell_,', sum(n.endswith('-room') for n in names),
      '-room,', sum('Portal_' in n for n in names), 'Portal_ objects')
" >"$work/blender-$f.txt" 2>&1 || true
    if grep -q '^BLENDER' "$work/blender-$f.txt"; then
      pass "blender $f: $(grep '^BLENDER' "$work/blender-$f.txt")"
    else
      bad "blender $f: Blender printed no object counts (import failed?); see $work/blender-$f.txt"
    fi
  done
else
  echo "SKIP  blender not installed (optional: apt-get install blender)"
fi

# --- HTML viewer: headless Chromium (scripts/check-viewer.sh) ------------------------------
if [ "${SKIP_VIEWER:-0}" = 1 ]; then
  echo "SKIP  viewer.html (SKIP_VIEWER=1)"
elif PORTALFIND="$bin" scripts/check-viewer.sh "$model" "${opts[@]}" >"$work/viewer.txt" 2>&1; then
  pass "viewer.html in headless Chromium: $(grep -c '^PASS' "$work/viewer.txt") checks passed (log: $work/viewer.txt)"
else
  bad "viewer.html in headless Chromium: $(grep '^FAIL' "$work/viewer.txt" | head -3 | tr '\n' ' ') (log: $work/viewer.txt)"
fi

exit $fail
