//! Feeds arbitrary bytes to the OBJ and PLY readers: each must return a mesh or a failure,
//! never panic, hang or allocate without bound. Whatever they read must be a valid mesh that
//! writes and reads back unchanged in both formats.
//! Seed the corpus with a few shape files: `cp some/*.obj some/*.ply fuzz/corpus/mesh_read/`.

#![no_main]

use felt::geometry::{Mesh, parse_obj, parse_ply, write_obj, write_ply};
use libfuzzer_sys::fuzz_target;

fn check(mesh: &Mesh) {
    mesh.validate().expect("a mesh felt read is valid");
    let _ = (
        mesh.volume(),
        mesh.area(),
        mesh.is_closed(),
        mesh.euler_characteristic(),
    );
    let obj = write_obj(mesh).expect("a valid mesh writes as OBJ");
    assert_eq!(&parse_obj(&obj).expect("felt reads its own OBJ"), mesh);
    let ply = write_ply(mesh).expect("a valid mesh writes as PLY");
    assert_eq!(&parse_ply(&ply).expect("felt reads its own PLY"), mesh);
}

fuzz_target!(|data: &[u8]| {
    if let Ok(mesh) = parse_obj(data) {
        check(&mesh);
    }
    if let Ok(mesh) = parse_ply(data) {
        check(&mesh);
    }
});
