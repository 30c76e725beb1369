//! Lines (2D): thinned maxima of the jump and ridge measures, linked into polylines.
//!
//! # Which detector draws the lines (paper, sections 4.3 and 5.5)
//!
//! Section 4.3 derives separatrices as discontinuities of the change of influence; section 5.5
//! observes that in FTPD fields most of them show as *zero-order* discontinuities (σ itself steps,
//! because the pairs span a finite cone), the rest as *first-order* ones (σ has a kink). The
//! Hessian of a blurred step is zero on the step and extreme at ± scale beside it, so the maximum
//! of |∇²_ω σ| lies beside a jump, not on it; on a kink it lies on the line. So lines are drawn by
//! two detectors, and the choice is made per place:
//!
//! - **jump**: maxima of the jump strength along the gradient (Canny's non-maximum
//!   suppression), where it is ≥ τ at z ≥ Z (hysteresis down to τ/2 and Z − 1, to neighbours
//!   that lie along the line rather than across it and whose normal turns by less than 45°);
//! - **ridge** (height ridges of |∇²_ω σ|, eq. 13 itself): maxima of the strength along its
//!   direction, same thresholds, except within 2·scale + 1.5 cells of a jump line (where the
//!   Hessian only shows the flanks of that jump).
//!
//! # From line cells to polylines: what noise can and cannot draw
//!
//! The filtered field's noise is correlated over about ±2·scale cells, so one noise excursion
//! makes a short maximum line, and a real line that fades into the noise ends in a hook along
//! whatever smooth structure is next to it. So the linked chains are refined, all in units of the
//! scale:
//!
//! - the thinned cells are made one cell wide first: where a diagonal line runs between cell
//!   centres, non-maximum suppression keeps two cells per row, and a chain through both zigzags
//!   by half a cell, which the turn test below would read as bends, cutting lines into pieces
//!   too short to keep (see `thin::one_cell_wide`); thinner lines also leave noise less to
//!   draw;
//! - a chain is cut where it turns by more than 45° within ⌈scale⌉ + 1 points on either side (a
//!   junction, or a hook);
//! - each piece is trimmed back to its first and last *strong* cell (τ and Z): weak cells join
//!   strong ones, they do not prolong a line where its own significance is gone;
//! - pieces shorter than max(3, ⌈4·scale⌉) cells are dropped ([`MIN_LINE_CELLS`] is the floor);
//! - ends of two lines of one kind are joined across a gap of at most 2·⌈3·scale⌉ cells (one
//!   filter support) when each end lies within 1.5 cells of the other's tangent and the tangents
//!   agree within 30°; the points laid across carry strength and z 0 (bridged, not measured);
//! - lines shorter than [`LINE_MIN_SCALES`] = 6 scales, measured along their points and not
//!   across the bridged gaps, are dropped: that is the length noise does not reach (lines drawn
//!   by noise alone are mostly 2–5 scales long; the test `pure_noise_draws_few_lines` holds them
//!   under 10 per 10⁶ cells on fields of pure noise). Along a line the filtered noise has
//!   the correlation exp(−d²/(4·scale²)) (the Gaussian factor of every filter, convolved with
//!   itself), 10⁻⁴ at 6 scales: a line that long is significant at two places whose noise is
//!   independent, which one noise excursion is not.
//!
//! Where the step across a line passes through zero (a shadow boundary whose step changes sign
//! along it) nothing is drawn: there is no discontinuity to find at that noise level, and the
//! bridge does not guess across more than one filter support.
//!
//! Lines are located to a fraction of a cell: a jump line where the second derivative across it
//! vanishes (one Newton step from the cell centre, −σ_nn/σ_nnn along the gradient), a ridge by a
//! parabola through the maximum and its two neighbours across the line.

mod bridge;
mod chains;
mod thin;

use super::{LineKind, Polyline, Separatrices};
use bridge::{bridge, long_enough};
use chains::{link, refine_chains};
use thin::thin;

/// Shortest chain of line cells kept as a polyline at any scale (see [`LINE_MIN_SCALES`]).
pub const MIN_LINE_CELLS: usize = 3;

