//! Colour builtins (docs/language.md, Fields: blackbody). `blackbody(T)` of a number is
//! integrated exactly; of a scalarfield it reads the shared blackbody table at `T`, through the
//! grid read every field kernel already knows (a 1-D grid whose x coordinate is T), so ranges,
//! derivatives and compilation need nothing new.

use crate::base::failure::Outcome;
use crate::field::{self, Field};
use crate::interp::Interpreter;
use crate::interp::registry::{Args, Registry};
use crate::interp::value::Value;
use crate::render::blackbody::{BlackbodyTable, blackbody};

pub fn register(r: &mut Registry) {
    r.add(
        "colour",
        &[
            "blackbody(float T, bool normalize?) -> vector",
            "blackbody(scalarfield T, bool normalize?) -> vectorfield",
        ],
        "the linear Rec.709 colour of a black body at T kelvin, from Planck's law and the CIE \
         1931 2° observer: with luminance Y = 1 (default), or with normalize = false the \
         radiance weighted by the colour-matching functions, in W·sr⁻¹·m⁻²; black below 800 K \
         and where T is not a finite number",
        run,
    );
}

fn run(_: &mut Interpreter, args: Args) -> Outcome<Value> {
    let normalize = match args.opt("normalize") {
        Some(v) => v.as_bool()?,
        None => true,
    };
    match args.get("T")? {
        Value::Field(t) => {
            let table = Field::from_linear_grid(BlackbodyTable::shared(normalize))?;
            let zero = Field::constant_scalar(0.0);
            let at = Field::vector_from(t, &zero, &zero)?;
            Ok(Value::Field(field::compose(&table, &at)?))
        }
        t => Ok(Value::Vector(blackbody(t.as_float()?, normalize))),
    }
}
