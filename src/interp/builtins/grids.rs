//! Domain and cache builtins (docs/language.md, "Domains and caches"): `domain`, the cache
//! constructors, `cachewrite`, `cacheread`, `cachefill`, `cachesave` and `cacheload`.
//!
//! `cachewrite` does not sample anything: it compiles the field and hands it to a cache that
//! fills 8³ bricks the first time something reads them, so a cache that no output reaches
//! costs nothing. Value semantics come from swapping the cache variable's state: `cacheread`
//! captures the cache as it is, and a later `cachewrite` installs a new cache without touching
//! fields already read.

use crate::base::failure::{Failure, Outcome};
use crate::check::types::Shape;
use crate::field::{CompiledField, Field};
use crate::grid::cache::Cache;
use crate::grid::cache::outside::{Outside, OutsideRead};
use crate::grid::frustum::Frustum;
use crate::grid::vdb::VdbMeta;
use crate::grid::vdb_cache;
use crate::interp::Interpreter;
use crate::interp::registry::{Args, Registry};
use crate::interp::value::{CacheVar, Value};
use crate::space::domain::Domain;
use crate::space::{GridDerivative, GridSource, Interp};
use crate::syntax::diagnostic::{self, Diagnostic, Stage};
use glam::{DMat3, DVec3};
use std::cell::RefCell;
use std::rc::Rc;
use std::sync::Arc;

pub fn register(r: &mut Registry) {
    r.add(
        "caches",
        &[
            "domain(vector origin, vector lengths, vector orientation) -> domain",
            "domain(vector origin, vector lengths, vector orientation, float cell) -> domain",
            "domain(vector origin, vector lengths, vector orientation, float cellxy, float cellz) -> domain",
        ],
        "an oriented box (corner, edge lengths, rotation vector), with cubic or (xy, z) cells",
        |interp, a| {
            let (origin, lengths, orientation) = (
                a.get("origin")?.as_vector()?,
                a.get("lengths")?.as_vector()?,
                a.get("orientation")?.as_vector()?,
            );
            let domain = match a.form {
                0 => Domain::new(origin, lengths, orientation)?,
                1 => {
                    let cell = a.float("cell")?;
                    Domain::with_cells(origin, lengths, orientation, cell, cell)?
                }
                _ => Domain::with_cells(origin, lengths, orientation, a.float("cellxy")?, a.float("cellz")?)?,
            };
            if let Some((axis, asked, made)) = domain.length_change(lengths) {
                warn_length_change(interp, &domain, axis, asked, made);
            }
            Ok(Value::Domain(Rc::new(domain)))
        },
    );
    r.add(
        "caches",
        &["scalarcache(domain d, float background?) -> scalarcache"],
        "storage for a scalarfield at the cell centres of d; reads give background outside d",
        |_, a| {
            let background = a.opt_float("background")?.unwrap_or(0.0);
            new_cache(&a, Shape::Scalar, vec![background])
        },
    );
    r.add(
        "caches",
        &["vectorcache(domain d, vector background?) -> vectorcache"],
        "storage for a vectorfield at the cell centres of d",
        |_, a| {
            let b = match a.opt("background") {
                Some(v) => v.as_vector()?,
                None => DVec3::ZERO,
            };
            new_cache(&a, Shape::Vector, b.to_array().to_vec())
        },
    );
    r.add(
        "caches",
        &["matrixcache(domain d, matrix background?) -> matrixcache"],
        "storage for a matrixfield at the cell centres of d",
        |_, a| {
            let m = match a.opt("background") {
                Some(v) => v.as_matrix()?,
                None => DMat3::ZERO,
            };
            let rows = (0..9).map(|i| m.row(i / 3)[i % 3]).collect();
            new_cache(&a, Shape::Matrix, rows)
        },
    );
    r.add(
        "caches",
        &[
            "cachewrite(scalarcache c, scalarfield f) -> void",
            "cachewrite(vectorcache c, vectorfield f) -> void",
            "cachewrite(matrixcache c, matrixfield f) -> void",
        ],
        "samples f into c (lazily: bricks are computed when first read)",
        cachewrite,
    );
    r.add(
        "caches",
        &[
            "cacheread(scalarcache c, string interp?, string derivative?, string outside?) -> scalarfield",
            "cacheread(vectorcache c, string interp?, string derivative?, string outside?) -> vectorfield",
            "cacheread(matrixcache c, string interp?, string derivative?, string outside?) -> matrixfield",
        ],
        "the field interpolating c's samples: interp \"linear\" (default) or \"cubic\"; \
         grad of it is the interpolant's derivative, or derivative = \"central\" differences; \
         outside = \"background\" (default), \"extrapolate\" (linear, for SELMA maps) or \"hold\" \
         (edge values in the border half cell: never below or above the samples, for densities)",
        cacheread,
    );
    r.choices("cacheread", "interp", "interpolation", &["linear", "cubic"]);
    r.choices(
        "cacheread",
        "derivative",
        "derivative",
        &["interpolant", "central"],
    );
    r.choices(
        "cacheread",
        "outside",
        "outside mode",
        &["background", "extrapolate", "hold"],
    );
    r.add(
        "caches",
        &[
            "cachefill(scalarcache c) -> void",
            "cachefill(vectorcache c) -> void",
            "cachefill(matrixcache c) -> void",
        ],
        "computes every brick of c now (for timing, or before saving)",
        |interp, a| {
            let cache = written(&a)?;
            cache.prepare()?;
            cache.fill_all();
            report_now(interp, &cache);
            Ok(Value::Void)
        },
    );
    r.add(
        "caches",
        &[
            "cachesave(scalarcache c, string path, string class?, bool append?) -> void",
            "cachesave(vectorcache c, string path, string vector_type?, bool append?) -> void",
        ],
        "writes c as a grid of an OpenVDB file (named \"density\" or \"vel\", or the name after \
         '#': \"a.vdb#temperature\"); saving several grids to one file in a run keeps them all, \
         append = true also keeps the grids the file held before the run; class \"fog volume\" \
         (default), \"level set\" or \"unknown\"; vector_type as OpenVDB names it (default \
         \"contravariant relative\")",
        cachesave,
    );
    r.add(
        "caches",
        &[
            "cacheload(string path, string grid, string interp?, string derivative?, string outside?) -> scalarfield",
        ],
        "reads a float grid of an OpenVDB file as a field, read as cacheread reads a cache \
         (interp, derivative, outside)",
        |interp, a| {
            let read = ReadOptions::of(&a)?;
            let (cache, frustum) = load_checked(interp, &a, 1)?;
            read.field(Arc::new(cache), frustum.as_ref(), "cacheload")
        },
    );
    r.add(
        "caches",
        &["cacheloadvector(string path, string grid, string interp?, string derivative?, string outside?) -> vectorfield"],
        "reads a vector grid of an OpenVDB file as a field, read as cacheread reads a cache",
        |interp, a| {
            let read = ReadOptions::of(&a)?;
            let (cache, frustum) = load_checked(interp, &a, 3)?;
            read.field(Arc::new(cache), frustum.as_ref(), "cacheload")
        },
    );
}

