#!/usr/bin/env python3
"""The projection's growth per step on the jittered tank with the particles (nearly) frozen
(docs/hard-cases.md, "The projection amplifies on disordered particles").

cases/hard/still_water.toml at its quick size with gravity scaled to 9.81e-6 (speeds stay
~1e-6: the particles do not move), no shifting, to t = 4 (2 000 steps of 2e-3), one variant of
the projection's operators per run; prints the growth per step of the largest speed over the
second half of the run (an exponential growth factor there is the step map's amplification;
a linear drift gives about ln 2 / 1000 = 0.069 %).

  cargo build --release -p dgsph && python3 docs/study/frozen_projection.py   (about a minute)
"""
import csv, json, math, os, re, subprocess

SCENE = open('cases/hard/still_water.toml').read()
VARIANTS = {
    'renormalised pair, consistent Laplacian, Robin rows':
        "[pressure]\ngradient = 'difference'\nrenormalise = true\nconsistent_laplacian = true\n"
        "[free_surface]\nextrapolate = true\n",
    'renormalised pair, consistent Laplacian, Dirichlet rows':
        "[pressure]\ngradient = 'difference'\nrenormalise = true\nconsistent_laplacian = true\n[free_surface]\n",
    'renormalised pair, Morris Laplacian':
        "[pressure]\ngradient = 'difference'\nrenormalise = true\n[free_surface]\n",
    'difference pair, not renormalised': "[pressure]\ngradient = 'difference'\n[free_surface]\n",
    'symmetric gradient (flow default)': "[free_surface]\n",
    'renormalised pair, packed start (relax_iterations = 60)':
        "[pressure]\ngradient = 'difference'\nrenormalise = true\n[free_surface]\n[start]\nrelax_iterations = 60\n",
}

def scene(extra):
    text = SCENE
    # Drop the scene's own [free_surface], [start] and [effects] tables and its checks.
    for table in ('free_surface', 'start', 'effects'):
        text = re.sub(r'^\[%s\]\n(?:(?!\[).*\n?)*' % table, '', text, flags=re.M)
    text = re.sub(r'^t_end = .*$', 't_end = 4.0', text, count=1, flags=re.M)
    text = text[:text.index('[[check]]')] + text[text.index('[quick]'):]
    head, quick = text.split('[quick]')
    return head + extra + "[effects]\ngravity = [0.0, -9.81e-6, 0.0]\n\n[quick]" + quick

out = 'target/frozen_projection'
os.makedirs(out, exist_ok=True)
print('| variant | growth of max speed per step (steps 1000-2000) |\n|---|---|')
for k, (name, extra) in enumerate(VARIANTS.items()):
    path = '%s/v%d.toml' % (out, k)
    open(path, 'w').write(scene(extra))
    r = subprocess.run(['target/release/dgsph', 'run', path, '--preset', 'quick', '--schemes', 'euler',
                        '--out', out, '--progress-every', '0'], capture_output=True, text=True)
    rows = [x for x in csv.DictReader(open('%s/v%d_euler.csv' % (out, k))) if x['max_speed']]
    steps = {int(x['step']): float(x['max_speed']) for x in rows}
    last = max(steps)
    if last < 2000:
        status = json.load(open('%s/v%d_euler.run.json' % (out, k)))['status']
        print('| %s | %s |' % (name, status.split(':')[1].strip() if ':' in status else status))
        continue
    a, b = steps[1000], steps[2000]
    print('| %s | %+.3f %% |' % (name, 100 * (math.exp(math.log(b / a) / 1000) - 1)))
