import csv,sys
def load(p):
    rows=list(csv.DictReader(open(p)))
    return {(r['name'],r['config']):{k:v for k,v in r.items() if not k.startswith('seconds')} for r in rows}
ref=load('results/accuracy/round6/cases.csv')
new=load(sys.argv[1])
n=0;bad=0
for k,v in new.items():
    if k not in ref: print('missing in ref',k); bad+=1; continue
    n+=1
    if ref[k]!=v:
        bad+=1; print('DIFF',k,{c:(ref[k][c],v[c]) for c in v if ref[k][c]!=v[c]})
print(n,'compared',bad,'differ')
