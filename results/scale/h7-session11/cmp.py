import json,sys
def strip(x):
    if isinstance(x,dict): return {k:strip(v) for k,v in x.items() if not ('second' in k or 'time' in k or 'timing' in k or k in ('memory','peak_mib','elapsed'))}
    if isinstance(x,list): return [strip(v) for v in x]
    return x
a,b=sys.argv[1],sys.argv[2]
import os
for n in sorted(os.listdir(a)):
    p=os.path.join(a,n,'result.json')
    if not os.path.exists(p): continue
    x=json.dumps(strip(json.load(open(p))),sort_keys=True)
    q=os.path.join(b,n,'result.json')
    y=json.dumps(strip(json.load(open(q))),sort_keys=True) if os.path.exists(q) else None
    print('same' if x==y else 'DIFF', n, len(x))
