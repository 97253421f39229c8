import csv,sys
for f in sys.argv[1:]:
    r=list(csv.DictReader(open(f)))
    cl=[x for x in r if x['closed']=='true']
    lk=sum(1 for x in cl if x['leaks'] not in ('0',''))
    inval=sum(1 for x in r if x['validation']!='ok')
    iso=sum(int(x['rooms_isolated']) for x in r); tot=sum(int(x['rooms']) for x in r)
    other=sum(1 for x in r if x['same_rooms']!='true')
    print(f'{f}: rows {len(r)}, invalid {inval}, closed rows leaking {lk}/{len(cl)}, rooms {iso}/{tot}, other-rooms rows {other}')
