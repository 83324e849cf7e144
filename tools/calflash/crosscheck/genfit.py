"""The fit benchmark's design as a CSV: y and five inputs a..e, n rows (BENCHMARKS.md, calflash fit end to end).
Usage: python3 genfit.py N OUT.csv"""
import random, sys
n=int(sys.argv[1]); random.seed(3)
with open(sys.argv[2],'w') as f:
    f.write("y,a,b,c,d,e\n")
    w=f.write
    for i in range(n):
        v=[random.uniform(-1,1) for _ in range(5)]
        y=2.5+0.4*v[0]-0.3*v[1]+0.05*v[2]+0.01*v[0]*v[0]+1e-3*random.uniform(-1,1)
        w("%.9f,%.9f,%.9f,%.9f,%.9f,%.9f\n"%(y,v[0],v[1],v[2],v[3],v[4]))
