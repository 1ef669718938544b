#!/usr/bin/python3
"""Alignment robustness over generated rooms (issue 13).

For each seed: `locard scan-sim --random SEED` draws a room, its objects, a tripod scan and a
sensor; `locard align` aligns it; the result is compared view by view with the simulator's
exact poses. A view is
  good     registered, verified, and within 0.5 deg / 1 cm of the truth (after the best
           rigid fit of the verified views, rotation by chordal mean),
  flagged  registered but flagged by the self-check, or not registered (reported by index),
  silent   registered, verified, and more than 2 deg or 5 cm off: the failure that must not
           happen, a wrong view that claims to be right.
A room succeeds when align exits 0 (>= 90 % of views verified), ATE <= 3 mm and every
verified view is good. It is accurate (the issue's "within the bar, the rest flagged") when
ATE <= 3 mm and every verified view is good, whatever share of views was verified. The fit to the truth and the ATE use the verified views: what the run
vouches for. Each room also prints the ATE of every registered view (the alignment's own
accuracy, flags aside) and the error's systematic part: the mean offset along the views'
own viewing directions and the mean rotation error in the camera frame.

  /usr/bin/python3 bench/room_robustness.py --locard build/release/locard --seeds 1-50 \
      [--sensor kinect_v1|kinect_v2] [--surfaces plain|textured] [--work DIR] [--json OUT]
      [--reports DIR]

Prints one line per room and a summary; the work folder is removed unless --keep.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np


def quat_to_matrix(q):
    x, y, z, w = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def load_tum(path):
    poses = {}
    with open(path) as f:
        for line in f:
            if line.startswith('#') or not line.strip():
                continue
            v = [float(x) for x in line.split()]
            T = np.eye(4)
            T[:3, :3] = quat_to_matrix(v[4:8])
            T[:3, 3] = v[1:4]
            poses[round(v[0], 4)] = T
    return poses


def rotation_deg(R):
    return float(np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))))


def rotation_vector_deg(R):
    """Axis times angle (degrees) of a rotation matrix."""
    angle = np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))
    if angle < 1e-12:
        return np.zeros(3)
    axis = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) / (2 * np.sin(angle))
    return axis * np.degrees(angle)


def rigid_fit(pairs):
    """Best rigid fit (R, t) of estimate/truth pose pairs: rotation by the chordal mean, then
    translation; R @ estimate + t is comparable with the truth."""
    M = sum(G[:3, :3] @ T[:3, :3].T for T, G in pairs)
    U, _, Vt = np.linalg.svd(M)
    R = U @ np.diag([1, 1, np.linalg.det(U @ Vt)]) @ Vt
    t = np.mean([G[:3, 3] - R @ T[:3, 3] for T, G in pairs], axis=0)
    return R, t


def fitted_ate_mm(pairs):
    """ATE (mm) of estimate/truth pairs after the best rigid fit (chordal-mean rotation)."""
    R, t = rigid_fit(pairs)
    return float(np.sqrt(np.mean([np.sum(np.square(R @ T[:3, 3] + t - G[:3, 3])) for T, G in pairs]))) * 1000


def view_error(R, t, T, G):
    """Centre (mm) and rotation (degrees) error of estimate T against truth G after the fit (R, t)."""
    return (float(np.linalg.norm(R @ T[:3, 3] + t - G[:3, 3])) * 1000,
            rotation_deg(G[:3, :3].T @ (R @ T[:3, :3])))


def is_accurate(row):
    """The issue's bar for a room: ATE <= 3 mm over the verified views, each of them good."""
    return bool(row['ate_mm'] <= 3.0 and row['good'] == row['views'] - row['flagged'])


def evaluate(scan, out):
    return evaluate_report(os.path.join(out, 'stage_report.json'),
                           os.path.join(scan, 'groundtruth.txt'))