/// Warns that a domain's box grew or shrank to a whole number of cells.
fn warn_length_change(
    interp: &mut Interpreter,
    domain: &Domain,
    axis: usize,
    asked: f64,
    made: f64,
) {
    let resolution = domain.resolution.unwrap_or([1, 1, 1]);
    interp.warnings.push(
        Diagnostic::warning(
            Stage::Runtime,
            interp.call_span,
            format!(
                "the domain's {} length {asked} is not a whole number of cells of {}: it is {made} \
                 ({} cells), the far face moved by {:.3} of a cell",
                ["x", "y", "z"][axis],
                domain.cell[axis],
                resolution[axis],
                (made - asked).abs() / domain.cell[axis],
            ),
        )
        .with_help("cells are cubic: make the length a multiple of the cell size"),
    );
}

fn cachesave(interp: &mut Interpreter, a: Args) -> Outcome<Value> {
    let cache = written(&a)?;
    let (file, name) = split_grid_name(a.string("path")?)?;
    let vector = cache.width() == 3;
    // Each form has its own keyword: class for scalars, vector_type for vectors.
    let (class, vector_type) = if vector {
        let vector_type = match a.opt("vector_type") {
            Some(v) => v.as_str()?.to_string(),
            None => vdb_cache::DEFAULT_VECTOR_TYPE.to_string(),
        };
        (vdb_cache::GridClass::Unknown, vector_type)
    } else {
        let class = match a.opt("class") {
            Some(v) => vdb_cache::GridClass::parse(v.as_str()?)?,
            None => vdb_cache::GridClass::FogVolume,
        };
        (class, String::new())
    };
    let options = vdb_cache::GridOptions {
        name: name
            .unwrap_or(if vector { "vel" } else { "density" })
            .to_string(),
        class,
        vector_type,
        creator: crate::interp::provenance::creator(),
    };
    let path = interp.files.writing(file)?;
    // Before the fill, which can take long: a file in the way should not cost it.
    crate::io::output::check_writable(&path)
        .map_err(|e| Failure::new(format!("cannot write VDB file '{}': {e}", path.display())))?;
    let append = matches!(a.opt("append"), Some(Value::Bool(true)));
    let grid = match &cache_var(&a)?.frustum {
        Some(frustum) => vdb_cache::grid_placed(&cache, &options, &frustum.vdb_placement())?,
        None => vdb_cache::grid_of(&cache, &options)?,
    };
    let mut metadata: Vec<(String, VdbMeta)> = crate::interp::provenance::of(interp)
        .into_iter()
        .map(|(k, v)| (k, VdbMeta::String(v)))
        .collect();
    metadata.push(("creator".into(), VdbMeta::String(options.creator.clone())));
    let keep = append || interp.files.vdbs_written.contains(&path);
    vdb_cache::save(&path, grid, keep, &metadata)?;
    interp.files.vdbs_written.insert(path);
    report_now(interp, &cache);
    Ok(Value::Void)
}

