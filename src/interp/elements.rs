//! An array's elements and the share of the memory budget they hold.
//!
//! The one key decision: the charge lives with the storage. An array holds a `Reservation`
//! for its slots (every slot a whole `Value`, whatever the element type, at the capacity the
//! vector really has) plus the heap blocks its elements own outside their slots (a field's
//! list of component nodes, a string's text), taken when the storage is made and given back
//! when it is dropped. So millions of fields in arrays count against every later request,
//! graph nodes included, while they live; growth is checked beside the live field graphs
//! before the larger storage is made (a sphere cut by 24 knives once held 1.9 GB of array
//! elements that no check saw). The nodes the fields point to are the node table's to count
//! (`crate::field::node`), shared as they are between fields.

use super::value::Value;
use crate::base::failure::Outcome;
use crate::engine::budget::Reservation;
use std::ops::Deref;

/// What one slot takes: a whole `Value`.
pub const SLOT_BYTES: usize = std::mem::size_of::<Value>();

/// Elements with their charge (see the module's paragraph).
#[derive(Debug)]
pub struct Elements {
    items: Vec<Value>,
    /// Bytes the elements own outside their slots (`owned_bytes`).
    owned: u64,
    held: Reservation,
}

impl Elements {
    /// Elements already made, holding their bytes from now on (the builtin or expression that
    /// made them checked them beforehand, or they are small).
    pub fn new(items: Vec<Value>) -> Elements {
        let owned = items.iter().map(owned_bytes).sum();
        let held = crate::engine::budget::hold(storage_bytes(items.capacity(), owned));
        Elements { items, owned, held }
    }

    /// Appends `value`. When the storage is full it doubles (from 4 slots), as the standard
    /// library's own growth does but explicitly, so what is charged is what is allocated. The
    /// new storage is filled while the old one is still held (a reallocation may copy), so
    /// the whole new storage, its new slots taken as filled with values like this one, must
    /// fit beside what is held and the live field graphs first.
    pub fn push(&mut self, value: Value) -> Outcome<()> {
        let owned = owned_bytes(&value);
        if self.items.len() == self.items.capacity() {
            let capacity = (2 * self.items.capacity()).max(4);
            let more = (capacity * SLOT_BYTES) as f64
                + (capacity - self.items.len()) as f64 * owned as f64;
            let what = format!("an array of {} elements", self.items.len() + 1);
            crate::field::node::check_beside_graphs(0.0, more, &what)?;
            self.items.reserve_exact(capacity - self.items.len());
        }
        self.items.push(value);
        self.owned += owned;
        self.recharge();
        Ok(())
    }

    /// Changes element `index` (which exists) through `change`, keeping the charge for what
    /// the element owns up to date.
    pub fn update<R>(&mut self, index: usize, change: impl FnOnce(&mut Value) -> R) -> R {
        let item = &mut self.items[index];
        let before = owned_bytes(item);
        let result = change(item);
        self.owned = self.owned - before + owned_bytes(item);
        self.recharge();
        result
    }

    /// The bytes held: the slots at the storage's capacity and what the elements own.
    pub fn bytes(&self) -> u64 {
        self.held.bytes()
    }

    fn recharge(&mut self) {
        self.held
            .resize(storage_bytes(self.items.capacity(), self.owned));
    }
}

impl Deref for Elements {
    type Target = [Value];

    fn deref(&self) -> &[Value] {
        &self.items
    }
}

/// A copy holds its own bytes (arrays are copied on write: `Rc::make_mut`); the writer checks
/// the copy's size before it is made (`copy_bytes`).
impl Clone for Elements {
    fn clone(&self) -> Elements {
        Elements::new(self.items.clone())
    }
}

impl Elements {
    /// What a copy of these elements will hold (its storage is exactly as long as they are).
    pub fn copy_bytes(&self) -> f64 {
        storage_bytes(self.items.len(), self.owned) as f64
    }
}

/// Checks, before a builtin builds it, that an array of `len` elements each owning `owned`
/// bytes (`owned_bytes`) fits beside what is held and the live field graphs.
pub fn check_array(len: usize, owned: u64, what: &str) -> Outcome<()> {
    let bytes = len as f64 * (SLOT_BYTES as u64 + owned) as f64;
    crate::field::node::check_beside_graphs(0.0, bytes, what)
}

fn storage_bytes(capacity: usize, owned: u64) -> u64 {
    (capacity * SLOT_BYTES) as u64 + owned
}

