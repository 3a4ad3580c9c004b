//! Hash-consing: the one table through which every node is made, so that the same operation on
//! the same children is always the same node.
//!
//! The one key decision: the table holds weak references, keyed by the operation and its
//! children's ids, so it never keeps a graph alive; dead entries are swept out when the table
//! has doubled since the last sweep. Until then an entry also keeps its node's id, and a node
//! that was dropped and is made again gets that id back: ids name structures, not
//! allocations, so what is remembered by id (substitution's memo) survives a graph that a
//! script drops and rebuilds every step, such as a back trace whose z component nothing kept.
//!
//! The table is process-wide on purpose, unlike a run's budget, profile and interrupt flag
//! (`crate::engine`): a node is a value, not a resource of one run. Equal structure is the same
//! node whichever session built it (sessions may share graphs), the table holds only weak
//! references so it keeps nothing of any session alive, and the memory graphs take is checked
//! against the budget of the engine current where they are built (`check_graph_memory`).
//!
//! Building a tower of derivatives is mostly lookups in this table, so a key is made without
//! a heap block (up to three children inline) and hashed with foldhash rather than SipHash:
//! the keys are ids the process made itself, nothing an adversary chooses, and nothing
//! iterates the table in an order that reaches output.

use super::{Node, NodeRef, Op};
use std::collections::HashMap;
use std::collections::hash_map::Entry::{Occupied, Vacant};
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, LazyLock, Mutex, Weak};

/// The hasher of maps keyed by node ids or by node keys (see the module's paragraph).
pub type IdHasher = foldhash::fast::FixedState;

/// The identity of an operation on identified children: up to three children's ids inline
/// (every operation but a kernel of more arguments), the rest in `more`.
#[derive(PartialEq, Eq, Hash)]
struct Key {
    tag: u8,
    payload: u64,
    children: [u64; 3],
    more: Box<[u64]>,
}

fn key_of(op: &Op) -> Key {
    let key = |tag: u8, payload: u64, ids: &[u64]| {
        let mut children = [0; 3];
        let inline = ids.len().min(3);
        children[..inline].copy_from_slice(&ids[..inline]);
        Key {
            tag,
            payload,
            children,
            more: ids[inline..].into(),
        }
    };
    match op {
        // Constants are keyed by bits, so 0.0 and -0.0 stay distinct.
        Op::Const(c) => key(0, c.to_bits(), &[]),
        Op::X => key(1, 0, &[]),
        Op::Y => key(2, 0, &[]),
        Op::Z => key(3, 0, &[]),
        Op::Unary(m, a) => key(4, *m as u64, &[a.id]),
        Op::Binary(b, x, y) => key(5, *b as u64, &[x.id, y.id]),
        Op::Select(c, a, b) => key(6, 0, &[c.id, a.id, b.id]),
        Op::Kernel(k, args) => {
            // Ids start at 1, so the zeros that pad a kernel of fewer than three arguments
            // name no node. The kernel enters by its derived hash; `intern` confirms a match
            // with its derived equality and moves on where two hashes collide.
            let ids: Vec<u64> = args.iter().map(|a| a.id).collect();
            key(7, k.identity_hash(), &ids)
        }
        Op::Output(k, i) => key(8, *i as u64, &[k.id]),
    }
}

/// A node made through the table, and its id, kept after the node is dropped.
struct Entry {
    id: u64,
    node: Weak<Node>,
}

struct Table {
    nodes: HashMap<Key, Entry, IdHasher>,
    /// Size at which dead entries are next swept out.
    sweep_at: usize,
}

static TABLE: LazyLock<Mutex<Table>> = LazyLock::new(|| {
    Mutex::new(Table {
        nodes: HashMap::default(),
        sweep_at: 1 << 16,
    })
});
static NEXT_ID: AtomicU64 = AtomicU64::new(1);
/// `TABLE`'s length, readable without its lock (for the memory budget's frequent checks).
static LENGTH: AtomicUsize = AtomicUsize::new(0);

/// What one node costs in memory with its table entry: the node and its `Arc` counts, the
/// key with its children inline, the entry and the map's own slot,
/// each heap block with malloc's 16-byte header; and the 64 bytes a derivative's working
/// maps take per node it visits. Measured against peak RSS: a tower of nested `laplacian`s
/// under a 100 MiB budget peaked at 160 MiB above the process's baseline with 144 bytes
/// charged per node (728,615 nodes), 230 bytes each.
const NODE_BYTES: usize = std::mem::size_of::<Node>()
    + 2 * std::mem::size_of::<usize>()
    + 16
    + std::mem::size_of::<Key>()
    + std::mem::size_of::<Entry>()
    + 16
    + 64;

/// The unique node for `op`, made if it does not exist yet. No simplification.
pub(super) fn intern(op: Op) -> NodeRef {
    let mut key = key_of(&op);
    // A poisoned table only means another thread panicked while holding it; the map itself is
    // still consistent (entries are inserted whole), so keep using it.
    let mut table = TABLE.lock().unwrap_or_else(|e| e.into_inner());
    // A kernel enters by a hash of its fields: where a different live kernel holds that key,
    // it moves on to the next, so two kernels are one node exactly when they are equal.
    if let Op::Kernel(kernel, _) = &op {
        while let Some(found) = table.nodes.get(&key).and_then(|e| e.node.upgrade()) {
            match &found.op {
                Op::Kernel(other, _) if !other.same(kernel.as_ref()) => {
                    key.payload = key.payload.wrapping_add(1)
                }
                _ => return found,
            }
        }
    }
    let node = match table.nodes.entry(key) {
        Occupied(mut entry) => {
            if let Some(node) = entry.get().node.upgrade() {
                return node;
            }
            let node = Arc::new(Node {
                id: entry.get().id,
                op,
            });
            entry.get_mut().node = Arc::downgrade(&node);
            node
        }
        Vacant(entry) => {
            let node = Arc::new(Node {
                id: NEXT_ID.fetch_add(1, Ordering::Relaxed),
                op,
            });
            entry.insert(Entry {
                id: node.id,
                node: Arc::downgrade(&node),
            });
            node
        }
    };
    if table.nodes.len() >= table.sweep_at {
        table.nodes.retain(|_, entry| entry.node.strong_count() > 0);
        table.sweep_at = (table.nodes.len() * 2).max(1 << 16);
    }
    LENGTH.store(table.nodes.len(), Ordering::Relaxed);
    node
}

