import csv,sys
a=list(csv.DictReader(open(sys.argv[1]))); b=list(csv.DictReader(open(sys.argv[2])))
assert len(a)==len(b)
keys=['final_portals','rooms_isolated','same_rooms','active_cells','validation']
n=0
for x,y in zip(a,b):
    d=[(k,x[k][:60],y[k][:60]) for k in x if k!='seconds' and x[k]!=y[k]]
    if d: n+=1; print(x['model'],x['variant'],d)
print(len(a),'rows,',n,'differ')
