import csv,sys
rigid=('rotate','offset','scale','shuffle')
for path in sys.argv[1:]:
    r=list(csv.DictReader(open(path)))
    un=[x for x in r if x['same_rooms']=='false']
    rg=[x for x in un if x['variant'].startswith(rigid)]
    iso=sum(int(x['rooms_isolated'] or 0) for x in r); tot=sum(int(x['rooms'] or 0) for x in r)
    base={x['model']:x for x in r if x['variant']=='base'}
    biso=sum(int(x['rooms_isolated'] or 0) for x in base.values()); btot=sum(int(x['rooms'] or 0) for x in base.values())
    print(f"{path}: rows {len(r)} invalid {sum(x['validation']!='ok' for x in r)} unlike {len(un)} rigid-unlike {len(rg)} isolated {iso}/{tot} base-isolated {biso}/{btot}")
    for x in un: print(f"   {x['model']:32s} {x['variant']:16s} {x['rooms_isolated']}/{x['rooms']} base {base[x['model']]['rooms_isolated']}")
