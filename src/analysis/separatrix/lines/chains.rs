//! Linking line cells into chains, and refining the chains: cut at sharp turns, trimmed to their
//! strong cells, short pieces dropped.

use super::MIN_LINE_CELLS;

/// Links 8-connected kept cells into chains (ends and junctions first, then loops).
pub(super) fn link(dims: [usize; 3], keep: &[bool]) -> Vec<Vec<usize>> {
    let (w, hgt) = (dims[0] as isize, dims[1] as isize);
    let nb = |c: usize| -> Vec<usize> {
        let (i, j) = ((c % dims[0]) as isize, (c / dims[0]) as isize);
        let mut out = Vec::new();
        // 4-neighbours first, so chains follow the line rather than cut corners.
        for (di, dj) in [
            (1, 0),
            (0, 1),
            (-1, 0),
            (0, -1),
            (1, 1),
            (-1, 1),
            (-1, -1),
            (1, -1),
        ] {
            let (a, b) = (i + di, j + dj);
            if a >= 0 && b >= 0 && a < w && b < hgt && keep[(a + w * b) as usize] {
                out.push((a + w * b) as usize);
            }
        }
        out
    };
    let mut used = vec![false; keep.len()];
    let mut chains = Vec::new();
    let walk = |start: usize, used: &mut [bool]| {
        let mut chain = vec![start];
        used[start] = true;
        let mut cur = start;
        while let Some(next) = nb(cur).into_iter().find(|&k| !used[k]) {
            used[next] = true;
            chain.push(next);
            cur = next;
        }
        chain
    };
    let cells: Vec<usize> = (0..keep.len()).filter(|&c| keep[c]).collect();
    for pass in 0..2 {
        for &c in &cells {
            if used[c] || (pass == 0 && nb(c).len() == 2) {
                continue;
            }
            let mut chain = walk(c, &mut used);
            // A start in the middle of a line: extend backwards from the start too.
            let back = walk_back(&nb, &mut used, c);
            if !back.is_empty() {
                let mut b = back;
                b.reverse();
                b.append(&mut chain);
                chain = b;
            }
            chains.push(chain);
        }
    }
    chains
}

fn walk_back(nb: &dyn Fn(usize) -> Vec<usize>, used: &mut [bool], start: usize) -> Vec<usize> {
    let mut out = Vec::new();
    let mut cur = start;
    while let Some(next) = nb(cur).into_iter().find(|&k| !used[k]) {
        used[next] = true;
        out.push(next);
        cur = next;
    }
    out
}

/// The points of a chain of cells (cell centres moved by their sub-cell offsets).
fn chain_points(dims: [usize; 3], chain: &[usize], off: &[[f64; 2]]) -> Vec<[f64; 2]> {
    chain
        .iter()
        .map(|&c| {
            let (i, j) = (c % dims[0], c / dims[0]);
            [i as f64 + 0.5 + off[c][0], j as f64 + 0.5 + off[c][1]]
        })
        .collect()
}

/// The shortest piece of a chain kept for bridging at `scale`: max([`MIN_LINE_CELLS`],
/// ⌈4·scale⌉) cells (the filtered noise is correlated over about ±2·scale).
fn min_piece_cells(scale: f64) -> usize {
    ((4.0 * scale).ceil() as usize).max(MIN_LINE_CELLS)
}

/// Cuts chains where they turn by more than 45° over ⌈scale⌉ + 1 cells on either side (two lines
/// met at a junction, or a line hooking off), trims each piece back to its first and last strong
/// cell (weak cells join strong ones, they do not extend a line where its contrast fades), then
/// drops the pieces shorter than [`min_piece_cells`] (whole lines are judged by [`long_enough`]
/// after bridging).
pub(super) fn refine_chains(
    dims: [usize; 3],
    chains: Vec<Vec<usize>>,
    off: &[[f64; 2]],
    scale: f64,
    strong: &dyn Fn(usize) -> bool,
) -> Vec<Vec<usize>> {
    let k = (scale.ceil() as usize + 1).max(2);
    let min_len = min_piece_cells(scale);
    let mut out = Vec::new();
    for chain in chains {
        let p = chain_points(dims, &chain, off);
        let n = p.len();
        let cos_turn = |i: usize| {
            let a = [p[i][0] - p[i - k][0], p[i][1] - p[i - k][1]];
            let b = [p[i + k][0] - p[i][0], p[i + k][1] - p[i][1]];
            let l = a[0].hypot(a[1]) * b[0].hypot(b[1]);
            if l > 0.0 {
                (a[0] * b[0] + a[1] * b[1]) / l
            } else {
                1.0
            }
        };
        let cos: Vec<f64> = (0..n)
            .map(|i| {
                if i >= k && i + k < n {
                    cos_turn(i)
                } else {
                    1.0
                }
            })
            .collect();
        let mut start = 0;
        for i in 0..n {
            let local_min =
                (i == 0 || cos[i] <= cos[i - 1]) && (i + 1 == n || cos[i] <= cos[i + 1]);
            if cos[i] < std::f64::consts::FRAC_1_SQRT_2 && local_min {
                out.push(chain[start..i].to_vec());
                start = i + 1;
            }
        }
        out.push(chain[start..].to_vec());
    }
    out.into_iter()
        .filter_map(|c| {
            let first = c.iter().position(|&x| strong(x))?;
            let last = c.iter().rposition(|&x| strong(x))?;
            let c = c[first..=last].to_vec();
            (c.len() >= min_len).then_some(c)
        })
        .collect()
}