def evaluate_report(report_path, truth_path):
    truth = load_tum(truth_path)
    report = json.load(open(report_path))
    views = []
    for f in report['frames']:
        T = None
        if f['status'] == 'registered' and 'T_world_camera' in f:
            T = np.eye(4)
            T[:3, :] = np.array(f['T_world_camera'])
        views.append((f, T, truth[round(f['timestamp'], 4)]))
    placed = [(f, T, G) for f, T, G in views if T is not None]
    # What the run vouches for: the verified views. They are fitted to the truth and judged;
    # a wrong view among them that the others do not outvote shows as silent.
    vouched = [(f, T, G) for f, T, G in placed if f.get('verified')]
    result = {'views': len(views), 'registered': len(placed), 'good': 0, 'flagged': 0,
              'silent': 0, 'ate_mm': float('nan'), 'worst_deg': 0.0, 'worst_mm': 0.0,
              'flag_reasons': {}, 'flagged_but_good': 0}
    result['flagged'] = sum(1 for f, T, _ in views if T is None or not f.get('verified'))
    # The alignment's own accuracy, whatever the self-check says: every registered view.
    result['ate_all_mm'] = fitted_ate_mm([(T, G) for _, T, G in placed]) if len(placed) >= 2 else float('nan')
    if len(vouched) < 2:
        return result
    # Best rigid fit estimate -> truth: rotation by the chordal mean, then translation, over
    # the verified views.
    R, t = rigid_fit([(T, G) for _, T, G in vouched])
    errors, along, tilt = [], [], []
    for f, T, G in vouched:
        e = R @ T[:3, 3] + t - G[:3, 3]
        dt, dr = view_error(R, t, T, G)
        errors.append(dt)
        along.append(float(e @ G[:3, 2]) * 1000)
        tilt.append(rotation_vector_deg(G[:3, :3].T @ (R @ T[:3, :3])))
        result['worst_mm'] = max(result['worst_mm'], dt)
        result['worst_deg'] = max(result['worst_deg'], dr)
        if dt <= 10 and dr <= 0.5:
            result['good'] += 1
        elif dt > 50 or dr > 2:
            result['silent'] += 1
    result['ate_mm'] = float(np.sqrt(np.mean(np.square(errors))))
    # The systematic part of the error, what the best rigid fit cannot take out: the mean
    # offset along each view's own viewing direction (a view behind its place is negative) and
    # the mean rotation error in the camera frame (x: pitch, y: yaw, z: roll). A turn whose
    # views all sit behind their places and tilt alike is biased, not noisy (docs/benchmarks.md).
    result['along_mm'] = float(np.mean(along))
    result['camera_rotation_deg'] = [float(x) for x in np.mean(tilt, axis=0)]
    # The flagged views, judged the same way: a flag on a view that is in fact within the bar
    # costs the room its verified share; the reasons say which check raised it.
    for f, T, G in placed:
        if f.get('verified'):
            continue
        dt, dr = view_error(R, t, T, G)
        good = dt <= 10 and dr <= 0.5
        result['flagged_but_good'] += good
        for reason in reason_kinds(f.get('check', {}).get('reason', '') or f.get('reason', '')):
            tally = result['flag_reasons'].setdefault(reason, [0, 0])
            tally[0] += 1
            tally[1] += good
    return result


REASON_KINDS = [('geometry does not fix', 'constraint'), ('other views place it', 'correction'),
                ('overlap with the other', 'overlap'), ('sees through', 'free-space'),
                ("tripod's centre", 'tripod-offset'), ('pan axis', 'off-axis'),
                ("tripod's head", 'tripod-residual'), ('block of', 'block'),
                ('does not register', 'no-icp'), ('no other view', 'alone'),
                ('piece of its own', 'alone'), ('where its camera stands', 'slide')]


def reason_kinds(reason):
    kinds = {kind for text, kind in REASON_KINDS if text in reason}
    return sorted(kinds) or (['other'] if reason else ['none'])