/// Shortest line kept, in scales, measured along its points (see the module docs: the length
/// that lines drawn by noise alone do not reach).
pub const LINE_MIN_SCALES: f64 = 6.0;

pub(super) fn trace_lines(sep: &mut Separatrices, grads: &[[f64; 2]], jump_offset: &[[f64; 2]]) {
    let dims = sep.dims;
    let n = grads.len();
    let (tau, zt) = (sep.tau, sep.z_threshold);
    let z_low = (zt - 1.0).max(0.5 * zt);
    let (jump, jz, def) = (&sep.jump, &sep.jump_z, &sep.defined);
    let jump_ok = |c: usize, strong: bool| {
        let (t, z) = if strong {
            (tau, zt)
        } else {
            (0.5 * tau, z_low)
        };
        def[c] && jump[c] > 0.0 && jump[c] >= t && jz[c] >= z
    };
    let (jkeep, _) = thin(dims, jump, grads, &jump_ok);
    let joff = jump_offset;
    let jchains = refine_chains(dims, link(dims, &jkeep), joff, sep.scale, &|c| {
        jump_ok(c, true)
    });
    let mut jump_cells = vec![false; n];
    for c in jchains.iter().flatten() {
        jump_cells[*c] = true;
    }
    // Ridges: not within 2·scale + 1.5 cells of a jump line.
    let near = 2.0 * sep.scale + 1.5;
    let ri = near.ceil() as isize;
    let (w, hgt) = (dims[0] as isize, dims[1] as isize);
    let near_jump = |c: usize| {
        let (i, j) = ((c % dims[0]) as isize, (c / dims[0]) as isize);
        for dj in -ri..=ri {
            for di in -ri..=ri {
                let (a, b) = (i + di, j + dj);
                if a >= 0
                    && b >= 0
                    && a < w
                    && b < hgt
                    && ((di * di + dj * dj) as f64) <= near * near
                    && jump_cells[(a + w * b) as usize]
                {
                    return true;
                }
            }
        }
        false
    };
    let (st, z, dir) = (&sep.strength, &sep.z, &sep.dir);
    let ridge_ok = |c: usize, strong: bool| {
        let (t, zz) = if strong {
            (tau, zt)
        } else {
            (0.5 * tau, z_low)
        };
        def[c] && st[c] > 0.0 && st[c] >= t && z[c] >= zz && !near_jump(c)
    };
    let normals: Vec<[f64; 2]> = dir.iter().map(|d| [d[0], d[1]]).collect();
    let (rkeep, roff) = thin(dims, st, &normals, &ridge_ok);
    let rchains = refine_chains(dims, link(dims, &rkeep), &roff, sep.scale, &|c| {
        ridge_ok(c, true)
    });
    let mut lines = Vec::new();
    let mut line = vec![0u8; n];
    for (kind, chains, off, val, zv) in [
        (LineKind::Jump, &jchains, joff, jump, jz),
        (LineKind::Ridge, &rchains, &roff[..], st, z),
    ] {
        for chain in chains {
            let mut p = Polyline {
                kind,
                points: Vec::with_capacity(chain.len()),
                strength: Vec::with_capacity(chain.len()),
                z: Vec::with_capacity(chain.len()),
            };
            for &c in chain {
                let (i, j) = (c % dims[0], c / dims[0]);
                p.points
                    .push([i as f64 + 0.5 + off[c][0], j as f64 + 0.5 + off[c][1]]);
                p.strength.push(val[c]);
                p.z.push(zv[c]);
            }
            lines.push((p, chain.clone()));
        }
    }
    let scale = sep.scale;
    let kept: Vec<(Polyline, Vec<usize>)> = bridge(lines, scale)
        .into_iter()
        .filter(|(l, _)| long_enough(l, scale))
        .collect();
    for (l, cells) in &kept {
        for &c in cells {
            line[c] = if l.kind == LineKind::Jump { 1 } else { 2 };
        }
    }
    sep.line = line;
    sep.lines = kept.into_iter().map(|(l, _)| l).collect();
}
