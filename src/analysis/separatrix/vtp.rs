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
    let s = PolyData::new(lines, mesh).xml();
    crate::output::write_atomically(path, |tmp| {
        std::fs::write(tmp, s.as_bytes()).with_context(|| format!("writing {}", tmp.display()))
    })
}

/// The points with their arrays, and the lines and triangles as VTK connectivity and offsets.
#[derive(Default)]
struct PolyData {
    pts: Vec<DVec3>,
    strength: Vec<f64>,
    zs: Vec<f64>,
    conn: Vec<usize>,
    offs: Vec<usize>,
    /// Per line: 0 jump, 1 ridge.
    kinds: Vec<i32>,
    pconn: Vec<usize>,
    poffs: Vec<usize>,
}

impl PolyData {
    /// The lines first, then the mesh (whose points carry strength and z 0).
    fn new(lines: &[SceneLine], mesh: Option<(&[DVec3], &[[usize; 3]])>) -> PolyData {
        let mut d = PolyData::default();
        for (kind, p, s, z) in lines {
            let base = d.pts.len();
            d.pts.extend(p);
            d.strength.extend(s);
            d.zs.extend(z);
            d.conn.extend(base..base + p.len());
            d.offs.push(d.conn.len());
            d.kinds.push(match kind {
                LineKind::Jump => 0,
                LineKind::Ridge => 1,
            });
        }
        if let Some((mp, tris)) = mesh {
            let base = d.pts.len();
            d.pts.extend(mp);
            d.strength.extend(std::iter::repeat_n(0.0, mp.len()));
            d.zs.extend(std::iter::repeat_n(0.0, mp.len()));
            for t in tris {
                d.pconn.extend(t.iter().map(|v| v + base));
                d.poffs.push(d.pconn.len());
            }
        }
        d
    }

    /// The VTK XML document (ASCII arrays; non-finite values written as 0).
    fn xml(&self) -> String {
        let n_lines = self.offs.len();
        let n_polys = self.poffs.len();
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
            self.pts.len()
        );
        let join = |v: &mut dyn Iterator<Item = String>| v.collect::<Vec<_>>().join(" ");
        // Empty sections are left out (VTK needs none of them; vtkio cannot read an empty array).
        if !self.pts.is_empty() {
            let _ = writeln!(s, "<PointData Scalars=\"strength\">");
            let _ = writeln!(
                s,
                "<DataArray type=\"Float64\" Name=\"strength\" format=\"ascii\">{}</DataArray>",
                join(&mut self.strength.iter().map(|v| format!("{:e}", fin(*v))))
            );
            let _ = writeln!(
                s,
                "<DataArray type=\"Float64\" Name=\"z\" format=\"ascii\">{}</DataArray>",
                join(&mut self.zs.iter().map(|v| format!("{:e}", fin(*v))))
            );
            let _ = writeln!(s, "</PointData>");
        }
        let mut all_kinds: Vec<i32> = self.kinds.clone();
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
            join(&mut self.pts.iter().map(|p| format!(
                "{:e} {:e} {:e}",
                fin(p.x),
                fin(p.y),
                fin(p.z)
            )))
        );
        let _ = writeln!(s, "</Points>");
        for (tag, c, o) in [
            ("Lines", &self.conn, &self.offs),
            ("Polys", &self.pconn, &self.poffs),
        ] {
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
        s
    }
}
