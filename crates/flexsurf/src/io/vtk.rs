//! VTK output for ParaView: one XML unstructured grid (`.vtu`, triangles, base64-encoded binary arrays) per
//! frame with point data, a `.vtu` of the obstacles, and the `.pvd` collection that lists the frames with their
//! simulated times (ParaView opens the `.pvd` as a time series).
//!
//! The `.vtu` files are written by the `vtkio` crate (its data model and XML writer); the `.pvd` collection,
//! which `vtkio` does not cover, is a few lines of XML written here.

use super::atomic::{write_atomic, write_atomic_with};
use super::invalid;
use std::io::{self, Write};
use std::path::Path;
use vtkio::model::{
    Attribute, Attributes, ByteOrder, CellType, Cells, DataArray, DataSet, ElementType, IOBuffer,
    UnstructuredGridPiece, Version, VertexNumbers,
};
use vtkio::Vtk;

/// A point-data array of a `.vtu`.
#[derive(Debug, Clone, Copy)]
pub enum PointData<'a> {
    /// One value per point.
    Scalar(&'a str, &'a [f32]),
    /// A 3-vector per point.
    Vector(&'a str, &'a [[f32; 3]]),
    /// A 2-vector per point (e.g. texture coordinates).
    Pair(&'a str, &'a [[f32; 2]]),
}

impl PointData<'_> {
    fn len(&self) -> usize {
        match self {
            Self::Scalar(_, v) => v.len(),
            Self::Vector(_, v) => v.len(),
            Self::Pair(_, v) => v.len(),
        }
    }

    fn name(&self) -> &str {
        match self {
            Self::Scalar(n, _) | Self::Vector(n, _) | Self::Pair(n, _) => n,
        }
    }

    fn attribute(&self) -> Attribute {
        let (name, elem, data): (&str, ElementType, Vec<f32>) = match *self {
            Self::Scalar(n, v) => (n, ElementType::Scalars { num_comp: 1, lookup_table: None }, v.to_vec()),
            Self::Vector(n, v) => (n, ElementType::Vectors, v.iter().flatten().copied().collect()),
            Self::Pair(n, v) => (n, ElementType::TCoords(2), v.iter().flatten().copied().collect()),
        };
        Attribute::DataArray(DataArray { name: name.to_string(), elem, data: IOBuffer::F32(data) })
    }
}

/// A triangle surface with point data, and a cell-data id per triangle (e.g. which obstacle it belongs to).
#[derive(Debug, Clone, Copy)]
pub struct Surface<'a> {
    /// Points (m).
    pub points: &'a [[f32; 3]],
    /// Triangles.
    pub triangles: &'a [[u32; 3]],
    /// Point data arrays.
    pub point_data: &'a [PointData<'a>],
    /// Optional integer cell data: (name, one value per triangle).
    pub cell_ids: Option<(&'a str, &'a [u32])>,
}

/// The `vtkio` model of `s`, after checking sizes and indices.
fn model(s: &Surface<'_>, title: &str) -> io::Result<Vtk> {
    let n = s.points.len();
    for d in s.point_data {
        if d.len() != n {
            return Err(invalid(format!("point data {:?}: {} values for {n} points", d.name(), d.len())));
        }
    }
    if let Some(t) = s.triangles.iter().find(|t| t.iter().any(|&v| v as usize >= n)) {
        return Err(invalid(format!("triangle {t:?} refers to a point beyond the {n} points")));
    }
    let mut cell = Vec::new();
    if let Some((name, ids)) = s.cell_ids {
        if ids.len() != s.triangles.len() {
            return Err(invalid(format!("cell data {name:?}: {} values for {} cells", ids.len(), s.triangles.len())));
        }
        cell.push(Attribute::DataArray(DataArray {
            name: name.to_string(),
            elem: ElementType::Scalars { num_comp: 1, lookup_table: None },
            data: IOBuffer::U32(ids.to_vec()),
        }));
    }
    let connectivity: Vec<u64> = s.triangles.iter().flatten().map(|&v| u64::from(v)).collect();
    let offsets: Vec<u64> = (1..=s.triangles.len() as u64).map(|k| 3 * k).collect();
    let piece = UnstructuredGridPiece {
        points: IOBuffer::F32(s.points.iter().flatten().copied().collect()),
        cells: Cells {
            cell_verts: VertexNumbers::XML { connectivity, offsets },
            types: vec![CellType::Triangle; s.triangles.len()],
        },
        data: Attributes { point: s.point_data.iter().map(PointData::attribute).collect(), cell },
    };
    Ok(Vtk {
        version: Version::new((1, 0)),
        title: title.to_string(),
        byte_order: ByteOrder::LittleEndian,
        data: DataSet::inline(piece),
        file_path: None,
    })
}

/// Writes `s` as a `.vtu` (XML unstructured grid) at `path`, atomically.
pub fn write_vtu(path: impl AsRef<Path>, s: &Surface<'_>, title: &str) -> io::Result<()> {
    let vtk = model(s, title)?;
    let mut text = Vec::new();
    vtk.write_xml(&mut text).map_err(|e| io::Error::other(format!("VTK XML: {e}")))?;
    write_atomic(path, &text)
}

/// Writes the ParaView collection at `path`: one `DataSet` per `(time, file)`, files relative to the `.pvd`.
pub fn write_pvd(path: impl AsRef<Path>, entries: &[(f64, String)]) -> io::Result<()> {
    fn escape(s: &str) -> String {
        s.replace('&', "&amp;").replace('"', "&quot;").replace('<', "&lt;").replace('>', "&gt;")
    }
    write_atomic_with(path, |w: &mut dyn Write| {
        writeln!(w, "<?xml version=\"1.0\"?>")?;
        writeln!(w, "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">")?;
        writeln!(w, "  <Collection>")?;
        for (t, file) in entries {
            writeln!(w, "    <DataSet timestep=\"{t:e}\" group=\"\" part=\"0\" file=\"{}\"/>", escape(file))?;
        }
        writeln!(w, "  </Collection>")?;
        writeln!(w, "</VTKFile>")
    })
}