/// How a cache or a loaded grid is read as a field: `cacheread`'s and `cacheload`'s options.
struct ReadOptions {
    interp: Interp,
    derivative: GridDerivative,
    outside: Option<Outside>,
}

impl ReadOptions {
    fn of(a: &Args) -> Outcome<ReadOptions> {
        let interp = match a.opt("interp") {
            None => Interp::Linear,
            Some(v) => match v.as_str()? {
                "linear" => Interp::Linear,
                "cubic" => Interp::Cubic,
                other => {
                    return Err(Failure::new(format!(
                        "interp must be \"linear\" or \"cubic\", found \"{other}\""
                    )));
                }
            },
        };
        let derivative = match a.opt("derivative") {
            None => GridDerivative::Interpolant,
            Some(v) => match v.as_str()? {
                "interpolant" => GridDerivative::Interpolant,
                "central" => GridDerivative::Central,
                other => {
                    return Err(Failure::new(format!(
                        "derivative must be \"interpolant\" or \"central\", found \"{other}\""
                    )));
                }
            },
        };
        let outside = match a.opt("outside") {
            None => None,
            Some(v) => match v.as_str()? {
                "background" => None,
                "extrapolate" => Some(Outside::Extrapolate),
                "hold" => Some(Outside::Hold),
                other => {
                    return Err(Failure::new(format!(
                        "outside must be \"background\", \"extrapolate\" or \"hold\", found \"{other}\""
                    )));
                }
            },
        };
        Ok(ReadOptions {
            interp,
            derivative,
            outside,
        })
    }

    /// The field reading `cache`, through `frustum` when it is a frustum's (`call` names the
    /// builtin in messages).
    fn field(
        &self,
        cache: Arc<Cache>,
        frustum: Option<&Arc<Frustum>>,
        call: &str,
    ) -> Outcome<Value> {
        let grid: Arc<dyn GridSource> = match self.outside {
            Some(how) => Arc::new(OutsideRead::new(cache, how)),
            None => cache,
        };
        if frustum.is_some() && self.outside == Some(Outside::Extrapolate) {
            return Err(super::frustum::refusal(
                &format!("{call} with outside = \"extrapolate\""),
                "read it with outside = \"background\" or \"hold\"",
            ));
        }
        let grid = super::frustum::read_at_world(frustum, grid);
        Ok(Value::Field(Field::from_grid(
            grid,
            self.interp,
            self.derivative,
        )?))
    }
}