/// The heap a value owns outside its slot and outside what is counted elsewhere: a field's
/// block of component node handles, a string's text, a nested array's block (its elements
/// hold their own charge). Grids, meshes and particles are counted where they are made; the
/// nodes a field points to, by the node table.
pub fn owned_bytes(value: &Value) -> u64 {
    let handle = std::mem::size_of::<usize>();
    // An `Rc`/`Arc` block: its two counts, then the contents.
    let counted = |contents: usize| heap_block(2 * handle + contents);
    match value {
        Value::Field(field) => counted(field.components().len() * handle),
        Value::Str(text) => counted(text.len()),
        Value::Array(..) => counted(std::mem::size_of::<Elements>()),
        _ => 0,
    }
}

/// What the allocator takes for a request of `bytes`: glibc's malloc adds an 8-byte header and
/// rounds to 16, 32 bytes at least.
fn heap_block(bytes: usize) -> u64 {
    ((bytes + 8).div_ceil(16) * 16).max(32) as u64
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::Field;

    /// What an array holds is what its storage takes: the slots at the capacity the vector
    /// reports, and the blocks its fields own, given back when it is dropped.
    #[test]
    fn an_array_holds_its_slots_and_its_fields_blocks_until_dropped() {
        // A budget no other test's live field graphs (which growth is checked beside) fill.
        let engine = crate::engine::Engine::with_memory_limit(1 << 50);
        let _entered = engine.enter();
        let before = crate::engine::budget::used();
        let mut items = Elements::new(Vec::new());
        let mut grown = 0;
        for i in 0..1000 {
            let capacity = items.items.capacity();
            items
                .push(Value::Field(Field::constant_scalar(i as f64)))
                .unwrap();
            if items.items.capacity() != capacity {
                grown += 1;
            }
            // A scalar field's block: two counts and one node handle, 24 bytes, which
            // glibc's malloc serves from a 32-byte chunk.
            let expected = items.items.capacity() * SLOT_BYTES + (i + 1) * 32;
            assert_eq!(items.bytes(), expected as u64, "at {i} elements");
            assert_eq!(crate::engine::budget::used() - before, expected as u64);
        }
        // 4, 8, ..., 1024: nine growths.
        assert_eq!(grown, 9);
        assert_eq!(items.items.capacity(), 1024);
        let copy = items.clone();
        assert_eq!(copy.bytes() as f64, items.copy_bytes());
        assert_eq!(copy.bytes(), (1000 * SLOT_BYTES + 1000 * 32) as u64);
        items.update(3, |v| *v = Value::Float(1.0));
        assert_eq!(items.bytes(), (1024 * SLOT_BYTES + 999 * 32) as u64);
        drop(items);
        drop(copy);
        assert_eq!(crate::engine::budget::used(), before);
    }

    #[test]
    fn owned_blocks_are_what_the_allocator_takes() {
        // A vector field's three handles: 16 + 24 = 40 bytes, a 48-byte chunk; a matrix
        // field's nine: 16 + 72 = 88, a 96-byte chunk.
        let vector = Value::Field(Field::constant_vector(glam::DVec3::ONE));
        let matrix = Value::Field(Field::constant_matrix(glam::DMat3::IDENTITY));
        assert_eq!(owned_bytes(&vector), 48);
        assert_eq!(owned_bytes(&matrix), 96);
        assert_eq!(owned_bytes(&Value::string("")), 32);
        assert_eq!(owned_bytes(&Value::string(&"x".repeat(100))), 128);
        assert_eq!(owned_bytes(&Value::Float(1.0)), 0);
        // The rounding, asked of the allocator itself: a chunk is its usable size and its
        // 8-byte header. A busy allocator (other tests run beside this one) may hand out a
        // larger free chunk than a request needs, never a smaller one; most requests get the
        // smallest that fits.
        #[cfg(all(target_os = "linux", target_env = "gnu"))]
        {
            let mut exact = 0;
            for request in 1..300 {
                // SAFETY: the block is only measured and freed.
                let chunk = unsafe {
                    let block = libc::malloc(request);
                    assert!(!block.is_null());
                    let usable = libc::malloc_usable_size(block);
                    libc::free(block);
                    usable as u64 + 8
                };
                assert!(
                    heap_block(request) <= chunk,
                    "a request of {request} bytes took a {chunk}-byte chunk"
                );
                exact += usize::from(heap_block(request) == chunk);
            }
            assert!(
                exact > 150,
                "only {exact} of 299 requests took the predicted chunk"
            );
        }
    }
}
