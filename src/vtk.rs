//! VTK output: one XML PolyData file (`.vtp`) per frame and a ParaView collection (`.pvd`) that opens them as an
//! animation, with the fields a fracture study looks at. ParaView, VisIt and PyVista read them. The same surface
//! and fields can be written as an XML UnstructuredGrid (`.vtu`, [`VtkKind::UnstructuredGrid`]) for readers
//! without PolyData: meshio (5.3) reads `.vtu` but not `.vtp` (Python's `fissure.vtk.register_meshio()` gives it
//! a `.vtp` reader).
//!
//! Each frame holds the surface as it is then (the topology changes from frame to frame as a body tears; a
//! collection allows that, one file per step):
//! - points: positions \[m\] (`Float32` for an `f32` model, `Float64` for an `f64` one, written in full);
//! - point data: `velocity` \[m/s\] (3 components), `strain` (the largest strain `(l - L0)/L0` of the particle's
//!   edge springs), `body` (its body's index, -1 for none);
//! - cell data (per triangle): `body`, and `damage` in \[0, 1\]: 1 on a crack (a corner that fracture split
//!   off) and otherwise how near the triangle's most stretched edge spring is to its strain limit (unbreakable
//!   springs against a strain of [`DAMAGE_FULL_SCALE`]).
//!
//! Written by hand, as ASCII XML: the format is a few dozen lines of XML for this subset, and the candidate crate
//! (`vtkio`) has had no stable release since 0.6.3 (2021), its 0.7 only as release candidates, and would bring a
//! parser and an XML stack to every build of the facade. ASCII keeps files diffable and exact (values are
//! printed shortest-round-trip); a 642-vertex frame is about 60 kB.

use fissure_core::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Strain that counts as full damage on a spring that cannot break.
pub const DAMAGE_FULL_SCALE: f64 = 0.3;

/// Which VTK XML dataset to write.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VtkKind {
    /// PolyData, `.vtp`: a surface of polygons (ParaView, VisIt, PyVista).
    PolyData,
    /// UnstructuredGrid, `.vtu`: the same triangles as cells of type 5 (also meshio).
    UnstructuredGrid,
}

impl VtkKind {
    /// The file extension, without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            VtkKind::PolyData => "vtp",
            VtkKind::UnstructuredGrid => "vtu",
        }
    }

    /// The kind a path's extension names (`.vtp` or `.vtu`).
    pub fn from_path(path: &Path) -> Option<VtkKind> {
        match path.extension()?.to_str()? {
            "vtp" => Some(VtkKind::PolyData),
            "vtu" => Some(VtkKind::UnstructuredGrid),
            _ => None,
        }
    }
}

/// The `.vtp` text of the model's surface at `state`.
pub fn vtp_string<R: Real>(model: &Model<R>, state: &State<R>) -> String {
    vtk_string(model, state, VtkKind::PolyData)
}

/// The VTK XML text of the model's surface at `state` as a dataset of `kind`.
pub fn vtk_string<R: Real>(model: &Model<R>, state: &State<R>, kind: VtkKind) -> String {
    let q = &state.particle_q;
    let (n, ntri) = (model.particle_count(), model.tri_count());
    let (strain, ratio) = model.particle_strain(q, DAMAGE_FULL_SCALE);
    let float = if std::mem::size_of::<R>() == 4 { "Float32" } else { "Float64" };
    let mut s = String::with_capacity(100 * n + 40 * ntri + 1024);
    let dataset = match kind {
        VtkKind::PolyData => "PolyData",
        VtkKind::UnstructuredGrid => "UnstructuredGrid",
    };
    s.push_str("<?xml version=\"1.0\"?>\n");
    let _ = writeln!(
        s,
        "<VTKFile type=\"{dataset}\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n<{dataset}>"
    );
    let _ = match kind {
        VtkKind::PolyData => writeln!(
            s,
            "<Piece NumberOfPoints=\"{n}\" NumberOfVerts=\"0\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\"{ntri}\">"
        ),
        VtkKind::UnstructuredGrid => writeln!(s, "<Piece NumberOfPoints=\"{n}\" NumberOfCells=\"{ntri}\">"),
    };
    let vectors = |s: &mut String, name: &str, v: &[R::V]| {
        let _ = writeln!(s, "<DataArray type=\"{float}\" Name=\"{name}\" NumberOfComponents=\"3\" format=\"ascii\">");
        for p in v.iter().take(n) {
            let [x, y, z] = p.to_array();
            let _ = writeln!(s, "{x} {y} {z}");
        }
        s.push_str("</DataArray>\n");
    };
    let scalars = |s: &mut String, ty: &str, name: &str, values: &mut dyn Iterator<Item = String>| {
        let _ = writeln!(s, "<DataArray type=\"{ty}\" Name=\"{name}\" format=\"ascii\">");
        for v in values {
            s.push_str(&v);
            s.push('\n');
        }
        s.push_str("</DataArray>\n");
    };
    let body = |b: u32| if b == u32::MAX { -1 } else { b as i64 };

    s.push_str("<Points>\n");
    vectors(&mut s, "Points", q);
    s.push_str("</Points>\n<PointData Scalars=\"strain\" Vectors=\"velocity\">\n");
    vectors(&mut s, "velocity", &state.particle_qd);
    scalars(&mut s, "Float64", "strain", &mut strain.iter().map(|x| x.to_string()));
    scalars(&mut s, "Int32", "body", &mut model.particle_body.iter().map(|&b| body(b).to_string()));
    s.push_str("</PointData>\n<CellData Scalars=\"damage\">\n");
    scalars(&mut s, "Int32", "body", &mut model.tri_body.iter().map(|&b| body(b).to_string()));
    let damage = model.tri_indices.iter().map(|t| {
        let on_crack = t.iter().any(|&v| model.particle_origin[v as usize] != v);
        let d = if on_crack { 1.0 } else { t.iter().map(|&v| ratio[v as usize]).fold(0.0, f64::max).min(1.0) };
        d.to_string()
    });
    scalars(&mut s, "Float64", "damage", &mut damage.into_iter());
    let cells = match kind {
        VtkKind::PolyData => "Polys",
        VtkKind::UnstructuredGrid => "Cells",
    };
    let _ = writeln!(s, "</CellData>\n<{cells}>");
    scalars(&mut s, "Int64", "connectivity", &mut model.tri_indices.iter().map(|[a, b, c]| format!("{a} {b} {c}")));
    scalars(&mut s, "Int64", "offsets", &mut (1..=ntri).map(|k| (3 * k).to_string()));
    if kind == VtkKind::UnstructuredGrid {
        // VTK_TRIANGLE.
        scalars(&mut s, "UInt8", "types", &mut (0..ntri).map(|_| "5".to_string()));
    }
    let _ = writeln!(s, "</{cells}>\n</Piece>\n</{dataset}>\n</VTKFile>");
    s
}

