#!/usr/bin/env python3
"""The stretched drops (cases/hard/long_drop_2d.toml, long_drop_3d.toml) under the paper's
operators (the scenes as written) and under the flow scenes' default numerics written into a
copy (docs/hard-cases.md, "The stretched drop under the flow scenes' numerics").

For each variant, dimension, preset and scheme: where the run ended, the semi-axis error while
8 particles span the filament (the scene's check, 0.05), the second-moment volume change, and
the largest fraction of the particles flagged free surface with its time (the stretched
lattice's interior read as surface).

  cargo build --release -p dgsph && python3 docs/study/long_drop_numerics.py   (about 5 minutes
  on one core; `--quick` for the quick presets alone, seconds)
"""
import csv, json, os, re, subprocess, sys

FLOW_PRESSURE = """[pressure]
gradient = "symmetric"
renormalise = false
level_consistent = true
normalise_gradient = true
density_relaxation = 0.05
density_relaxation_form = "position"

"""
LIND = '[effects]\nshifting = { coefficient = 2.0, velocity_correction = "limited" }\n'
DELTA_PLUS = ('[effects]\nshifting = { coefficient = 2.0, velocity = "max", '
              'velocity_correction = "limited" }\n')
VARIANTS = {
    "paper's operators, no shifting (the scene)": None,
    "flow numerics, Lind shifting (the flow default)": LIND,
    "flow numerics, delta-plus shifting": DELTA_PLUS,
    "flow numerics, no shifting": '',
}


def flow_copy(text, dim, shifting):
    """The scene with the flow scenes' defaults for a free-surface flow spelled out."""
    threshold = '1.5' if dim == 2 else '2.25'
    surface = ('[free_surface]\ndiv_r_threshold = %s\nextrapolate = true\nscan = true\n\n%s'
               % (threshold, shifting))
    return re.sub(r'^\[free_surface\]\ndiv_r_threshold = .*\n', FLOW_PRESSURE + surface, text,
                  flags=re.M)


def main():
    presets = ['quick'] if '--quick' in sys.argv else ['quick', 'full']
    out = 'target/long_drop_numerics'
    os.makedirs(out, exist_ok=True)
    print('| variant | dim | preset | scheme | reached t | semi-axis error (resolved) | volume change'
          ' | largest free-surface fraction (at t) |')
    print('|---|---|---|---|---|---|---|---|')
    for dim in (2, 3):
        text = open('cases/hard/long_drop_%dd.toml' % dim).read()
        for k, (name, shifting) in enumerate(VARIANTS.items()):
            if dim == 3 and k > 1:
                continue
            tag = 'd%d_v%d' % (dim, k)
            path = '%s/%s.toml' % (out, tag)
            open(path, 'w').write(text if shifting is None else flow_copy(text, dim, shifting))
            for preset in presets:
                run_out = '%s/%s' % (out, preset)
                subprocess.run(['target/release/dgsph', 'run', path, '--preset', preset, '--out',
                                run_out, '--progress-every', '0'], capture_output=True, text=True)
                for scheme in ('euler', 'predictor_corrector', 'dg'):
                    base = '%s/%s_%s' % (run_out, tag, scheme)
                    results = json.load(open(base + '.run.json'))
                    rows = [r for r in csv.DictReader(open(base + '.csv'))
                            if r['free_surface_particles']]
                    n = float(results['fluid'])
                    worst = max(rows, key=lambda r: int(r['free_surface_particles']))
                    res = results.get('results', {})
                    frac = int(worst['free_surface_particles']) / n if n else float('nan')
                    print('| %s | %dD | %s | %s | %.4f | %.3f | %.3f | %.2f (%.4f) |' % (
                        name, dim, preset, scheme, float(rows[-1]['t']),
                        res.get('semi_axis_error_resolved_max', float('nan')),
                        res.get('volume_change_max', float('nan')), frac, float(worst['t'])))


if __name__ == '__main__':
    main()