/// `cacheload`'s grid as a cache (with its frustum, for a grid with OpenVDB's frustum map), with
/// a warning when it holds NaN or infinite values.
fn load_checked(
    interp: &mut Interpreter,
    a: &Args,
    width: usize,
) -> Outcome<(Cache, Option<Arc<Frustum>>)> {
    let (path, name) = (interp.files.reading(a.string("path")?)?, a.string("grid")?);
    let (cache, check, frustum) = vdb_cache::load(&path, name, width)?;
    if let Some(message) = check.warning(&path, name) {
        interp.warnings.push(
            Diagnostic::warning(Stage::Runtime, interp.call_span, message).with_help(
                "reading those voxels gives NaN; a render treats them as empty, other uses \
                 pass them on",
            ),
        );
    }
    Ok((cache, frustum.map(Arc::new)))
}

fn new_cache(a: &Args, shape: Shape, background: Vec<f64>) -> Outcome<Value> {
    let Value::Domain(d) = a.get("d")? else {
        return Err(Failure::new("a cache needs a domain"));
    };
    if d.resolution.is_none() {
        return Err(
            Failure::new("a cache needs a domain with a cell size").with_help(
                "add the cell size to the domain: domain(origin, lengths, orientation, cell)",
            ),
        );
    }
    if background.iter().any(|b| !b.is_finite()) {
        return Err(Failure::new("a cache's background must be finite"));
    }
    let width = background.len();
    d.check_grid_memory(width)?;
    Ok(Value::Cache(Rc::new(CacheVar {
        shape,
        domain: d.clone(),
        frustum: None,
        background,
        state: RefCell::new(None),
    })))
}

pub fn cache_var(a: &Args) -> Outcome<&Rc<CacheVar>> {
    match a.get("c")? {
        Value::Cache(c) => Ok(c),
        other => Err(Failure::new(format!(
            "expected a cache, found {}",
            other.type_of()
        ))),
    }
}

fn cachewrite(interp: &mut Interpreter, a: Args) -> Outcome<Value> {
    let var = cache_var(&a)?;
    let field = super::frustum::field_in_cells(var, &a.get("f")?.as_field()?)?;
    let width = field.kind().width();
    let label = format!(
        "cachewrite at {}",
        diagnostic::location(interp.call_span, &interp.sources.borrow())
    );
    let cache = Cache::from_field(
        (*var.domain).clone(),
        width,
        CompiledField::shared(&field),
        var.background.clone(),
        label,
    )?;
    let cache = Arc::new(cache.watch_map_reads(map_tally(interp)));
    interp
        .written_caches
        .push((Arc::downgrade(&cache), interp.call_span));
    interp.map_watched.push(Arc::downgrade(&cache));
    *var.state.borrow_mut() = Some(cache);
    Ok(Value::Void)
}

/// The tally of map reads outside the domain for the `cachewrite` line being run, made on its
/// first run (a loop's frames share it, so the warning comes once, with the total).
fn map_tally(interp: &mut Interpreter) -> Arc<std::sync::atomic::AtomicU64> {
    let span = interp.call_span;
    if let Some((_, _, tally)) = interp.map_tallies.iter().find(|(s, _, _)| *s == span) {
        return tally.clone();
    }
    // The cache's name as written: the call's first argument.
    let name = {
        let sources = interp.sources.borrow();
        let text = &sources.get(span.file).text;
        text.get(span.start as usize..span.end as usize)
            .and_then(|call| call.split_once('('))
            .and_then(|(_, args)| args.split([',', ')']).next())
            .map(|name| name.trim().to_string())
            .filter(|name| !name.is_empty())
            .unwrap_or_else(|| "c".to_string())
    };
    let tally = Arc::new(std::sync::atomic::AtomicU64::new(0));
    interp.map_tallies.push((span, name, tally.clone()));
    tally
}

/// After a run: one warning per `cachewrite` line whose map was read outside its domain into
/// the zero background, with the count and the read that fixes it.
pub fn report_map_reads(interp: &mut Interpreter) {
    for cache in std::mem::take(&mut interp.map_watched) {
        if let Some(cache) = cache.upgrade() {
            cache.settle_map_reads();
        }
    }
    for (span, name, tally) in &interp.map_tallies {
        let reads = tally.swap(0, std::sync::atomic::Ordering::Relaxed);
        if reads == 0 {
            continue;
        }
        interp.warnings.push(
            Diagnostic::warning(
                Stage::Runtime,
                *span,
                format!(
                    "this cache holds a map, and {reads} read{} of it landed outside its \
                     domain, where the zero background sends a point to the origin",
                    if reads == 1 { "" } else { "s" }
                ),
            )
            .with_help(format!(
                "a map is close to the identity beyond its faces: read it with \
                 cacheread({name}, outside = \"extrapolate\") (selmastep does)"
            )),
        );
    }
}

