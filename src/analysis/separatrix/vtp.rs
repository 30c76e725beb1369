//! Lines and surfaces as VTK XML PolyData (`.vtp`), in scene coordinates.

use super::LineKind;
use anyhow::Context;
use glam::DVec3;
use std::fmt::Write as _;
use std::path::Path;

/// A polyline in scene coordinates: kind, points, and per point strength and z.
pub type SceneLine = (LineKind, Vec<DVec3>, Vec<f64>, Vec<f64>);

/// Writes polylines (points already in scene coordinates) and/or triangles as VTK XML PolyData,
/// ASCII, with the point arrays `strength` and `z` and the cell array `kind` (0 jump, 1 ridge, 2
/// surface). Written to a temporary name, then renamed.
pub fn write_vtp(
    path: &Path,
    lines: &[SceneLine],
    mesh: Option<(&[DVec3], &[[usize; 3]])>,
) -> anyhow::Result<()> {
    let mut pts: Vec<DVec3> = Vec::new();
    let mut strength = Vec::new();
    let mut zs = Vec::new();
    let mut conn = Vec::new();
    let mut offs = Vec::new();
    let mut kinds = Vec::new();
    for (kind, p, s, z) in lines {
        let base = pts.len();
        pts.extend(p);
        strength.extend(s);
        zs.extend(z);
        conn.extend(base..base + p.len());
        offs.push(conn.len());
        kinds.push(match kind {
            LineKind::Jump => 0,
            LineKind::Ridge => 1,
        });
    }
    let n_lines = offs.len();
    let (mut pconn, mut poffs) = (Vec::new(), Vec::new());
    if let Some((mp, tris)) = mesh {
        let base = pts.len();
        pts.extend(mp);
        strength.extend(std::iter::repeat_n(0.0, mp.len()));
        zs.extend(std::iter::repeat_n(0.0, mp.len()));
        for t in tris {
            pconn.extend(t.iter().map(|v| v + base));
            poffs.push(pconn.len());
        }
    }
    let n_polys = poffs.len();
    let fin = |x: f64| if x.is_finite() { x } else { 0.0 };
    let mut s = String::new();
    let _ = writeln!(s, "<?xml version=\"1.0\"?>");
    let _ = writeln!(
        s,
        "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\">"
    );
    let _ = writeln!(s, "<PolyData>");
    let _ = writeln!(
        s,
        "<Piece NumberOfPoints=\"{}\" NumberOfVerts=\"0\" NumberOfLines=\"{n_lines}\" \
         NumberOfStrips=\"0\" NumberOfPolys=\"{n_polys}\">",
        pts.len()
    );
    let join = |v: &mut dyn Iterator<Item = String>| v.collect::<Vec<_>>().join(" ");
    // Empty sections are left out (VTK needs none of them; vtkio cannot read an empty array).
    if !pts.is_empty() {
        let _ = writeln!(s, "<PointData Scalars=\"strength\">");
        let _ = writeln!(
            s,
            "<DataArray type=\"Float64\" Name=\"strength\" format=\"ascii\">{}</DataArray>",
            join(&mut strength.iter().map(|v| format!("{:e}", fin(*v))))
        );
        let _ = writeln!(
            s,
            "<DataArray type=\"Float64\" Name=\"z\" format=\"ascii\">{}</DataArray>",
            join(&mut zs.iter().map(|v| format!("{:e}", fin(*v))))
        );
        let _ = writeln!(s, "</PointData>");
    }
    let mut all_kinds: Vec<i32> = kinds.clone();
    all_kinds.extend(std::iter::repeat_n(2, n_polys));
    if !all_kinds.is_empty() {
        let _ = writeln!(s, "<CellData Scalars=\"kind\">");
        let _ = writeln!(
            s,
            "<DataArray type=\"Int32\" Name=\"kind\" format=\"ascii\">{}</DataArray>",
            join(&mut all_kinds.iter().map(|v| v.to_string()))
        );
        let _ = writeln!(s, "</CellData>");
    }
    let _ = writeln!(s, "<Points>");
    let _ = writeln!(
        s,
        "<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">{}</DataArray>",
        join(
            &mut pts
                .iter()
                .map(|p| format!("{:e} {:e} {:e}", fin(p.x), fin(p.y), fin(p.z)))
        )
    );
    let _ = writeln!(s, "</Points>");
    for (tag, c, o) in [("Lines", &conn, &offs), ("Polys", &pconn, &poffs)] {
        if o.is_empty() {
            continue;
        }
        let _ = writeln!(s, "<{tag}>");
        let _ = writeln!(
            s,
            "<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">{}</DataArray>",
            join(&mut c.iter().map(|v| v.to_string()))
        );
        let _ = writeln!(
            s,
            "<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">{}</DataArray>",
            join(&mut o.iter().map(|v| v.to_string()))
        );
        let _ = writeln!(s, "</{tag}>");
    }
    let _ = writeln!(s, "</Piece>");
    let _ = writeln!(s, "</PolyData>");
    let _ = writeln!(s, "</VTKFile>");
    crate::output::write_atomically(path, |tmp| {
        std::fs::write(tmp, s.as_bytes()).with_context(|| format!("writing {}", tmp.display()))
    })
}
