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


def room_files(reports, seed):
    return os.path.join(reports, f'{seed}.json'), os.path.join(reports, f'{seed}.groundtruth.txt')


def print_views(reports, seed):
    """Each registered view's error after the fit of the verified ones, beside the check's figures."""
    report_path, truth_path = room_files(reports, seed)
    truth = rr.load_tum(truth_path)
    views = []
    for f in json.load(open(report_path))['frames']:
        if f['status'] != 'registered' or 'T_world_camera' not in f:
            continue
        T = np.eye(4)
        T[:3, :] = np.array(f['T_world_camera'])
        views.append((f, T, truth[round(f['timestamp'], 4)]))
    verified = [(T, G) for f, T, G in views if f.get('verified')]
    if len(verified) < 2:
        return
    R, t = rr.rigid_fit(verified)
    print('  frame verified   error         constraint  slide   play   off-model  correction  reason')
    for f, T, G in views:
        mm, deg = rr.view_error(R, t, T, G)
        c = f.get('check', {})
        print(f"  {f['frame_index']:5d} {'yes' if f.get('verified') else 'no ':>8} "
              f"{mm:6.1f} mm {deg:4.2f} deg  {c.get('constraint', float('nan')):.4f}  "
              f"{c.get('slide_constraint', float('nan')):.4f}  {1000 * c.get('tripod_play_m', float('nan')):4.1f}  "
              f"{1000 * c.get('tripod_residual_m', float('nan')):6.1f} mm  {1000 * c.get('correction_m', float('nan')):6.1f} mm  "
              f"{c.get('reason', '')[:70]}")


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
        row = rr.evaluate_report(*room_files(a.reports, seed))
        ok = rr.is_accurate(row)
        accurate += ok
        verified = row['views'] - row['flagged']
        print(f"seed {seed:3d}: {verified:3d} of {row['views']:3d} views verified, ATE {row['ate_mm']:5.2f} mm, "
              f"worst {row['worst_mm']:5.1f} mm / {row['worst_deg']:.2f} deg  {'accurate' if ok else 'NOT accurate'}")
        if a.seed is not None:
            print_views(a.reports, seed)
    if a.seed is None:
        print(f'SUMMARY {accurate} of {len(seeds)} rooms accurate')


if __name__ == '__main__':
    main()
