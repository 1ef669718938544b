#!/usr/bin/python3
"""The self-check's verdicts against the truth, view by view, from a sweep's saved reports.

    /usr/bin/python3 bench/room_robustness.py --seeds 1-50 --reports DIR   # once (an hour)
    /usr/bin/python3 bench/verified_views.py DIR                           # every room, seconds
    /usr/bin/python3 bench/verified_views.py DIR --seed 19                 # one room, each view

For each room: the verified views fitted to the truth as room_robustness.py fits them (rotation
by chordal mean, then translation), their ATE and worst view, and whether the room is accurate
(ATE <= 3 mm, every verified view within 1 cm / 0.5 degree). With --seed, each registered view's
error after that fit beside the check's figures (rotation constraint, slide constraint, the
tripod's play and the view's offset from the nodal model, the correction the check's ICP found)
and its reason when flagged: what a change to the check's rules would keep or drop can be read
here before the hour-long sweep that decides it.
"""
import argparse
import glob
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import room_robustness as rr  # noqa: E402


def registered_views(reports, seed):
    report = json.load(open(os.path.join(reports, f'{seed}.json')))
    truth = rr.load_tum(os.path.join(reports, f'{seed}.groundtruth.txt'))
    views = []
    for f in report['frames']:
        if f['status'] != 'registered' or 'T_world_camera' not in f:
            continue
        T = np.eye(4)
        T[:3, :] = np.array(f['T_world_camera'])
        views.append({'frame': f, 'T': T, 'G': truth[round(f['timestamp'], 4)],
                      'verified': bool(f.get('verified'))})
    return views, len(report['frames'])


def errors(views, R, t):
    for v in views:
        v['error_mm'] = float(np.linalg.norm(R @ v['T'][:3, 3] + t - v['G'][:3, 3])) * 1000
        v['error_deg'] = rr.rotation_deg(v['G'][:3, :3].T @ (R @ v['T'][:3, :3]))


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument('reports', help='the folder room_robustness.py --reports wrote')
    p.add_argument('--seed', type=int, help='list the views of this room')
    a = p.parse_args()
    seeds = sorted(int(os.path.basename(path)[:-5]) for path in glob.glob(os.path.join(a.reports, '*.json')))
    if a.seed is not None:
        seeds = [a.seed]
    accurate = 0
    for seed in seeds:
        views, total = registered_views(a.reports, seed)
        verified = [v for v in views if v['verified']]
        if len(verified) < 2:
            print(f'seed {seed:3d}: {len(verified)} of {total} views verified')
            continue
        R, t = rr.rigid_fit([(v['T'], v['G']) for v in verified])
        errors(views, R, t)
        ate = float(np.sqrt(np.mean([v['error_mm'] ** 2 for v in verified])))
        worst_mm = max(v['error_mm'] for v in verified)
        worst_deg = max(v['error_deg'] for v in verified)
        ok = ate <= 3.0 and worst_mm <= 10.0 and worst_deg <= 0.5
        accurate += ok
        print(f"seed {seed:3d}: {len(verified):3d} of {total:3d} views verified, ATE {ate:5.2f} mm, "
              f"worst {worst_mm:5.1f} mm / {worst_deg:.2f} deg  {'accurate' if ok else 'NOT accurate'}")
        if a.seed is None:
            continue
        print('  frame verified   error         constraint  slide   play   off-model  correction  reason')
        for v in views:
            c = v['frame'].get('check', {})
            print(f"  {v['frame']['frame_index']:5d} {'yes' if v['verified'] else 'no ':>8} "
                  f"{v['error_mm']:6.1f} mm {v['error_deg']:4.2f} deg  {c.get('constraint', float('nan')):.4f}  "
                  f"{c.get('slide_constraint', float('nan')):.4f}  {1000 * c.get('tripod_play_m', float('nan')):4.1f}  "
                  f"{1000 * c.get('tripod_residual_m', float('nan')):6.1f} mm  {1000 * c.get('correction_m', float('nan')):6.1f} mm  "
                  f"{c.get('reason', '')[:70]}")
    if a.seed is None:
        print(f'SUMMARY {accurate} of {len(seeds)} rooms accurate')


if __name__ == '__main__':
    main()
