//! Geometry builtins (docs/language.md, Geometry): level sets to meshes and back, mesh files, pieces.
//!
//! `ls2shape(ls)` without a domain meshes over the box where the level set can be positive,
//! found by interval analysis of `mask(ls)`, with `DEFAULT_MESH_CELLS` cells along its longest
//! side. `shape2ls` is a cache of the mesh's signed distance (winding-number sign), so it is
//! exact at cell centres and interpolated between; outside its domain it reads minus the
//! domain's diagonal, i.e. clearly outside.

use crate::base::failure::{Failure, Outcome};
use crate::field::{CompiledField, Field};
use crate::geometry::{self, Mesh, MeshDistance};
use crate::grid::cache::Cache;
use crate::interp::registry::Registry;
use crate::interp::value::Value;
use crate::space::{FieldSampler, GridSource};
use std::rc::Rc;
use std::sync::Arc;

pub fn register(r: &mut Registry) {
    r.add(
        "geometry",
        &[
            "ls2shape(scalarfield ls) -> shape",
            "ls2shape(scalarfield ls, domain d) -> shape",
        ],
        "the zero set of a level set as a closed triangle mesh (marching cubes over d's cells, or \
         over the level set's inside at 128 cells along its longest side)",
        |_, a| {
            let ls = a.get("ls")?.as_field()?;
            let sampler = CompiledField::prepared(&ls)?;
            let domain = match a.opt("d") {
                Some(Value::Domain(d)) => {
                    if d.resolution.is_none() {
                        return Err(Failure::new("ls2shape needs a domain with a cell size"));
                    }
                    (**d).clone()
                }
                _ => geometry::default_mesh_domain(&CompiledField::prepared(&ls.mask()?)?)?,
            };
            Ok(Value::Shape(Rc::new(geometry::marching_cubes(
                &sampler, &domain,
            )?)))
        },
    );
    r.add(
        "geometry",
        &["shape2ls(shape s, domain d) -> scalarfield"],
        "the signed distance to a mesh (positive inside, by winding number), sampled at d's cells",
        |interp, a| {
            let Value::Shape(mesh) = a.get("s")? else {
                return Err(Failure::new("expected a shape"));
            };
            let Value::Domain(d) = a.get("d")? else {
                return Err(Failure::new("expected a domain"));
            };
            if d.resolution.is_none() {
                return Err(Failure::new("shape2ls needs a domain with a cell size"));
            }
            let distance: Arc<dyn FieldSampler> = Arc::new(MeshDistance::new(mesh)?);
            let label = format!("shape2ls at {}", interp.location(interp.call_span));
            let outside = -d.lengths.length();
            let cache = Cache::from_field((**d).clone(), 1, distance, vec![outside], label)?;
            let grid: Arc<dyn GridSource> = Arc::new(cache);
            Ok(Value::Field(Field::from_linear_grid(grid)?))
        },
    );
    r.add(
        "geometry",
        &["loadshape(string path) -> shape"],
        "reads a triangle mesh from an OBJ or PLY file",
        |interp, a| {
            let path = interp.files.reading(a.string("path")?)?;
            Ok(Value::Shape(Rc::new(geometry::load_mesh(&path)?)))
        },
    );
    r.add(
        "geometry",
        &["saveshape(shape s, string path) -> void"],
        "writes a mesh as OBJ (text) or PLY (binary), by the path's extension",
        |interp, a| {
            let Value::Shape(mesh) = a.get("s")? else {
                return Err(Failure::new("expected a shape"));
            };
            geometry::save_mesh(mesh, &interp.files.writing(a.string("path")?)?)?;
            Ok(Value::Void)
        },
    );
    r.add(
        "geometry",
        &[
            "pieces(shape s) -> shape[]",
            "pieces(shape s, float minvolume) -> shape[]",
        ],
        "the connected components of a mesh; with minvolume, only those enclosing at least that \
         volume (slivers dropped)",
        |_, a| {
            let Value::Shape(mesh) = a.get("s")? else {
                return Err(Failure::new("expected a shape"));
            };
            let parts = match a.opt_float("minvolume")? {
                None => geometry::pieces(mesh),
                Some(least) => geometry::pieces_above(mesh, minimum_volume(least)?).0,
            };
            Ok(shapes(parts))
        },
    );
    r.add(
        "geometry",
        &["cutpieces(scalarfield l0, scalarfield[] knives, domain d, float minvolume?) -> shape[]"],
        "the solid l0 cut by every knife into the regions of their arrangement, each meshed over \
         d's cells as min(l0, ±knife...); pieces below minvolume (default: 8 cells' volume) are \
         dropped as slivers",
        |_, a| {
            let l0 = a.get("l0")?.as_field()?;
            let knives = fields_of(a.get("knives")?)?;
            let Value::Domain(d) = a.get("d")? else {
                return Err(Failure::new("expected a domain"));
            };
            let least = match a.opt_float("minvolume")? {
                Some(v) => minimum_volume(v)?,
                None => 8.0 * d.cell.x * d.cell.y * d.cell.z,
            };
            Ok(shapes(
                geometry::knives::cut(&l0, &knives, d, least)?.pieces,
            ))
        },
    );
    r.add(
        "geometry",
        &["cutall(scalarfield l0, scalarfield[] knives) -> scalarfield[]"],
        "the level set l0 cut by every knife: 2^n level sets min(l0, ±k0, ±k1, ...), knife 0 \
         deciding the most significant bit of the index and 0 meaning its positive side; \
         refused before it starts when they would not fit in the memory budget",
        |_, a| {
            let l0 = a.get("l0")?.as_field()?;
            let knives = fields_of(a.get("knives")?)?;
            check_cut_fits(knives.len())?;
            let sides = geometry::knives::sides(&l0, &knives)?;
            let sides = sides.into_iter().map(Value::Field).collect();
            Ok(Value::array(sides, crate::check::types::Type::ScalarField))
        },
    );
    r.add(
        "geometry",
        &["volume(shape s) -> float"],
        "the volume a closed mesh encloses",
        |_, a| Ok(Value::Float(mesh_of(a.get("s")?)?.volume())),
    );
    r.add(
        "geometry",
        &["area(shape s) -> float"],
        "the surface area of a mesh",
        |_, a| Ok(Value::Float(mesh_of(a.get("s")?)?.area())),
    );
    r.add(
        "geometry",
        &["vertices(shape s) -> int"],
        "the number of vertices of a mesh",
        |_, a| Ok(Value::Int(mesh_of(a.get("s")?)?.positions.len() as i64)),
    );
    r.add(
        "geometry",
        &["triangles(shape s) -> int"],
        "the number of triangles of a mesh",
        |_, a| Ok(Value::Int(mesh_of(a.get("s")?)?.triangles.len() as i64)),
    );
}

