//! The SAH-optimal collapse of the binary tree into 8-wide nodes: which binary nodes become
//! wide nodes, which become leaves (one binary leaf, or a subtree whose triangles fill at most
//! [`TestCosts::max_leaf_packets`] packets, merged into one leaf) and which are opened into their parent's
//! slots, chosen by dynamic programming over the binary tree to minimise the surface-area
//! cost of the wide tree (Ylitie, Karras and Laine, "Efficient incoherent ray traversal on GPUs
//! through compressed wide BVHs", HPG 2017, §4.1, eqs. 1–3; they build a binary tree to one
//! primitive a leaf and let the collapse choose the leaves, as here down to one packet).
//!
//! For a binary node n and a number of slots i = 1…8, C(n, i) is the least cost of standing
//! for n's subtree by at most i roots in the parent's slots:
//!
//! - C(n, 1) = min(C_leaf(n), C_node(n)), with C_leaf(n) = A(n)·c_packet·packets(n) (if n's
//!   triangles fill at most [`TestCosts::max_leaf_packets`] packets) and C_node(n) = A(n)·c_node +
//!   C_distribute(n, 8);
//! - C(n, i) = min(C_distribute(n, i), C(n, i − 1)) for i > 1;
//! - C_distribute(n, j) = min over 0 < k < j of C(left, k) + C(right, j − k);
//! - a binary leaf: C(n, i) = C_leaf(n) for every i.
//!
//! A(n) is n's surface area (half of it: only ratios matter), the probability that a ray which
//! meets the parent meets n (MacDonald and Booth 1990). The costs c_node (one 8-wide node test)
//! and c_packet (one 8-triangle packet test) are [`TestCosts`]' (measured on this query).
//!
//! The greedy collapse it replaces (open the child of largest area until eight; Wald, Benthin
//! and Boulos 2008) left the l-room-100k tree's nodes 3.8 children full on average, so a query
//! tested more nodes than the tree's 14,039 leaves need (docs/bvh.md, "Wide nodes by cost").

use super::{packets, Binary};

/// Slots of a wide node.
const WIDTH: usize = 8;
/// Packets a leaf may hold at most: a leaf reference keeps packets − 1 in two bits
/// (`bvh::LEAF`).
pub const LEAF_PACKETS_LIMIT: usize = 4;

/// The collapse's costs: what a node test and a packet test cost a query, and how many packets
/// a leaf may hold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TestCosts {
    /// Cost of one 8-wide node test (any unit: only the ratio to `packet_test` matters).
    pub node_test: f32,
    /// Cost of one 8-triangle packet test.
    pub packet_test: f32,
    /// Packets a leaf may hold, 1 to [`LEAF_PACKETS_LIMIT`].
    pub max_leaf_packets: usize,
}

impl TestCosts {
    /// Measured on the sound tracer's query (docs/bvh.md, "Wide nodes by cost"): trees that
    /// trade node tests for as many packet tests run the dependent chain in the same time, so a
    /// node test costs a packet test. Leaves of one packet: merged leaves (up to four packets)
    /// showed no gain in the bake and give the walk's leaf loop a trip count that varies.
    pub const MEASURED: TestCosts = TestCosts { node_test: 1.0, packet_test: 1.0, max_leaf_packets: 1 };
}

/// How a binary node stands for its subtree with i slots (index i − 1).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Choice {
    /// One leaf holding the whole subtree's triangles.
    Leaf,
    /// One wide node over the subtree.
    Node,
    /// The left child gets this many slots, the right the rest.
    Split(u8),
    /// As with one slot fewer.
    Fewer,
}

/// The cost table of one binary node and its children's.
pub(super) struct Plan {
    cost: [f32; WIDTH],
    choice: [Choice; WIDTH],
    children: Option<Box<[Plan; 2]>>,
}

