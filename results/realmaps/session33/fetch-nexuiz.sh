#!/bin/bash
# Fetches Nexuiz 2.5.2's game data (GPL; Debian package nexuiz-data, 267 MB, downloaded,
# not installed), extracts every map's .bsp (Quake 3 IBSP 46, as OpenArena's) and converts
# each with ../session31/q3obj.py (world model only; planar faces and meshes as triangles,
# Bezier patches 4 x 4 per 3 x 3 patch, nodraw/fog/flares skipped, triangles turned to the
# side Q3's vertex normals call front). Usage: fetch-nexuiz.sh [WORKDIR] (default /tmp/nx);
# writes WORKDIR/obj/*.obj (39 maps; the engine's empty _init map is skipped).
set -euo pipefail
W=${1:-/tmp/nx}
HERE=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$W/obj" "$W/x"
cd "$W"
ls nexuiz-data_*.deb >/dev/null 2>&1 || apt-get download nexuiz-data
dpkg-deb -x nexuiz-data_*.deb x
python3 - "$W" <<'PY'
import glob, os, sys, zipfile
w = sys.argv[1]
for pk in sorted(glob.glob(w + '/x/**/*.pk3', recursive=True)):
    z = zipfile.ZipFile(pk)
    for n in z.namelist():
        out = os.path.join(w, os.path.basename(n))
        if n.endswith('.bsp') and not n.endswith('_init.bsp') and not os.path.exists(out):
            open(out, 'wb').write(z.read(n))
PY
for f in "$W"/*.bsp; do
  m=$(basename "$f" .bsp)
  [ -f "$W/obj/$m.obj" ] || python3 "$HERE/../session31/q3obj.py" "$f" "$W/obj/$m.obj"
done
ls "$W"/obj/*.obj | wc -l
