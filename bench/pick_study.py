#!/usr/bin/python3
"""Issue 15 item 1 study: every reference distance of a case measured with both ends moved 1.5 cm
along the surface at right angles to the line (both ways), through `locard measure`, as an
investigator's clicks land near the tape points: 1.5 cm along the tangent (normal of the mesh
around the tape point, across the line), then onto the mesh (its closest point), where a click
would land. Counts the rows within their stated U with both ends snapped to a feature (a row
with an end "not snapped" is never counted within U) and the rows beyond 3 U. Uses Debian's
numpy (/usr/bin/python3). Measures into the case: give it a copy.
  bench/pick_study.py SCAN_DIR CASE_COPY [LOCARD] [--ends ENDS.json]
  (SCAN_DIR holds measurements.json, e.g. `locard scan-sim -o scan`; CASE_COPY a copy of
   `locard reconstruct scan -o case`; --ends writes each measured row's two ends - what each
   snapped to, how far along the line it lies from its tape end (+ outward), its standard
   uncertainty - for bench/pick_ends.py, which tells which kind of end carries the misses)"""
import argparse, json, subprocess, re, struct, sys
import numpy as np
ap=argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
ap.add_argument('scan'); ap.add_argument('case')
ap.add_argument('locard', nargs='?', default='build/release/locard')
ap.add_argument('--ends', help='write each measured row\'s two ends here (JSON)')
args=ap.parse_args()
scan, case, locard, ends_out = args.scan, args.case, args.locard, args.ends
refs=json.load(open(scan+'/measurements.json'))['measurements']
# mesh (binary PLY little endian): read vertices and faces
data=open(case+'/mesh/mesh.ply','rb').read()
hdr_end=data.index(b'end_header\n')+len(b'end_header\n'); hdr=data[:hdr_end].decode().splitlines()
nv=int([l for l in hdr if l.startswith('element vertex')][0].split()[2]); nf=int([l for l in hdr if l.startswith('element face')][0].split()[2])
props=[]; cur=None
for l in hdr:
    if l.startswith('element'): cur=l.split()[1]
    elif l.startswith('property') and cur=='vertex': props.append(l.split()[1])
sizes={'float':4,'double':8,'uchar':1,'int':4,'uint':4,'short':2,'ushort':2}
fmt={'float':'f','double':'d','uchar':'B','int':'i','uint':'I','short':'h','ushort':'H'}
vt=np.dtype([('p%d'%i,'<'+fmt[t]) for i,t in enumerate(props)])
V=np.frombuffer(data,dtype=vt,count=nv,offset=hdr_end)
P=np.stack([V['p0'],V['p1'],V['p2']],1).astype(float)
fo=hdr_end+vt.itemsize*nv
F=np.frombuffer(data,dtype=np.dtype([('n','u1'),('i','<i4',(3,))]),count=nf,offset=fo)['i']
C=P[F].mean(1); N=np.cross(P[F[:,1]]-P[F[:,0]],P[F[:,2]]-P[F[:,0]]); N/=np.linalg.norm(N,axis=1)[:,None]+1e-12
def closest_on_triangle(p,a,b,c):
    # Ericson, Real-Time Collision Detection 5.1.5
    ab=b-a; ac=c-a; ap=p-a; d1=ab@ap; d2=ac@ap
    if d1<=0 and d2<=0: return a
    bp=p-b; d3=ab@bp; d4=ac@bp
    if d3>=0 and d4<=d3: return b
    vc=d1*d4-d3*d2
    if vc<=0 and d1>=0 and d3<=0: return a+d1/(d1-d3)*ab
    cp=p-c; d5=ab@cp; d6=ac@cp
    if d6>=0 and d5<=d6: return c
    vb=d5*d2-d1*d6
    if vb<=0 and d2>=0 and d6<=0: return a+d2/(d2-d6)*ac
    va=d3*d6-d5*d4
    if va<=0 and d4-d3>=0 and d5-d6>=0: return b+(d4-d3)/((d4-d3)+(d5-d6))*(c-b)
    den=1/(va+vb+vc); return a+ab*vb*den+ac*vc*den
