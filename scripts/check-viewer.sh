#!/usr/bin/env bash
# Checks the 3D viewer (`run --export html` -> viewer.html) in headless Chromium:
#   - loads the page from disk (file://, no server, no network), waits until it is ready;
#   - the page's state at load is the run's stop: its cell count equals the run's final
#     cells (as printed by `portalfind run`);
#   - steps the slider with real key presses (Home, ArrowRight x3, End) and by setting its
#     value; after each move the page's cell count must equal the recorded one
#     (weight_curve's cells remaining after that many collapses);
#   - clicks the middle of the picture and reads the info panel (a cell or a portal);
#   - screenshots the page at the stop and at step 0, and asserts the pictures are not
#     blank (enough pixels differ from the background, several colours);
#   - fails on any console error or uncaught page error.
# Chromium is Debian's `chromium` (installed with apt-get if missing and we are root); the
# driver is npm's playwright-core (installed into target/check-viewer/node), which drives
# that Chromium over CDP; WebGL runs on SwiftShader (software), so no GPU is needed.
#
# Usage: scripts/check-viewer.sh [MODEL [RUN OPTIONS...]]
#   default: the thesis's four_room_optimized with --heuristic refined --estimator hull
#   --stop cells:4. Outputs (viewer.html, screenshots, log) go to target/check-viewer/.
#   PORTALFIND=path picks the binary (default target/release/portalfind, built if missing).
#   SHOT=path also copies the screenshot at the stop there.
set -euo pipefail
cd "$(dirname "$0")/.."
work=target/check-viewer
bin=${PORTALFIND:-target/release/portalfind}
mkdir -p "$work"
[ -x "$bin" ] || cargo build --release

if ! command -v chromium >/dev/null; then
  if [ "$(id -u)" = 0 ]; then
    echo "installing Debian's chromium (apt-get) ..."
    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium) >"$work/apt.log" 2>&1 ||
      { echo "FAIL  could not install chromium (see $work/apt.log)"; exit 1; }
  else
    echo "FAIL  chromium is not installed (apt-get install chromium)"
    exit 1
  fi
fi
node_dir=$work/node
if [ ! -d "$node_dir/node_modules/playwright-core" ]; then
  npm install --silent --no-audit --no-fund --prefix "$node_dir" playwright-core@1.57.0 >/dev/null
fi

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
"$bin" run "$model" "${opts[@]}" --out "$out" --export html >"$work/run.log"
cells=$(awk '/^final cells /{print $NF}' "$work/run.log")
echo "run: $model: $cells final cells -> $out/viewer.html ($(du -k "$out/viewer.html" | cut -f1) KiB)"

set +e
NODE_PATH="$node_dir/node_modules" node scripts/check-viewer.js "$(realpath "$out/viewer.html")" "$cells" "$work"
status=$?
if [ -n "${SHOT:-}" ]; then cp "$work/viewer_stop.png" "$SHOT"; fi
exit $status
