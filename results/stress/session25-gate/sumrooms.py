import csv,sys
for f in sys.argv[1:]:
    r=list(csv.DictReader(open(f)))
    iso=sum(int(x['rooms_isolated']) for x in r); tot=sum(int(x['rooms']) for x in r)
    other=sum(1 for x in r if x['same_rooms']!='true')
    full=sum(1 for x in r if x['rooms_isolated']==x['rooms'])
    print(f, 'rooms isolated', iso,'/',tot, 'rows all rooms',full,'/',len(r),'other-rooms rows',other)