def seeds_of(text):
    seeds = []
    for part in text.split(','):
        a, _, b = part.partition('-')
        seeds += list(range(int(a), int(b or a) + 1))
    return seeds


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument('--locard', default='build/release/locard')
    p.add_argument('--seeds', default='1-50')
    p.add_argument('--sensor', choices=['kinect_v1', 'kinect_v2'])
    p.add_argument('--surfaces', choices=['plain', 'textured'])
    p.add_argument('--work')
    p.add_argument('--json')
    p.add_argument('--keep', action='store_true')
    p.add_argument('--reports', help="copy each room's stage_report.json here as SEED.json (for study after the scans are removed)")
    a = p.parse_args()
    work = a.work or tempfile.mkdtemp(prefix='locard-rooms-')
    os.makedirs(work, exist_ok=True)
    rows = []
    for seed in seeds_of(a.seeds):
        scan, out = os.path.join(work, f'{seed}-scan'), os.path.join(work, f'{seed}-aligned')
        shutil.rmtree(scan, ignore_errors=True)
        shutil.rmtree(out, ignore_errors=True)
        sim = [a.locard, '--quiet', 'scan-sim', '--random', str(seed), '-o', scan]
        if a.sensor:
            sim += ['--sensor', a.sensor]
        if a.surfaces:
            sim += ['--surfaces', a.surfaces]
        subprocess.run(sim, check=True, stdout=subprocess.DEVNULL)
        start = time.monotonic()
        r = subprocess.run([a.locard, '--quiet', 'align', scan, '-o', out],
                           capture_output=True, text=True)
        seconds = time.monotonic() - start
        if r.returncode not in (0, 4):
            sys.exit(f'seed {seed}: align exited {r.returncode}\n{r.stderr}')
        row = evaluate(scan, out)
        capture = json.load(open(os.path.join(scan, 'capture.json')))
        scene = json.load(open(os.path.join(scan, 'scene.json')))
        row.update(seed=seed, exit=r.returncode, seconds=round(seconds, 1),
                   sensor=capture.get('sensor'), rings=capture.get('ring_sizes'),
                   walls=scene['room'].get('texture', 'plain'))
        row['accurate'] = is_accurate(row)
        row['success'] = r.returncode == 0 and row['accurate']
        rows.append(row)
        print(f"seed {seed:3d} {row['sensor']:9s} rings {str(row['rings']):14s} exit {r.returncode} "
              f"{'OK  ' if row['success'] else 'ACC ' if row['accurate'] else 'FAIL'} ATE {row['ate_mm']:8.2f} mm  "
              f"verified-worst {row['worst_mm']:7.1f} mm {row['worst_deg']:6.2f} deg  "
              f"flagged {row['flagged']:3d}/{row['views']:3d} ({row['flagged_but_good']} good)  "
              f"silent {row['silent']:3d}  {seconds:5.1f} s", flush=True)
        if 'along_mm' in row:
            print(f"          all registered views: ATE {row['ate_all_mm']:.2f} mm; bias: along the view {row['along_mm']:+.2f} mm, camera-frame rotation "
                  f"(pitch, yaw, roll) {', '.join(f'{x:+.3f}' for x in row['camera_rotation_deg'])} deg",
                  flush=True)
        print('          flags: ' + ', '.join(f'{k} {v[0]} ({v[1]} good)'
                                            for k, v in sorted(row['flag_reasons'].items())),
              flush=True)
        if a.reports:
            os.makedirs(a.reports, exist_ok=True)
            shutil.copy(os.path.join(out, 'stage_report.json'), os.path.join(a.reports, f'{seed}.json'))
            shutil.copy(os.path.join(scan, 'groundtruth.txt'), os.path.join(a.reports, f'{seed}.groundtruth.txt'))
        if a.json:  # as it goes: a long sweep stopped part-way keeps what it measured
            json.dump(rows, open(a.json, 'w'), indent=1)
        if not a.keep:
            shutil.rmtree(scan, ignore_errors=True)
            shutil.rmtree(out, ignore_errors=True)
    ok = sum(r['success'] for r in rows)
    silent_rooms = sum(1 for r in rows if r['silent'])
    silent_views = sum(r['silent'] for r in rows)
    accurate = sum(r['accurate'] for r in rows)
    print(f"SUMMARY rooms {len(rows)} succeeded {ok} (accurate, the rest flagged: {accurate}) | rooms with a silent wrong view "
          f"{silent_rooms} ({silent_views} views) | exit 4 {sum(r['exit'] == 4 for r in rows)} | "
          f"median time {np.median([r['seconds'] for r in rows]):.1f} s")
    if a.json:
        json.dump(rows, open(a.json, 'w'), indent=1)
    if not a.keep and not a.work:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == '__main__':
    main()
