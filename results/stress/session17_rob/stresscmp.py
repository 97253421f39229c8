import csv,sys
a={ (r['model'],r['variant']):r for r in csv.DictReader(open(sys.argv[1]))}
b={ (r['model'],r['variant']):r for r in csv.DictReader(open(sys.argv[2]))}
print(len(a),len(b))
n=0
for k in a:
  ra,rb=a[k],b[k]
  diff=[c for c in ra if c!='seconds' and ra[c]!=rb[c]]
  if diff:
    n+=1
    print(k, {c:(ra[c][:60],rb[c][:60]) for c in diff})
print('rows differing',n)
