//! The deeper update that the paper's section 5 proposes: below the
//! enclosing node of Algorithm 1, descend further and keep every subtree the
//! moved geometry does not touch; rebuild only the touched ones.
//!
//! At a node, each moved triangle (in its new state) is routed to the child
//! whose interval contains its box (when both do, to the side of the middle
//! between the two clip planes its center lies on). A child that neither
//! held a moved triangle nor receives one is *kept*. The descent stops, and
//! the node is rebuilt over its unmoved triangles plus those routed to it,
//! at a leaf, at a node of at most [`Updater::deep_stop_below`] triangles,
//! or where a moved triangle fits in neither child's interval. The kept
//! subtrees' clip planes stay as they were, so every triangle still lies
//! within its ancestors' planes.
//!
//! The index bookkeeping the paper warns of: moved triangles leave one
//! subtree's range of the triangle order and join another's, so the ranges
//! between them shift. Within the enclosing node's interval (the count there
//! is unchanged) the pieces are laid out again in tree order: a kept
//! subtree's range is copied to its new place and its leaves' first slots
//! are adjusted; a rebuilt subtree is written where its range now starts.

use super::{
    Array, Enclosing, Piece, PpeMemory, PpeWork, UpdateError, UpdateReport, Updater, interval,
};
use crate::aabb::Aabb;
use crate::bih::BihNode;

/// The plan for one subtree below the enclosing node; `P` is what a
/// rebuilt subtree becomes: its new subtree, built while planning (so that
/// a builder's error comes before the tree is touched), or in a dry plan
/// ([`pieces`]) only its size.
enum Plan<P> {
    /// Kept as it is; its triangles were at slots `first .. end`.
    Keep { node: u32, first: usize, end: usize },
    /// Rebuilt.
    Rebuild { node: u32, piece: P },
    /// The node kept, its children updated.
    Inner(Box<Plan<P>>, Box<Plan<P>>),
}

/// Brings the subtree of `enc.node`, whose interval is `first .. end` and
/// whose moved triangles sit at `moved_slots`, up to date.
pub(super) fn update(
    up: &mut Updater,
    enc: &Enclosing,
    (first, end): (usize, usize),
    moved_slots: &[usize],
    r: &mut UpdateReport,
) -> Result<(), UpdateError> {
    let plan = plan(
        up,
        span(enc, first, end),
        moved_slots,
        moved_in(up, moved_slots),
        &mut |s, ids| up.build_subtree(&ids, s.region, s.depth),
        &mut r.ppe_find,
    )?;
    r.ppe_find.loads += up.ppe_memory.take();
    let old = up.bih.prim_ids[first..end].to_vec();
    r.ppe_apply.ids_copied += old.len() as u64;
    let mut pos = first;
    lay_out(up, plan, &old, first, &mut pos, r);
    debug_assert_eq!(pos, end, "the interval's size changed");
    Ok(())
}

/// The sizes of the subtrees the deep update of `enc.node` (interval
/// `first .. end`, moved triangles at `moved_slots`) would rebuild, in tree
/// order: the same descent and routing as [`update`], nothing built; the
/// descent's PPE work is counted into `work`.
pub(super) fn pieces(
    up: &Updater,
    enc: &Enclosing,
    (first, end): (usize, usize),
    moved_slots: &[usize],
    work: &mut PpeWork,
) -> Vec<usize> {
    let plan = plan(
        up,
        span(enc, first, end),
        moved_slots,
        moved_in(up, moved_slots),
        &mut |_, ids| Ok::<_, UpdateError>(ids.len()),
        work,
    );
    let mut sizes = Vec::new();
    collect(&plan.expect("counting never fails"), &mut sizes);
    sizes
}

fn collect(plan: &Plan<usize>, sizes: &mut Vec<usize>) {
    match plan {
        Plan::Keep { .. } => {}
        Plan::Rebuild { piece, .. } => sizes.push(*piece),
        Plan::Inner(l, r) => {
            collect(l, sizes);
            collect(r, sizes);
        }
    }
}

fn span(enc: &Enclosing, first: usize, end: usize) -> Span {
    Span {
        node: enc.node,
        region: enc.region,
        first,
        end,
        depth: enc.depth,
    }
}

fn moved_in(up: &Updater, moved_slots: &[usize]) -> Vec<u32> {
    moved_slots.iter().map(|&s| up.bih.prim_ids[s]).collect()
}

#[derive(Clone, Copy)]
struct Span {
    node: u32,
    region: Aabb,
    first: usize,
    end: usize,
    depth: u32,
}

