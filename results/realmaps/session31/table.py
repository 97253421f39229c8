#!/usr/bin/env python3
"""table.py realmaps.csv: the Markdown summary and per-map table of batch.sh's CSV."""
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
n = len(rows)
ok = sum(r['validation'] == 'validate ok' for r in rows)
crc = sum(r['complex_rc'] == '0' for r in rows)
rrc = sum(r['run_rc'] == '0' for r in rows)
leak = sum(r['leaks'] not in ('', '0') for r in rows)
tris = sum(int(r['triangles']) for r in rows)
print(f'{n} maps, {tris:,} triangles in all: `complex` exit 0 on {crc}, full validation ok on {ok}; '
      f'{leak} leak (open to the outside); `run` exit 0 on {rrc}.\n')
print('| map | triangles | validation | leaks | active cells | `complex` s | final cells | final portal pairs | stop | initial weights s | collapses s | `run` s |')
print('|---|---:|---|---:|---:|---:|---:|---:|---|---:|---:|---:|')
for r in rows:
    stop = r['stop'].replace('lowest weight ', 'w ').replace(' reached', '')
    try:
        stop = 'w %.3f' % float(stop[2:]) if stop.startswith('w ') else stop
    except ValueError:
        pass
    print(f"| {r['map']} | {int(r['triangles']):,} | {r['validation']} | {r['leaks']} | {int(r['active_cells'] or 0):,} | "
          f"{float(r['complex_seconds']):.1f} | {r['final_cells']} | {r['final_portals']} | {stop} | "
          f"{r['initial_weights_s']} | {r['collapses_s']} | {r['run_seconds']} |")
