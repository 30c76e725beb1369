//! Joining lines across short gaps along their own direction, and the length a line needs to be
//! kept.

use super::super::Polyline;
use super::LINE_MIN_SCALES;

/// Whether a bridged line is long enough to be kept at `scale` (see the module docs): at least
/// [`LINE_MIN_SCALES`] scales measured along it, not counting the segments laid across gaps
/// (whose points carry z 0).
pub(super) fn long_enough(line: &Polyline, scale: f64) -> bool {
    let arc: f64 = line
        .points
        .windows(2)
        .zip(line.z.windows(2))
        .filter(|(_, z)| z[0] > 0.0 && z[1] > 0.0)
        .map(|(w, _)| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
        .sum();
    arc >= LINE_MIN_SCALES * scale
}

/// Unit tangent at one end of a polyline, pointing out of it, from the point `k` back.
fn end_tangent(p: &[[f64; 2]], head: bool, k: usize) -> Option<[f64; 2]> {
    let n = p.len();
    let k = k.min(n.checked_sub(1)?);
    let (a, b) = if head {
        (p[k], p[0])
    } else {
        (p[n - 1 - k], p[n - 1])
    };
    let d = [b[0] - a[0], b[1] - a[1]];
    let l = d[0].hypot(d[1]);
    (l > 0.0).then(|| [d[0] / l, d[1] / l])
}

/// Joins lines of one kind across gaps along their own direction: an end of one and an end of
/// another at most 2·⌈3·scale⌉ cells apart (one filter support, over which one noise excursion can
/// hide a line), each lying within 1.5 cells of the other's tangent line and the two tangents
/// within 30° of each other. Nearest pairs first. The points laid across a gap (one a cell) carry
/// strength and z 0: they are bridged, not measured.
pub(super) fn bridge(
    mut lines: Vec<(Polyline, Vec<usize>)>,
    scale: f64,
) -> Vec<(Polyline, Vec<usize>)> {
    let max_gap = 2.0 * (3.0 * scale).ceil();
    let k = (scale.ceil() as usize + 1).max(2);
    let cos30 = 0.75f64.sqrt();
    loop {
        let mut best: Option<(f64, usize, bool, usize, bool)> = None;
        for a in 0..lines.len() {
            for b in 0..lines.len() {
                if a == b || lines[a].0.kind != lines[b].0.kind {
                    continue;
                }
                for a_head in [false, true] {
                    for b_head in [false, true] {
                        let (pa, pb) = (&lines[a].0.points, &lines[b].0.points);
                        let ea = if a_head { pa[0] } else { pa[pa.len() - 1] };
                        let eb = if b_head { pb[0] } else { pb[pb.len() - 1] };
                        let (Some(ta), Some(tb)) =
                            (end_tangent(pa, a_head, k), end_tangent(pb, b_head, k))
                        else {
                            continue;
                        };
                        let g = [eb[0] - ea[0], eb[1] - ea[1]];
                        let d = g[0].hypot(g[1]);
                        if !(d > 0.0 && d <= max_gap) {
                            continue;
                        }
                        // The tangents point out of their lines: towards each other, opposed.
                        let along_a = g[0] * ta[0] + g[1] * ta[1];
                        let along_b = -(g[0] * tb[0] + g[1] * tb[1]);
                        let lat_a = (g[0] * ta[1] - g[1] * ta[0]).abs();
                        let lat_b = (g[0] * tb[1] - g[1] * tb[0]).abs();
                        let opposed = -(ta[0] * tb[0] + ta[1] * tb[1]);
                        if along_a > 0.0
                            && along_b > 0.0
                            && lat_a <= 1.5
                            && lat_b <= 1.5
                            && opposed >= cos30
                            && best.is_none_or(|b| d < b.0)
                        {
                            best = Some((d, a, a_head, b, b_head));
                        }
                    }
                }
            }
        }
        let Some((d, a, a_head, b, b_head)) = best else {
            return lines;
        };
        let (hi, lo) = (a.max(b), a.min(b));
        let (lb, cb) = lines.remove(hi);
        let (la, ca) = lines.remove(lo);
        let (mut la, mut lb) = if a > b { (lb, la) } else { (la, lb) };
        let mut cells = ca;
        cells.extend(cb);
        // Orient: la ends at the gap, lb starts at it.
        let rev = |l: &mut Polyline| {
            l.points.reverse();
            l.strength.reverse();
            l.z.reverse();
        };
        if a_head {
            rev(&mut la);
        }
        if !b_head {
            rev(&mut lb);
        }
        let (ea, eb) = (la.points[la.points.len() - 1], lb.points[0]);
        let steps = d.ceil() as usize;
        for s in 1..steps {
            let t = s as f64 / steps as f64;
            la.points
                .push([ea[0] + t * (eb[0] - ea[0]), ea[1] + t * (eb[1] - ea[1])]);
            la.strength.push(0.0);
            la.z.push(0.0);
        }
        la.points.extend(lb.points);
        la.strength.extend(lb.strength);
        la.z.extend(lb.z);
        lines.push((la, cells));
    }
}
