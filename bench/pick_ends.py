#!/usr/bin/python3
"""Which kind of end carries the pick study's misses: reads the files `bench/pick_study.py
--ends` wrote (one per room) and prints, per feature an end snapped to (face, edge, corner,
outermost point, not snapped), how many ends, their mean and rms offset along the line from
the tape end, and how the offsets compare with the ends' stated standard uncertainty (rms of
offset / u near 1: U is honest; well above: U is too small for that kind of end); then every
row not measured within U (pick_study's verdict), with both ends. Uses Debian's numpy
(/usr/bin/python3).
  bench/pick_ends.py ENDS.json [ENDS.json ...]"""
import argparse, json, collections
import numpy as np
ap=argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
ap.add_argument('ends', nargs='+', help='files written by bench/pick_study.py --ends')
by_feature=collections.defaultdict(list); misses=[]; rows=0
for path in ap.parse_args().ends:
    for r in json.load(open(path)):
        rows+=1
        if not r['within_U']: misses.append((path,r))
        for k in 'ab': by_feature[r[k]['feature']].append((r[k]['along_m'],r[k]['u_m']))
print(f'{rows} rows measured, {rows-len(misses)} within U with both ends snapped ({100*(rows-len(misses))/max(rows,1):.1f} %)')
print(f'{"end snapped to":26s} {"ends":>5s} {"mean mm":>8s} {"rms mm":>7s} {"rms along/u":>12s} {"|along|>2u":>10s}')
for feature,v in sorted(by_feature.items(),key=lambda x:-len(x[1])):
    along=np.array([x[0] for x in v]); u=np.array([x[1] for x in v])
    z=along[u>0]/u[u>0]
    zrms=f'{np.sqrt((z*z).mean()):12.2f}' if len(z) else f'{"-":>12s}'
    print(f'{feature:26s} {len(v):5d} {1000*along.mean():+8.2f} {1000*np.sqrt((along*along).mean()):7.2f} {zrms} {int((abs(z)>2).sum()):10d}')
print('rows not within U:')
for path,r in misses:
    ends=' | '.join(f"{k} {r[k]['feature']} {1000*r[k]['along_m']:+.1f} mm (u {1000*r[k]['u_m']:.1f}, {r[k]['points']} points, {r[k]['views']} views)" for k in 'ab')
    print(f"  {path}: {r['name']} {r['sign']:+d}: {1000*r['error_m']:+.1f} mm at U {1000*r['U_m']:.1f} mm; {ends}")
