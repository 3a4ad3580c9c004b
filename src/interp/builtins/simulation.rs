//! Simulation builtins (docs/language.md "Simulation"): `fftdivfree`.
//!
//! Everything else a fluid script needs (advection, injection, buoyancy, obstacle boundaries,
//! gridded, gridless and SELMA densities) is `advect`, `compose`, caches and the library
//! functions of `stdlib/fluids.felt`. The projection is the one step that cannot be written as
//! a field expression: it needs the whole velocity at once.

use crate::base::failure::{Failure, Outcome};
use crate::field::{CompiledField, Field};
use crate::fluids::divfree::DivergenceFree;
use crate::interp::registry::Registry;
use crate::interp::value::Value;
use crate::space::{GridDerivative, GridSource, Interp};
use std::sync::Arc;

pub fn register(r: &mut Registry) {
    r.add(
        "simulation",
        &["fftdivfree(vectorfield u, domain d) -> vectorfield"],
        "u sampled at d's cell centres with its divergent part removed by FFTs (periodic over d): \
         the central-difference divergence of the result is zero; solved only when something \
         reads it, and grad/div/curl of it use central differences",
        |interp, a| {
            let velocity = a.get("u")?.as_field()?;
            let Value::Domain(domain) = a.get("d")? else {
                return Err(Failure::new("fftdivfree needs a domain"));
            };
            let label = format!("fftdivfree at {}", interp.location(interp.call_span));
            Ok(Value::Field(divergence_free(&velocity, domain, label)?))
        },
    );
}

fn divergence_free(
    velocity: &Field,
    domain: &crate::space::domain::Domain,
    label: String,
) -> Outcome<Field> {
    let solve = DivergenceFree::new(domain.clone(), CompiledField::shared(velocity), label)?;
    let grid: Arc<dyn GridSource> = Arc::new(solve);
    Field::from_grid(grid, Interp::Linear, GridDerivative::Central)
}
