//! Non-maximum suppression with hysteresis, and thinning to lines one cell wide.

/// The neighbour step across a line whose normal is `d` (quantised to 8 directions).
fn normal_step(d: [f64; 2]) -> (isize, isize) {
    let a = d[1].atan2(d[0]).rem_euclid(std::f64::consts::PI);
    let oct = ((a / (std::f64::consts::PI / 4.0)).round() as usize) % 4;
    [(1, 0), (1, 1), (0, 1), (-1, 1)][oct]
}

/// Non-maximum suppression + hysteresis of `value` across the normals `normal`, candidates where
/// `ok(i, strong)`. Returns kept cells and the sub-cell offset along the normal step.
pub(super) fn thin(
    dims: [usize; 3],
    value: &[f64],
    normal: &[[f64; 2]],
    ok: &dyn Fn(usize, bool) -> bool,
) -> (Vec<bool>, Vec<[f64; 2]>) {
    let (w, hgt) = (dims[0] as isize, dims[1] as isize);
    let n = value.len();
    let at = |i: isize, j: isize| -> Option<usize> {
        (i >= 0 && j >= 0 && i < w && j < hgt).then(|| (i + w * j) as usize)
    };
    let mut weak = vec![false; n];
    let mut strong = vec![false; n];
    let mut offset = vec![[0.0; 2]; n];
    for j in 0..hgt {
        for i in 0..w {
            let c = (i + w * j) as usize;
            if !ok(c, false) {
                continue;
            }
            let (di, dj) = normal_step(normal[c]);
            let v0 = value[c];
            let vm = at(i - di, j - dj).map_or(0.0, |k| value[k]);
            let vp = at(i + di, j + dj).map_or(0.0, |k| value[k]);
            // Ties broken to one side, so a plateau two cells wide keeps one.
            if !(v0 > vm && v0 >= vp) {
                continue;
            }
            weak[c] = true;
            strong[c] = ok(c, true);
            let denom = vm - 2.0 * v0 + vp;
            let t = if denom < 0.0 {
                (0.5 * (vm - vp) / denom).clamp(-0.5, 0.5)
            } else {
                0.0
            };
            offset[c] = [t * di as f64, t * dj as f64];
        }
    }
    // Hysteresis: weak cells 8-connected to kept ones along their line, with a normal within 45°
    // of theirs (so that a line does not wander off where its contrast fades and the normals
    // turn).
    let unit = |c: usize| {
        let l = normal[c][0].hypot(normal[c][1]);
        if l > 0.0 {
            [normal[c][0] / l, normal[c][1] / l]
        } else {
            [0.0, 0.0]
        }
    };
    let mut keep = strong.clone();
    let mut stack: Vec<usize> = (0..n).filter(|&c| strong[c]).collect();
    while let Some(c) = stack.pop() {
        let (i, j) = ((c % dims[0]) as isize, (c / dims[0]) as isize);
        for dj in -1..=1 {
            for di in -1..=1 {
                if let Some(k) = at(i + di, j + dj)
                    && weak[k]
                    && !keep[k]
                    && {
                        let (a, b) = (unit(c), unit(k));
                        // Along the line, not across it: the step to the neighbour makes at least
                        // 45° with the normal (so a parallel response beside the line is not
                        // joined to it).
                        let along = (di as f64 * a[0] + dj as f64 * a[1]).abs()
                            <= std::f64::consts::FRAC_1_SQRT_2 * (di as f64).hypot(dj as f64);
                        along
                            && (a[0] * b[0] + a[1] * b[1]).abs() >= std::f64::consts::FRAC_1_SQRT_2
                    }
                {
                    keep[k] = true;
                    stack.push(k);
                }
            }
        }
    }
    one_cell_wide(dims, &mut keep, &strong, value);
    (keep, offset)
}

/// Makes the kept cells a line one cell wide (8-connected). Non-maximum suppression across a
/// quantised normal keeps two cells per row where a diagonal line runs between cell centres
/// (each is the maximum along its own diagonal), and the chain linked through both zigzags: its
/// points alternate between the located line and the centre of a cell half a cell off it, which
/// the turn test (over ⌈scale⌉ + 1 points) read as bends of 45° and more and cut the line into
/// pieces too short to keep. A kept cell at the corner of such a staircase (a kept neighbour to
/// its side and one above or below it) whose other kept neighbours stay 8-connected without it
/// is dropped, weak before strong and weaker first, in one pass (a line is thinned, not eroded
/// from its ends).
fn one_cell_wide(dims: [usize; 3], keep: &mut [bool], strong: &[bool], value: &[f64]) {
    let (w, hgt) = (dims[0] as isize, dims[1] as isize);
    let at = |i: isize, j: isize| -> Option<usize> {
        (i >= 0 && j >= 0 && i < w && j < hgt).then(|| (i + w * j) as usize)
    };
    let mut order: Vec<usize> = (0..keep.len()).filter(|&c| keep[c]).collect();
    // Weak cells before strong ones, weaker first: of two cells side by side, the one kept is
    // the stronger.
    order.sort_by(|&a, &b| {
        strong[a]
            .cmp(&strong[b])
            .then(value[a].total_cmp(&value[b]))
    });
    // The 8 neighbours in ring order, so that ring neighbours are adjacent cells.
    const RING: [(isize, isize); 8] = [
        (1, 0),
        (1, 1),
        (0, 1),
        (-1, 1),
        (-1, 0),
        (-1, -1),
        (0, -1),
        (1, -1),
    ];
    for c in order {
        let (i, j) = ((c % dims[0]) as isize, (c / dims[0]) as isize);
        let on: [bool; 8] = RING.map(|(di, dj)| at(i + di, j + dj).is_some_and(|k| keep[k]));
        let side = on[0] || on[4];
        let above = on[2] || on[6];
        if !(side && above) {
            continue;
        }
        // Count the 8-connected groups of kept neighbours without c: walking the ring, a kept
        // cell starts a group unless the cell before it is kept, or (for a 4-neighbour, at even
        // ring positions) the 4-neighbour two before it is: two 4-neighbours at a right angle
        // touch diagonally even when the diagonal cell between them is not kept. Two diagonal
        // cells two apart do not touch.
        let mut groups = 0;
        for k in 0..8 {
            let prev = (k + 7) % 8;
            let prev2 = (k + 6) % 8;
            let joined = on[prev] || (k % 2 == 0 && on[prev2]);
            if on[k] && !joined {
                groups += 1;
            }
        }
        // 0: every kept neighbour joins the one before it, the ring is closed, one group.
        if groups <= 1 {
            keep[c] = false;
        }
    }
}