fn written(a: &Args) -> Outcome<Arc<Cache>> {
    let var = cache_var(a)?;
    let state = var.state.borrow();
    state.clone().ok_or_else(|| {
        Failure::new("this cache was never written").with_help("call cachewrite(c, field) first")
    })
}

fn cacheread(interp: &mut Interpreter, a: Args) -> Outcome<Value> {
    let var = cache_var(&a)?;
    let read = ReadOptions::of(&a)?;
    let state = var.state.borrow().clone();
    match state {
        Some(cache) => read.field(cache, var.frustum.as_ref(), "cacheread"),
        None => {
            interp.warnings.push(
                Diagnostic::warning(
                    Stage::Runtime,
                    interp.call_span,
                    "this cache was never written; reading it gives its background everywhere",
                )
                .with_help("call cachewrite(c, field) before cacheread(c)"),
            );
            Ok(Value::Field(constant_of(var.shape, &var.background)))
        }
    }
}

fn constant_of(shape: Shape, background: &[f64]) -> Field {
    match shape {
        Shape::Scalar => Field::constant_scalar(background[0]),
        Shape::Vector => Field::constant_vector(DVec3::from_slice(background)),
        Shape::Matrix => Field::constant_matrix(DMat3::from_cols_array(&[
            background[0],
            background[3],
            background[6],
            background[1],
            background[4],
            background[7],
            background[2],
            background[5],
            background[8],
        ])),
    }
}

/// `"a.vdb#name"` → (`"a.vdb"`, `Some("name")`); `"a.vdb#"`, with nothing after the `#`, is an
/// error rather than a file called `a.vdb#`.
fn split_grid_name(path: &str) -> Outcome<(&str, Option<&str>)> {
    match path.rsplit_once('#') {
        Some((file, "")) => Err(Failure::new(format!(
            "the grid name after '#' in \"{path}\" is empty"
        ))
        .with_help(format!(
            "name the grid (\"{file}#density\") or leave out the '#' for the default name"
        ))),
        Some((file, name)) => Ok((file, Some(name))),
        None => Ok((path, None)),
    }
}

/// Reports non-finite values of a cache now (after a full fill) instead of at the end of the run.
fn report_now(interp: &mut Interpreter, cache: &Arc<Cache>) {
    interp
        .written_caches
        .retain(|(w, _)| !std::ptr::eq(w.as_ptr(), Arc::as_ptr(cache)));
    report_nonfinite(interp, cache, interp.call_span);
}

/// A warning when a cache holds NaN or infinite values (division by zero in its field).
pub fn report_nonfinite(interp: &mut Interpreter, cache: &Cache, span: crate::syntax::span::Span) {
    if let Some((count, at)) = cache.nonfinite_report() {
        interp.warnings.push(
            Diagnostic::warning(
                Stage::Runtime,
                span,
                format!(
                    "{count} non-finite value{} written into this cache, the first at ({}, {}, {})",
                    if count == 1 { "" } else { "s" },
                    at.x,
                    at.y,
                    at.z
                ),
            )
            .with_help("a division by a field that is zero somewhere gives infinities or NaN; guard it with select or max"),
        );
    }
}

/// `field` sampled lazily over the cells of `grid` and read back the way `grid` is read
/// (extrapolating outside when it does): the intermediate grids of error-correcting advection.
pub fn resample(field: &Field, grid: &dyn GridSource, label: &str) -> Outcome<Field> {
    let Some(lattice) = grid.lattice() else {
        return Err(Failure::new(format!(
            "{} has no cells to sample onto",
            grid.label()
        )));
    };
    let cache = Arc::new(Cache::from_field(
        Domain::from_lattice(&lattice),
        field.kind().width(),
        CompiledField::shared(field),
        grid.background(),
        label.to_string(),
    )?);
    let read: Arc<dyn GridSource> = if lattice.extrapolates {
        Arc::new(OutsideRead::new(cache, Outside::Extrapolate))
    } else {
        cache
    };
    Field::from_linear_grid(read)
}
