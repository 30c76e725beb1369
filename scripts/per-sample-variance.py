#!/usr/bin/env python3
"""Per-sample variance and CPU time per sample of several ftpd3d builds, interleaved.

usage: per-sample-variance.py SCENE WEIGHT SPP ROUNDS LABEL=BIN [LABEL=BIN ...] [-- FLAGS]

Each round runs every binary once (rotated order, the same seed for all in a round) on a 48-cell
slice z = 0 with FLAGS appended. The per-sample variance of a run is the sum over cells of
n * stderr^2 from its own EXR (the standard error over independent scrambled groups, so
stratification counts), over the cells every run resolves; the CPU time is the process's user +
system time. Efficiency = 1 / (variance * time per sample), relative to the first binary. It
needs the Python module (`pip install .`) for reading the EXR files. Load-independent in
variance; the time ratio scatters with the machine's load, so interleave several rounds."""
import os, sys, subprocess, resource, numpy as np, ftpd3d
argv = sys.argv[1:]
extra = []
if '--' in argv:
    i = argv.index('--'); extra = argv[i+1:]; argv = argv[:i]
scene, weight, spp, rounds = argv[0], argv[1], int(argv[2]), int(argv[3])
bins = [a.split('=', 1) for a in argv[4:]]
res = {lab: [] for lab, _ in bins}
for r in range(rounds):
    order = bins[r % len(bins):] + bins[:r % len(bins)]
    for label, b in order:
        out = f'/tmp/var_{os.getpid()}_{label}.exr'
        cmd = [b, '--scene', scene, '--slice', 'z=0', '--res', '48', '--weight', weight,
               '--spp', str(spp), '--seed', str(100 + r), '-o', out, '--no-png', '--quiet'] + extra
        p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        _, status, ru = os.wait4(p.pid, 0)
        if status != 0:
            print(label, 'failed', p.stderr.read().decode()[-500:]); sys.exit(1)
        cpu = ru.ru_utime + ru.ru_stime
        f = ftpd3d.read(out)
        ch = f
        se = np.asarray(ch['ftpd.stderr'], dtype=float); n = np.asarray(ch['samples'], dtype=float)
        valid = np.asarray(ch['valid'], dtype=float) > 0
        res[label].append((cpu, n.sum(), se, n, valid))
        os.remove(out)
# common cells
mask = None
for l in res:
    for (_, _, se, n, v) in res[l]:
        m = v & (se > 0)
        mask = m if mask is None else mask & m
base = bins[0][0]
def stats(l):
    V = np.mean([np.sum((se**2 * n)[mask]) for (_, _, se, n, _) in res[l]])
    t = np.mean([cpu / tot for (cpu, tot, _, _, _) in res[l]])
    vs = [np.sum((se**2 * n)[mask]) for (_, _, se, n, _) in res[l]]
    return V, t, vs
Vb, tb, _ = stats(base)
print(f'{scene} {weight} {spp} spp x {rounds} rounds, {mask.sum()} cells; extra {extra}')
print('| label | per-sample var (rel) | CPU us/sample (rel) | efficiency | var per round |')
for l, _ in bins:
    V, t, vs = stats(l)
    print(f'| {l} | {V/Vb:.3f} | {t*1e6:.2f} ({t/tb:.3f}) | {(Vb*tb)/(V*t):.3f} | {" ".join(f"{v/Vb:.3f}" for v in vs)} |')
