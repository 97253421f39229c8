#!/usr/bin/env bash
# Vendors three.js for the 3D viewer (src/output/viewer.rs inlines it into viewer.html with
# include_str!, so a fresh clone needs no npm). Run once per upgrade; commits nothing itself.
#
# three.js is MIT-licensed (assets/three/LICENSE). 0.170.0 is the last release whose build
# ships one self-contained minified ES module (build/three.module.min.js); from 0.171 on the
# module build is split into three.module.js + three.core.js and no minified file is shipped.
#
# Usage: scripts/vendor-three.sh [VERSION]   (default 0.170.0)
set -euo pipefail
cd "$(dirname "$0")/.."
version=${1:-0.170.0}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
(cd "$tmp" && npm pack --silent "three@$version" >/dev/null && tar xzf "three-$version.tgz")
mkdir -p assets/three
cp "$tmp/package/build/three.module.min.js" assets/three/three.module.min.js
cp "$tmp/package/LICENSE" assets/three/LICENSE
echo "three $version -> assets/three/three.module.min.js"
sha256sum assets/three/three.module.min.js