/// Plans the subtree `s`: `moved_slots` are the slots in it that hold moved
/// triangles (sorted), `moved_in` the moved triangles routed to it;
/// `rebuild` makes a rebuilt subtree of its span and triangle ids; the
/// PPE's work of the descent is counted into `work`.
fn plan<P>(
    up: &Updater,
    s: Span,
    moved_slots: &[usize],
    moved_in: Vec<u32>,
    rebuild: &mut impl FnMut(Span, Vec<u32>) -> Result<P, UpdateError>,
    work: &mut PpeWork,
) -> Result<Plan<P>, UpdateError> {
    if moved_slots.is_empty() && moved_in.is_empty() {
        return Ok(Plan::Keep {
            node: s.node,
            first: s.first,
            end: s.end,
        });
    }
    let node = up.bih.nodes[s.node as usize];
    work.nodes_visited += 1;
    up.ppe_memory.load(Array::Nodes, s.node as u64);
    let size = s.end - s.first - moved_slots.len() + moved_in.len();
    if node.is_leaf() || size <= up.deep_stop_below {
        return rebuilt(up, s, moved_slots, moved_in, rebuild);
    }
    let a = node.axis();
    let [cl, cr] = node.clip();
    let (mut lr, mut rr) = (s.region, s.region);
    lr.max[a] = lr.max[a].min(cl);
    rr.min[a] = rr.min[a].max(cr);
    let middle = cl * 0.5 + cr * 0.5;
    let (mut to_left, mut to_right) = (Vec::new(), Vec::new());
    work.routed += moved_in.len() as u64;
    for &id in &moved_in {
        up.ppe_memory.load(Array::Triangles, id as u64);
        let b = up.scene.triangles[id as usize].bounds();
        let left = match (lr.contains_box(&b), rr.contains_box(&b)) {
            (true, false) => true,
            (false, true) => false,
            (true, true) => b.center()[a] <= middle,
            (false, false) => return rebuilt(up, s, moved_slots, moved_in, rebuild),
        };
        if left { &mut to_left } else { &mut to_right }.push(id);
    }
    let c = node.left_child();
    let (lf, mid) = interval(&up.bih, c);
    debug_assert_eq!((lf, interval(&up.bih, c + 1)), (s.first, (mid, s.end)));
    let k = moved_slots.partition_point(|&slot| slot < mid);
    let child = |node, region, first, end| Span {
        node,
        region,
        first,
        end,
        depth: s.depth + 1,
    };
    Ok(Plan::Inner(
        Box::new(plan(
            up,
            child(c, lr, s.first, mid),
            &moved_slots[..k],
            to_left,
            rebuild,
            work,
        )?),
        Box::new(plan(
            up,
            child(c + 1, rr, mid, s.end),
            &moved_slots[k..],
            to_right,
            rebuild,
            work,
        )?),
    ))
}

/// The subtree `s` rebuilt over its unmoved triangles and `moved_in`.
fn rebuilt<P>(
    up: &Updater,
    s: Span,
    moved_slots: &[usize],
    moved_in: Vec<u32>,
    rebuild: &mut impl FnMut(Span, Vec<u32>) -> Result<P, UpdateError>,
) -> Result<Plan<P>, UpdateError> {
    let mut ids = Vec::with_capacity(s.end - s.first - moved_slots.len() + moved_in.len());
    let mut k = 0;
    for slot in s.first..s.end {
        if moved_slots.get(k) == Some(&slot) {
            k += 1;
        } else {
            ids.push(up.bih.prim_ids[slot]);
        }
    }
    ids.extend(moved_in);
    Ok(Plan::Rebuild {
        node: s.node,
        piece: rebuild(s, ids)?,
    })
}

/// Carries out `plan`, its triangles from slot `*pos` on; `old` holds the
/// interval's triangle order as it was, from slot `base`.
fn lay_out(
    up: &mut Updater,
    plan: Plan<Piece>,
    old: &[u32],
    base: usize,
    pos: &mut usize,
    r: &mut UpdateReport,
) {
    match plan {
        Plan::Keep { node, first, end } => {
            let len = end - first;
            if *pos != first {
                up.bih.prim_ids[*pos..*pos + len].copy_from_slice(&old[first - base..end - base]);
                let delta = *pos as i64 - first as i64;
                let (leaves, nodes) = shift_leaves(&mut up.bih.nodes, node, delta, &up.ppe_memory);
                r.leaves_adjusted += leaves;
                r.moved_slots += len;
                r.ppe_apply += PpeWork {
                    nodes_written: nodes,
                    ids_copied: len as u64,
                    ..PpeWork::default()
                };
            }
            r.kept += len;
            *pos += len;
        }
        Plan::Rebuild { node, piece } => {
            // The piece's ids were gathered for its build, then are
            // written in place.
            r.ppe_apply.ids_copied += piece.bih.prim_ids.len() as u64;
            up.install(node, *pos, &piece, r);
            *pos += piece.bih.prim_ids.len();
        }
        Plan::Inner(left, right) => {
            lay_out(up, *left, old, base, pos, r);
            lay_out(up, *right, old, base, pos, r);
        }
    }
}

/// Adds `delta` to the first slot of every leaf below `node`; returns how
/// many leaves there were and how many nodes were visited (each node
/// read and written through the PPE's caches, `mem`).
fn shift_leaves(nodes: &mut [BihNode], node: u32, delta: i64, mem: &PpeMemory) -> (usize, u64) {
    let (mut stack, mut leaves, mut visited) = (vec![node], 0, 0);
    while let Some(id) = stack.pop() {
        visited += 1;
        mem.load(Array::Nodes, id as u64);
        mem.store(Array::Nodes, id as u64);
        let n = nodes[id as usize];
        if n.is_leaf() {
            let (f, c) = n.leaf_range();
            nodes[id as usize] = BihNode::leaf((f as i64 + delta) as u32, c);
            leaves += 1;
        } else {
            stack.extend([n.left_child(), n.left_child() + 1]);
        }
    }
    (leaves, visited)
}