/// The cost tables of the whole binary tree, bottom up.
pub(super) fn plan(node: &Binary, c: &TestCosts) -> Plan {
    let area = node.bounds().half_area();
    match node {
        Binary::Leaf { start, end, .. } => {
            let leaf = area * c.packet_test * packets(end - start);
            Plan { cost: [leaf; WIDTH], choice: [Choice::Leaf; WIDTH], children: None }
        }
        Binary::Inner { children, .. } => {
            let (l, r) = if triangles(node) >= 4096 {
                rayon::join(|| plan(&children[0], c), || plan(&children[1], c))
            } else {
                (plan(&children[0], c), plan(&children[1], c))
            };
            // C_distribute(n, j) for j = 2…8 and the best k for each.
            let mut dist = [(f32::INFINITY, 0u8); WIDTH + 1];
            for (j, d) in dist.iter_mut().enumerate().skip(2) {
                for k in 1..j {
                    let sum = l.cost[k - 1] + r.cost[j - k - 1];
                    if sum < d.0 {
                        *d = (sum, k as u8);
                    }
                }
            }
            let n_packets = packets(triangles(node));
            let as_leaf = if n_packets <= c.max_leaf_packets as f32 { area * c.packet_test * n_packets } else { f32::INFINITY };
            let as_node = area * c.node_test + dist[WIDTH].0;
            let mut cost = [0.0; WIDTH];
            let mut choice = [Choice::Node; WIDTH];
            (cost[0], choice[0]) = if as_leaf <= as_node { (as_leaf, Choice::Leaf) } else { (as_node, Choice::Node) };
            for i in 2..=WIDTH {
                (cost[i - 1], choice[i - 1]) = if dist[i].0 < cost[i - 2] {
                    (dist[i].0, Choice::Split(dist[i].1))
                } else {
                    (cost[i - 2], Choice::Fewer)
                };
            }
            Plan { cost, choice, children: Some(Box::new([l, r])) }
        }
    }
}

/// Triangles under a binary node (its run of the order).
fn triangles(node: &Binary) -> usize {
    let (start, end) = run(node);
    end - start
}

/// A binary node's run of the triangle order (a subtree's triangles are contiguous in it).
pub(super) fn run(node: &Binary) -> (usize, usize) {
    match node {
        Binary::Leaf { start, end, .. } => (*start, *end),
        Binary::Inner { children, .. } => (run(&children[0]).0, run(&children[1]).1),
    }
}

/// What a slot of a wide node holds.
pub(super) enum Slot<'a> {
    /// A leaf over these binary nodes' triangles (one run of the order).
    Leaf(&'a Binary),
    /// A wide node over this binary node, with its plan.
    Node(&'a Binary, &'a Plan),
}

/// The slots of the wide node that stands for `node` (planned by `plan`): at most eight.
pub(super) fn slots<'a>(node: &'a Binary, plan: &'a Plan) -> Vec<Slot<'a>> {
    let mut out = Vec::with_capacity(WIDTH);
    let (Binary::Inner { children, .. }, Some(p)) = (node, &plan.children) else {
        // A binary leaf at the root: one leaf slot.
        out.push(Slot::Leaf(node));
        return out;
    };
    // The best share of the eight slots between the two children (what C_node counted; the
    // root is a wide node whatever its own cost table says).
    let k = (1..WIDTH)
        .fold((f32::INFINITY, 1), |best, k| {
            let c = p[0].cost[k - 1] + p[1].cost[WIDTH - k - 1];
            if c < best.0 {
                (c, k)
            } else {
                best
            }
        })
        .1;
    expand(&children[0], &p[0], k, &mut out);
    expand(&children[1], &p[1], WIDTH - k, &mut out);
    out
}

/// Appends the roots that stand for `node` in at most `slots` slots.
fn expand<'a>(node: &'a Binary, plan: &'a Plan, slots: usize, out: &mut Vec<Slot<'a>>) {
    let mut j = slots;
    while plan.choice[j - 1] == Choice::Fewer {
        j -= 1;
    }
    match (plan.choice[j - 1], node, &plan.children) {
        (Choice::Leaf, ..) => out.push(Slot::Leaf(node)),
        (Choice::Node, ..) => out.push(Slot::Node(node, plan)),
        (Choice::Split(k), Binary::Inner { children, .. }, Some(p)) => {
            expand(&children[0], &p[0], k as usize, out);
            expand(&children[1], &p[1], j - k as usize, out);
        }
        _ => unreachable!("only inner nodes split, and Fewer was followed"),
    }
}
