#!/usr/bin/env python3
"""Squared error of the `ftpd` channel and of its Sobel gradient (the gradient view) of EXR fields
against a reference field, over cells valid in both; z variance and p95 of the reported and actual
relative errors. Used by scripts/gradient-domain.sh.

    scripts/field-error.py REFERENCE.exr FIELD.exr...
"""
import sys, OpenEXR, numpy as np
def load(p):
    f = OpenEXR.File(p)
    ch = f.parts[0].channels
    s = np.array(ch['ftpd'].pixels, dtype=np.float64)
    v = np.array(ch['valid'].pixels) > 0
    e = np.array(ch['ftpd.stderr'].pixels, dtype=np.float64) if 'ftpd.stderr' in ch else None
    return s, v, e
def sobel(a):
    p = np.pad(a, 1, mode='edge')
    gx = (p[:-2,2:] + 2*p[1:-1,2:] + p[2:,2:]) - (p[:-2,:-2] + 2*p[1:-1,:-2] + p[2:,:-2])
    gy = (p[2:,:-2] + 2*p[2:,1:-1] + p[2:,2:]) - (p[:-2,:-2] + 2*p[:-2,1:-1] + p[:-2,2:])
    return gx, gy
ref, rv, _ = load(sys.argv[1])
gr = sobel(ref)
for p in sys.argv[2:]:
    s, v, e = load(p)
    m = rv & v
    mse = np.mean((s[m]-ref[m])**2)
    g = sobel(s)
    inner = np.zeros_like(m); inner[1:-1,1:-1] = True
    mm = m & inner
    gmse = np.mean((g[0][mm]-gr[0][mm])**2 + (g[1][mm]-gr[1][mm])**2)
    z = ''
    if e is not None:
        ok = m & (e > 0) & (ref > 1e-6 * ref.max())
        zz = (s[ok]-ref[ok])/e[ok]
        z = f' zvar={np.mean(zz**2):.3f} n={ok.sum()} relerr_p95={np.percentile(e[ok]/np.maximum(s[ok],1e-30),95):.4f} actual_p95={np.percentile(np.abs(s[ok]-ref[ok])/np.maximum(ref[ok],1e-30),95):.4f}'
    print(f'{p}: field_mse={mse:.4e} grad_mse={gmse:.4e} valid={m.sum()}{z}')
