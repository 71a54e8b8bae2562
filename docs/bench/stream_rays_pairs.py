"""Interleaved wall-clock rounds of the stream renderer's ray groupings (issue 18, ninth session).

Usage: python3 docs/bench/stream_rays_pairs.py BINARY SCENE SPP ROUNDS [VARIANTS]
VARIANTS: comma-separated subset of single,packet8,stream (default all three; the first is the
base of the ratios). Each round renders every variant once (order reversed every other round),
2 threads; prints the render seconds and the geometric mean of the per-round ratios with a 95 %
t-interval, and the load average seen.
"""
import json, os, subprocess, sys, math, statistics, tempfile
binp, scene, spp, rounds = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
variants = {
  'single': {'GROOVE_STREAM_PACKETS': 'camera'},
  'packet8': {'GROOVE_STREAM_PACKETS': 'camera,bounce,shadow'},
  'stream': {'GROOVE_STREAM_PACKETS': 'camera,bounce,shadow,stream'},
}
if len(sys.argv) > 5: variants = {k: variants[k] for k in sys.argv[5].split(',')}
t = {k: [] for k in variants}
tmp = tempfile.mkdtemp()
exr, js = os.path.join(tmp, 'pair.exr'), os.path.join(tmp, 'pair.json')
loads = []
for r in range(rounds):
    order = list(variants) if r % 2 == 0 else list(reversed(list(variants)))
    for k in order:
        env = dict(os.environ); env.update(variants[k])
        subprocess.run([binp, 'render', scene, '--spp', spp, '-t', '2', '-q', '--renderer', 'stream', '-o', exr, '--json', js], env=env, check=True, stdout=subprocess.DEVNULL)
        t[k].append(json.load(open(js))['renders'][0]['render_seconds'])
    loads.append(os.getloadavg()[0])
print(scene, 'spp', spp, 'rounds', rounds, 'load %.1f-%.1f' % (min(loads), max(loads)))
for k in t: print(' ', k, ' '.join('%.3f' % x for x in t[k]))
base = list(variants)[0]
for k in list(variants)[1:]:
    lr = [math.log(a / b) for a, b in zip(t[k], t[base])]
    m = statistics.mean(lr); s = statistics.stdev(lr) / math.sqrt(len(lr))
    tq = {4: 2.776, 5: 2.571, 6: 2.447, 7: 2.365, 8: 2.306, 9: 2.262, 10: 2.228, 11: 2.201, 12: 2.179}.get(len(lr)-1, 2.0)
    print('  %s / %s: %.3f (95%% %.3f-%.3f)' % (k, base, math.exp(m), math.exp(m - tq*s), math.exp(m + tq*s)))
