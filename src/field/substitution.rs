//! Substitution: a graph with its position leaves x, y, z replaced by other nodes (a warp),
//! which is how `compose`, `advect` and the warps are made. The composed field is an ordinary
//! graph, so it is differentiated and compiled like any other.
//!
//! The one key decision: what substituting a warp made is remembered, per warp, from one call
//! to the next. A chain of advections (`f = advect(f, u, dt)` in a loop) substitutes the same
//! back trace, step after step, into a graph that has grown by one layer since the step
//! before. Hash-consing makes the result the old graph with one more layer, but finding that
//! out walked the whole graph, so n steps cost n² node visits and 5,000 RK4 steps never
//! finished building. With the earlier results at hand, the walk stops at every node the warp
//! has already been substituted into, and a step costs only its new nodes. Results are held
//! weakly, as in the hash-consing table, so remembering keeps no graph alive; a result that
//! has since been dropped is made again.

use super::node::{self, Node, NodeRef, Op};
use std::cell::RefCell;
use std::collections::HashMap;
use std::sync::{Arc, Weak};

/// How many warps' results are remembered, the most recently used: an advection step uses
/// one (its back trace) and a Runge–Kutta trace one per stage, an error-correcting scheme and
/// its clamp a handful more.
const WARPS_REMEMBERED: usize = 16;

/// Entries one warp's memo holds before the first sweep of the dead ones.
const FIRST_SWEEP: usize = 1 << 16;

/// What substituting one warp has made: the id of each node substituted into, and the node it
/// became.
struct Memo {
    /// The ids of the warp's three nodes. Hash-consing gives a warp that is built again (each
    /// step builds its back trace anew) the same nodes, and a node that was dropped meanwhile
    /// its old id (see `node::intern`), so the same warp finds its memo.
    warp: [u64; 3],
    made: HashMap<u64, Weak<Node>>,
    /// Size at which entries whose result has been dropped are next swept out.
    sweep_at: usize,
}

thread_local! {
    /// The memos of the warps this thread used last, least recently used first. Graphs are
    /// built by the thread that runs the script, so one list per thread is one per script,
    /// and needs no lock.
    static MEMOS: RefCell<Vec<Memo>> = const { RefCell::new(Vec::new()) };
}

/// The memo of `warp`, taken out of the list while a substitution uses it.
fn take_memo(warp: [u64; 3]) -> Memo {
    MEMOS.with_borrow_mut(|memos| match memos.iter().position(|m| m.warp == warp) {
        Some(i) => memos.remove(i),
        None => Memo {
            warp,
            made: HashMap::new(),
            sweep_at: FIRST_SWEEP,
        },
    })
}

/// Puts a memo back as the most recently used, forgetting the least recently used beyond
/// `WARPS_REMEMBERED`.
fn put_back(mut memo: Memo) {
    if memo.made.len() >= memo.sweep_at {
        memo.made.retain(|_, made| made.strong_count() > 0);
        memo.sweep_at = (memo.made.len() * 2).max(FIRST_SWEEP);
    }
    MEMOS.with_borrow_mut(|memos| {
        memos.push(memo);
        if memos.len() > WARPS_REMEMBERED {
            memos.remove(0);
        }
    });
}

/// `roots` with the position leaves x, y, z replaced by `at[0..3]`. Visits only the nodes that
/// this warp has not been substituted into before (or whose result has been dropped since),
/// children before parents, iteratively, so graphs thousands of nodes deep are fine.
pub fn substitute(roots: &[NodeRef], at: &[NodeRef; 3]) -> Vec<NodeRef> {
    let mut memo = take_memo(std::array::from_fn(|i| at[i].id));
    let mut made: HashMap<u64, NodeRef> = HashMap::new();
    let mut stack: Vec<(&NodeRef, bool)> = roots.iter().rev().map(|r| (r, false)).collect();
    while let Some((n, expanded)) = stack.pop() {
        if expanded {
            #[cfg(test)]
            VISITS.with(|v| v.set(v.get() + 1));
            let get = |c: &NodeRef| made[&c.id].clone();
            let new = match &n.op {
                Op::Const(_) => n.clone(),
                Op::X => at[0].clone(),
                Op::Y => at[1].clone(),
                Op::Z => at[2].clone(),
                Op::Unary(m, a) => node::unary(*m, get(a)),
                Op::Binary(b, x, y) => node::binary(*b, get(x), get(y)),
                Op::Select(c, a, b) => node::select(get(c), get(a), get(b)),
                Op::Kernel(k, args) => {
                    node::mk(Op::Kernel(k.clone(), args.iter().map(get).collect()))
                }
                Op::Output(k, i) => node::output_of(&get(k), *i as usize),
            };
            memo.made.insert(n.id, Arc::downgrade(&new));
            made.insert(n.id, new);
            continue;
        }
        if made.contains_key(&n.id) {
            continue;
        }
        if let Some(known) = memo.made.get(&n.id).and_then(Weak::upgrade) {
            made.insert(n.id, known);
            continue;
        }
        stack.push((n, true));
        for child in n.children().into_iter().rev() {
            if !made.contains_key(&child.id) {
                stack.push((child, false));
            }
        }
    }
    let result = roots.iter().map(|r| made[&r.id].clone()).collect();
    put_back(memo);
    result
}

/// Nodes substituted into on this thread so far: what substitutions have cost, for the tests
/// that a chain of warps is built in linear time.
#[cfg(test)]
pub fn visits() -> usize {
    VISITS.with(|v| v.get())
}

#[cfg(test)]
thread_local! {
    static VISITS: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}
