import csv,sys
def load(p):
    rows={}
    for r in csv.DictReader(open(p)):
        r.pop('seconds',None)
        rows[(r['model'],r['variant'])]=r
    return rows
a,b=load(sys.argv[1]),load(sys.argv[2])
diff=[k for k in a if k in b and a[k]!=b[k]]
print(len(a),len(b),"compared",len(set(a)&set(b)),"differ",len(diff))
for k in diff[:20]:
    print(k,{c:(a[k][c],b[k][c]) for c in a[k] if a[k][c]!=b[k][c]})
