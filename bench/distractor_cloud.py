#!/usr/bin/env python3
"""A larger line cloud for p6L's matching: the base cloud plus other scenes' clouds, each moved
300 m further sideways with its ids and server-keyframe timestamps offset, as distractors for
global descriptor matching (docs/paper-tables.md "Table 1's 4x: what every client reaches on the
same maps"). Run by hand, not by ctest.

  bench/distractor_cloud.py OUT.json BASE.json OTHER.json...

The inputs are JSON maps of one camera (`lcv map transform X.lcmap X.json --sim3-align-to GT`
writes one); OUT.json is read by `lcv localize --map` and `lcv slam --map-in`. Do not align OUT
to a ground truth again: the distractors' server keyframes would join the alignment.
"""
import json, sys
def qrot(q, v):
    w, x, y, z = q
    # rotation matrix from a unit quaternion (w, x, y, z)
    R = [[1-2*(y*y+z*z), 2*(x*y-w*z), 2*(x*z+w*y)],
         [2*(x*y+w*z), 1-2*(x*x+z*z), 2*(y*z-w*x)],
         [2*(x*z-w*y), 2*(y*z+w*x), 1-2*(x*x+y*y)]]
    return [sum(R[i][j]*v[j] for j in range(3)) for i in range(3)]
out = json.load(open(sys.argv[2]))
for k, path in enumerate(sys.argv[3:], start=1):
    m = json.load(open(path))
    assert m['cameras'] == out['cameras'], path
    off = [0.0, 300.0 * k, 0.0]   # 300 m apart sideways: no geometric overlap
    ids = 1000000 * k
    for l in m['lines']:
        l['id'] += ids
        l['anchor'] = [a + o for a, o in zip(l['anchor'], off)]
        l['server_keyframe_ids'] = [i + ids for i in l['server_keyframe_ids']]
        out['lines'].append(l)
    for s in m['server_keyframes']:
        s['id'] += ids
        s['timestamp'] = s.get('timestamp', 0.0) + 1000.0 * k
        s['line_ids'] = [i + ids for i in s['line_ids']]
        c = s['cam_from_world']
        Ro = qrot(c['rotation_wxyz'], off)
        c['translation'] = [t - r for t, r in zip(c['translation'], Ro)]
        out['server_keyframes'].append(s)
out['description'] = out.get('description', '') + ' | distractor clouds: ' + ' '.join(sys.argv[3:])
json.dump(out, open(sys.argv[1], 'w'))
print(len(out['lines']), 'lines,', len(out['server_keyframes']), 'server keyframes')
