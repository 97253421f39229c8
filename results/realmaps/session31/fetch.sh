#!/bin/bash
# Fetches OpenArena's game data (GPL; Debian packages openarena-data, openarena-085-data,
# openarena-088-data: 153 MB, downloaded, not installed), extracts every map's .bsp and
# converts each to OBJ with q3obj.py: world geometry (model 0), planar faces and meshes as
# triangles, Bezier patches 4 x 4 per 3 x 3 patch, triangles turned to face the side Q3's
# vertex normals give. Usage: fetch.sh [WORKDIR] (default /tmp/oa); writes WORKDIR/obj/*.obj.
set -euo pipefail
W=${1:-/tmp/oa}
HERE=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$W/obj" "$W/x"
cd "$W"
for p in openarena-data openarena-085-data openarena-088-data; do
  ls ${p}_*.deb >/dev/null 2>&1 || apt-get download "$p"
  dpkg-deb -x ${p}_*.deb x
done
python3 - "$W" <<'PY'
import glob, os, sys, zipfile
w = sys.argv[1]
# Later patches first: a map in several paks is taken from the newest.
for pk in sorted(glob.glob(w + '/x/**/*.pk3', recursive=True), reverse=True):
    z = zipfile.ZipFile(pk)
    for n in z.namelist():
        out = os.path.join(w, os.path.basename(n))
        if n.endswith('.bsp') and not os.path.exists(out):
            open(out, 'wb').write(z.read(n))
PY
for f in "$W"/*.bsp; do
  m=$(basename "$f" .bsp)
  [ -f "$W/obj/$m.obj" ] || python3 "$HERE/q3obj.py" "$f" "$W/obj/$m.obj"
done
ls "$W"/obj/*.obj | wc -l
