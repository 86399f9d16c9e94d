//! Writing fields: a profile as CSV, a grid as HDF5 with an XDMF index that
//! ParaView opens as a structured grid. Both are replaced atomically.

use super::Averaged;
use crate::durable::write_atomic;
use crate::error::TalusError;
use std::io::Write;
use std::path::Path;

const AXES: [&str; 3] = ["x", "y", "z"];

/// The stress components a profile reports, as (a, b).
const COMPONENTS: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)];

/// The header of a profile along `axis`.
pub fn profile_header(axis: usize) -> String {
    let mut h = format!("{}_m,density_kg_m3,velocity_x_m_s,velocity_y_m_s,velocity_z_m_s", AXES[axis]);
    for (a, b) in COMPONENTS {
        h.push_str(&format!(",stress_{}{}_pa", AXES[a], AXES[b]));
    }
    let n = AXES[axis];
    h.push_str(&format!(",kinetic_stress_{n}{n}_pa,contact_stress_{n}{n}_pa"));
    h
}

/// `profile_<axis>.csv`: a row per point. Stress is kinetic plus contact,
/// compression positive; the component ab is the force's a component times
/// the branch's b component.
pub fn profile_csv(path: &Path, axis: usize, f: &Averaged) -> Result<(), TalusError> {
    write_atomic(path, |w| {
        writeln!(w, "{}", profile_header(axis))?;
        for i in 0..f.density.len() {
            write!(w, "{:.9e},{:.9e}", f.at[i][axis], f.density[i])?;
            for k in 0..3 {
                write!(w, ",{:.9e}", f.velocity[i][k])?;
            }
            for (a, b) in COMPONENTS {
                write!(w, ",{:.9e}", f.stress(i, a, b))?;
            }
            writeln!(w, ",{:.9e},{:.9e}", f.kinetic[i][4 * axis], f.contact[i][4 * axis])?;
        }
        Ok(())
    })
}

/// `fields.h5` and `fields.xdmf`: every field on an nx x ny x nz grid of
/// cell centres (`origin` the first centre, `spacing` between centres).
pub fn grid_hdf5(dir: &Path, n: [usize; 3], origin: [f64; 3], spacing: [f64; 3], f: &Averaged) -> Result<(), TalusError> {
    let h5 = dir.join("fields.h5");
    let tmp = dir.join("fields.h5.partial");
    let err = |e: hdf5_metno::Error| TalusError::Run(format!("writing {}: {e}", tmp.display()));
    let dims = (n[2], n[1], n[0]);
    let mut names: Vec<(String, bool)> = Vec::new();
    {
        let file = hdf5_metno::File::create(&tmp).map_err(err)?;
        file.new_dataset::<f64>().shape(dims).create("density").map_err(err)?.write_raw(&f.density).map_err(err)?;
        names.push(("density".into(), false));
        let v: Vec<f64> = f.velocity.iter().flat_map(|v| [v.x, v.y, v.z]).collect();
        file.new_dataset::<f64>().shape((n[2], n[1], n[0], 3)).create("velocity").map_err(err)?.write_raw(&v).map_err(err)?;
        names.push(("velocity".into(), true));
        for (a, b) in COMPONENTS {
            for (kind, part) in [("stress", None), ("kinetic_stress", Some(true)), ("contact_stress", Some(false))] {
                if part.is_some() && a != b {
                    continue;
                }
                let name = format!("{kind}_{}{}", AXES[a], AXES[b]);
                let data: Vec<f64> = (0..f.density.len())
                    .map(|i| match part {
                        None => f.stress(i, a, b),
                        Some(true) => f.kinetic[i][3 * a + b],
                        Some(false) => f.contact[i][3 * a + b],
                    })
                    .collect();
                file.new_dataset::<f64>().shape(dims).create(name.as_str()).map_err(err)?.write_raw(&data).map_err(err)?;
                names.push((name, false));
            }
        }
        file.flush().map_err(err)?;
    }
    crate::durable::sync_rename(&tmp, &h5)?;
    let mut s = String::from("<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n<Domain>\n<Grid Name=\"fields\" GridType=\"Uniform\">\n");
    let d = format!("{} {} {}", n[2], n[1], n[0]);
    s.push_str(&format!("<Topology TopologyType=\"3DCoRectMesh\" Dimensions=\"{d}\"/>\n<Geometry GeometryType=\"ORIGIN_DXDYDZ\">\n"));
    s.push_str(&format!("<DataItem Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">{:e} {:e} {:e}</DataItem>\n", origin[2], origin[1], origin[0]));
    s.push_str(&format!("<DataItem Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">{:e} {:e} {:e}</DataItem>\n</Geometry>\n", spacing[2], spacing[1], spacing[0]));
    for (name, vector) in &names {
        let (ty, dims) = if *vector { ("Vector", format!("{d} 3")) } else { ("Scalar", d.clone()) };
        s.push_str(&format!(
            "<Attribute Name=\"{name}\" AttributeType=\"{ty}\" Center=\"Node\">\n<DataItem Dimensions=\"{dims}\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">fields.h5:/{name}</DataItem>\n</Attribute>\n"
        ));
    }
    s.push_str("</Grid>\n</Domain>\n</Xdmf>\n");
    write_atomic(&dir.join("fields.xdmf"), |w| w.write_all(s.as_bytes()))
}