fn shapes(meshes: Vec<Mesh>) -> Value {
    let parts = meshes
        .into_iter()
        .map(|m| Value::Shape(Rc::new(m)))
        .collect();
    Value::array(parts, crate::check::types::Type::Shape)
}

fn fields_of(array: &Value) -> Outcome<Vec<Field>> {
    array.as_array()?.iter().map(|k| k.as_field()).collect()
}

/// Refuses a `cutall` by `knives` knives before it starts when its level sets would not fit
/// beside the live field graphs: each knife doubles them, so the last few knives decide, and
/// building towards a limit that 24 knives pass by gigabytes only wastes the time.
/// What they take: the `min` nodes (`side_nodes`), and per level set its slot in the array,
/// the block its field owns, and its handle in the working lists of the last two knives.
fn check_cut_fits(knives: usize) -> Outcome<()> {
    use crate::interp::elements::{SLOT_BYTES, owned_bytes};
    let nodes = geometry::knives::side_nodes(knives);
    let sides = 2f64.powi(knives as i32);
    let owned = owned_bytes(&Value::Field(Field::constant_scalar(0.0))) as f64;
    let handle = std::mem::size_of::<Field>() as f64;
    let bytes = sides * (SLOT_BYTES as f64 + owned + 1.5 * handle);
    let count = if knives < 64 {
        format!("{} level sets", 1u64 << knives)
    } else {
        format!("2^{knives} level sets")
    };
    let what = format!("cutall by {knives} knives ({count} and {nodes} field nodes)");
    crate::field::node::check_beside_graphs(nodes, bytes, &what).map_err(|f| {
        f.with_help(
            "each knife doubles cutall's level sets: cut with fewer knives, use \
             cutpieces(l0, knives, d), which meshes only the pieces that occur, or raise the \
             budget with --memory-limit MB",
        )
    })
}

fn minimum_volume(v: f64) -> Outcome<f64> {
    if v >= 0.0 && v.is_finite() {
        Ok(v)
    } else {
        Err(Failure::new(format!(
            "the minimum piece volume must be zero or positive, found {v}"
        )))
    }
}

fn mesh_of(v: &Value) -> Outcome<&Mesh> {
    match v {
        Value::Shape(m) => Ok(m),
        other => Err(Failure::new(format!(
            "expected a shape, found {}",
            other.type_of()
        ))),
    }
}