/// Writes the model's surface at `state` to `path`: PolyData for a `.vtp` path, UnstructuredGrid for `.vtu`
/// (any other extension is an `InvalidInput` error).
pub fn write_vtk<R: Real>(path: impl AsRef<Path>, model: &Model<R>, state: &State<R>) -> std::io::Result<()> {
    let path = path.as_ref();
    let kind = VtkKind::from_path(path).ok_or_else(|| {
        std::io::Error::new(std::io::ErrorKind::InvalidInput, "want a .vtp (PolyData) or .vtu (UnstructuredGrid) path")
    })?;
    std::fs::write(path, vtk_string(model, state, kind))
}

/// A time series: `STEM_0000.vtp`, `STEM_0001.vtp`, ... (or `.vtu`) in a folder, and `STEM.pvd` listing them
/// with their times. The collection is rewritten after every frame, so a run cut short still opens.
#[derive(Clone, Debug)]
pub struct VtkSeries {
    dir: PathBuf,
    stem: String,
    kind: VtkKind,
    frames: Vec<(f64, String)>,
}

impl VtkSeries {
    /// A series of `kind` in `dir` (created if missing) named `stem`.
    pub fn new(dir: impl AsRef<Path>, stem: &str, kind: VtkKind) -> std::io::Result<Self> {
        std::fs::create_dir_all(dir.as_ref())?;
        Ok(VtkSeries { dir: dir.as_ref().to_path_buf(), stem: stem.into(), kind, frames: Vec::new() })
    }

    /// Writes the next frame (at `state.time`) and updates the collection; returns the frame's path.
    pub fn write<R: Real>(&mut self, model: &Model<R>, state: &State<R>) -> std::io::Result<PathBuf> {
        let name = format!("{}_{:04}.{}", self.stem, self.frames.len(), self.kind.extension());
        let path = self.dir.join(&name);
        std::fs::write(&path, vtk_string(model, state, self.kind))?;
        self.frames.push((state.time, name));
        std::fs::write(self.collection(), self.pvd_string())?;
        Ok(path)
    }

    /// The collection file, `STEM.pvd`.
    pub fn collection(&self) -> PathBuf {
        self.dir.join(format!("{}.pvd", self.stem))
    }

    /// Frames written so far.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// Whether no frame was written yet.
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    fn pvd_string(&self) -> String {
        let mut s =
            String::from("<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n<Collection>\n");
        for (t, name) in &self.frames {
            let _ = writeln!(s, "<DataSet timestep=\"{t}\" group=\"\" part=\"0\" file=\"{name}\"/>");
        }
        s.push_str("</Collection>\n</VTKFile>\n");
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    #[test]
    fn vtp_lists_every_point_and_triangle() {
        let mut b = ModelBuilder::new();
        b.add_soft_body(&Mesh::icosphere(0.2, 1).translated(DVec3::Y), &SoftBodyOptions::default()).unwrap();
        let m: Model<f32> = b.finalize().unwrap();
        let s = vtp_string(&m, &m.state());
        assert!(s.contains("NumberOfPoints=\"42\"") && s.contains("NumberOfPolys=\"80\""));
        // Points; velocity, strain, body (points); body, damage (cells); connectivity, offsets.
        assert_eq!(s.matches("<DataArray").count(), 8);
        assert!(s.contains("<DataArray type=\"Float32\" Name=\"Points\""));
        assert!(s.trim_end().ends_with("</VTKFile>"));
        let u = vtk_string(&m, &m.state(), VtkKind::UnstructuredGrid);
        assert!(u.contains("NumberOfCells=\"80\"") && u.matches("<DataArray").count() == 9);
    }
}
