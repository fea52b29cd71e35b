#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""How far the fan triangulation of an OBJ list's polygons (what the OBJ reader does) is from
the polygons: per file, the fans' total area against the polygons' own (Newell's normal, exact for
planar polygons). Reads the paths listed in LIST (default /tmp/f820.txt).

  /usr/bin/python3 bench/robustness/fan_area.py LIST
"""
import sys, numpy as np
bad=0; tot=0; worst=[]
for path in open(sys.argv[1] if len(sys.argv) > 1 else '/tmp/f820.txt').read().split():
    V=[]; polys=[]
    for line in open(path, errors='replace'):
        if line.startswith('v '):
            V.append([float(x) for x in line.split()[1:4]])
        elif line.startswith('f '):
            idx=[int(t.split('/')[0]) for t in line.split()[1:]]
            if len(idx)>3: polys.append(idx)
    if not polys: continue
    V=np.array(V); n=len(V)
    fan=0.0; true=0.0
    for p in polys:
        q=[i-1 if i>0 else n+i for i in p]; P=V[q]
        newell=np.zeros(3)
        for k in range(len(P)): newell+=np.cross(P[k],P[(k+1)%len(P)])
        true+=np.linalg.norm(newell)/2
        fan+=sum(np.linalg.norm(np.cross(P[k]-P[0],P[k+1]-P[0]))/2 for k in range(1,len(P)-1))
    tot+=1
    if true>0 and fan>1.05*true:
        bad+=1; worst.append((fan/true, path.split('/')[-1]))
print('files with polygons:', tot, 'fan area > 1.05x the polygons\' area:', bad)
print(sorted(worst)[-8:])