def onto_mesh(p):
    # A click lands on the mesh: the closest point of the nearest triangles.
    idx=np.argsort(np.linalg.norm(C-p,axis=1))[:64]
    best=None
    for f in idx:
        q=closest_on_triangle(p,P[F[f,0]],P[F[f,1]],P[F[f,2]])
        if best is None or np.linalg.norm(q-p)<np.linalg.norm(best-p): best=q
    return best
def normal_at(p):
    d=np.linalg.norm(C-p,axis=1); idx=np.argsort(d)[:30]
    n=N[idx]; n=n*np.sign(n@n[0])[:,None]; n=n.mean(0); return n/np.linalg.norm(n)
rows=[]; end_rows=[]
# A tape end the model lacks (a wall the flagged views alone saw, a part of a table never
# seen) cannot be clicked: `locard measure` refuses a point more than 5 cm from the mesh, and
# moving it onto the mesh's closest point would measure some other surface. Such rows are
# reported apart, as "tape end off the model", and never counted within U.
off_model=set()
for r in refs:
    for k in ('a','b'):
        p=np.array(r[k],float)
        if np.linalg.norm(onto_mesh(p)-p)>0.05: off_model.add(r['name'])
for r in refs:
    a=np.array(r['a'],float); b=np.array(r['b'],float); d=b-a; d/=np.linalg.norm(d)
    for sgn in (+1,-1):
        ends=[]
        for p in (a,b):
            t=np.cross(normal_at(p),d)
            if np.linalg.norm(t)<1e-6: t=np.cross([0,0,1],d)
            t/=np.linalg.norm(t); ends.append(onto_mesh(p+sgn*0.015*t))
        fa=','.join('%.4f'%v for v in ends[0]); fb=','.join('%.4f'%v for v in ends[1])
        out=subprocess.run([locard,'measure',case,'--from',fa,'--to',fb,'--no-report','--frame','world','--name','pick'],capture_output=True,text=True)
        m=re.search(r': ([0-9.]+) m \+- ([0-9.]+) m \(k=2\); ends (.+) and (.+)',out.stdout)
        if not m: rows.append((r['name'],sgn,None,None,None,out.stderr.strip()[:80])); continue
        dist,U=float(m.group(1)),float(m.group(2)); err=dist-r['distance_m']
        snapped = 'not snapped' not in (m.group(3)+m.group(4))
        if ends_out and r['name'] not in off_model:
            # The row just appended to the case (--name pick): its snapped ends, placed along
            # the line against the tape ends (positive: beyond the tape end, outward).
            last=json.load(open(case+'/measurements/measurements.json'))['measurements'][-1]
            row={'name':r['name'],'sign':sgn,'error_m':err,'U_m':U,'within_U':snapped and abs(err)<=U}
            for k,tape,outward in (('a',a,-d),('b',b,d)):
                e=last[k]
                row[k]={'feature':e['feature'],'along_m':float((np.array(e['snapped'])-tape)@outward),
                        'u_m':e['standard_uncertainty_m'],'views':e['views'],'points':e['points']}
            end_rows.append(row)
        rows.append((r['name'],sgn,err,U,snapped,m.group(3)+'/'+m.group(4)))
within=beyond=total=off=0
for name,sgn,err,U,sn,feat in rows:
    total+=1
    if err is None: print(f'{name:16s} {sgn:+d} FAILED {feat}'); continue
    if name in off_model:
        off+=1; print(f'{name:16s} {sgn:+d} error {1000*err:+7.1f} mm U {1000*U:5.1f} mm tape end off the model {feat}'); continue
    w = sn and abs(err)<=U; within+=w; beyond+= abs(err)>3*U
    print(f'{name:16s} {sgn:+d} error {1000*err:+7.1f} mm U {1000*U:5.1f} mm {"within" if w else ("not snapped" if not sn else "OUTSIDE")} {"(>3U)" if abs(err)>3*U else ""} {feat}')
print(f'within U (both ends snapped): {within}/{total}; beyond 3U: {beyond}/{total}; tape end off the model: {off}/{total}')
if ends_out: json.dump(end_rows,open(ends_out,'w'),indent=1)