/// Checks that the field graphs built so far fit in what is left of the memory budget. Cheap
/// (one atomic read) unless they seem not to, when dead entries are swept out first.
pub fn check_graph_memory() -> crate::base::failure::Outcome<()> {
    check_nodes(0.0, |live| format!("field graphs of {live} nodes")).map_err(|f| {
        f.with_help(
            "the script's fields have grown to more nodes than the budget holds: each nested \
             derivative (grad, laplacian, div, curl) multiplies a field's graph several times, \
             and each knife of `cutall` doubles its sides; differentiate fewer times (or cache \
             the field on a grid first), cut with fewer knives (`cutpieces` keeps only the \
             pieces that occur), or raise the budget with --memory-limit MB",
        )
    })
}

/// Checks that `nodes` nodes yet to be made and `bytes` of other storage (an array's) fit
/// beside the live graphs in what is left of the budget: graphs and arrays of fields grow
/// together, and each alone fitting says nothing of both. `what` names the request.
pub fn check_beside_graphs(
    nodes: f64,
    bytes: f64,
    what: &str,
) -> crate::base::failure::Outcome<()> {
    check_nodes_and(nodes, bytes, |live| match live {
        0 => what.to_string(),
        live => format!("{what}, beside field graphs of {live} nodes,"),
    })
}

/// What a node costs in the budget (`NODE_BYTES`), for projections of graphs yet to be made.
pub fn node_bytes() -> f64 {
    NODE_BYTES as f64
}

/// Checks that the live nodes and `more` nodes yet to be made fit in what is left of the
/// budget; `what` names them, given the live count.
fn check_nodes(more: f64, what: impl Fn(usize) -> String) -> crate::base::failure::Outcome<()> {
    check_nodes_and(more, 0.0, what)
}

/// `check_nodes` with `other` bytes besides the nodes.
fn check_nodes_and(
    more: f64,
    other: f64,
    what: impl Fn(usize) -> String,
) -> crate::base::failure::Outcome<()> {
    let bytes = |count: usize| (count as f64 + more) * NODE_BYTES as f64 + other;
    let fits = |count: usize| {
        bytes(count) + crate::engine::budget::used() as f64 <= crate::engine::budget::limit() as f64
    };
    if fits(LENGTH.load(Ordering::Relaxed)) {
        return Ok(());
    }
    let live = {
        let mut table = TABLE.lock().unwrap_or_else(|e| e.into_inner());
        table.nodes.retain(|_, entry| entry.node.strong_count() > 0);
        LENGTH.store(table.nodes.len(), Ordering::Relaxed);
        table.nodes.len()
    };
    crate::engine::budget::check(bytes(live), &what(live))
}

/// How many nodes the table has made so far (a running count, never lowered by sweeps): the
/// difference of two readings is what the code between them made.
pub fn nodes_made() -> u64 {
    NEXT_ID.load(Ordering::Relaxed)
}

/// A derivative pass over a graph of `total` nodes that has visited `done` of them and made
/// `made` nodes meanwhile, followed or not by the divergence of what it returns (a
/// `laplacian` is the divergence of a gradient): refused now when, going on at that rate,
/// the nodes it and the divergence would make do not fit in what is left of the budget.
///
/// A pass along three axes makes `r` new nodes per node it visits, `r·total` in all. The
/// divergence that follows takes each of the three results along its own axis only: it
/// visits about `total·(1 + r/3)` nodes per component (the graph and that component's share
/// of the new nodes) at a third of the rate, so it makes about `r·total·(1 + r/3)`. A tower
/// of nested derivatives grows severalfold per level, and building the last level only to
/// find at its end that it does not fit took most of a minute under a budget of gigabytes.
/// The rate is measured only after a sixteenth of the pass (and 16,384 nodes), so a small or
/// lopsided start does not decide.
pub fn check_projected_growth(
    made: u64,
    done: usize,
    total: usize,
    then_divergence: bool,
) -> crate::base::failure::Outcome<()> {
    if done < 16_384 || done < total / 16 || done >= total {
        return Ok(());
    }
    let rate = made as f64 / done as f64;
    let divergence = if then_divergence {
        rate * total as f64 * (1.0 + rate / 3.0)
    } else {
        0.0
    };
    let all = rate * total as f64 + divergence;
    let projected = (all - made as f64).max(0.0).round();
    check_nodes(projected, |live| {
        format!(
            "a derivative of a field of {total} nodes (at the rate of its first {done}, about \
             {projected} nodes more than the {live} that exist)"
        )
    })
    .map_err(|f| {
        f.with_help(
            "each nested derivative (grad, laplacian, div, curl) multiplies a field's graph \
             several times over, so a few levels of them outgrow any budget: differentiate \
             fewer times, cache the field on a grid (cachewrite) and differentiate the cache \
             read, or raise the budget with --memory-limit MB",
        )
    })
}

/// Entries in the hash-consing table: every live node, plus dead ones not yet swept. A cheap
/// upper bound on the size of any one graph.
pub fn table_len() -> usize {
    TABLE.lock().unwrap_or_else(|e| e.into_inner()).nodes.len()
}
