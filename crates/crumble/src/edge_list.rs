//! Per-node edge lists: each node of a graph keeps the list of the edges
//! that touch it, so that the edges of one node are found without a scan.
//! The broad phase's proxies list their pairs (`broad_phase.rs`), the
//! contact set's bodies their contacts (`contact.rs`).
//!
//! An edge joins two distinct nodes, its ends `0` and `1`, and sits in both
//! of their lists at once: `next[s]` and `prev[s]` of its [`Links`] link it
//! in the list of end `s`. Each node holds the first edge of its list (a
//! [`Head`]). The lists are doubly linked so that an edge leaves both in
//! O(1), and a new edge goes to the front of both.
//!
//! Invariant: for every node `n`, walking from its head along
//! `next[side(n)]` visits exactly the edges with `n` as an end, each once,
//! and stops at [`END`]; each visited edge's `prev[side(n)]` is the edge
//! visited before it, [`END`] for the first. [`check_list`] asserts it.

/// No edge: the end of a list, or an empty head.
pub(crate) const END: u32 = u32::MAX;

/// An edge's places in the lists of its two ends (index `s` for end `s`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C)]
pub(crate) struct Links {
    pub next: [u32; 2],
    pub prev: [u32; 2],
}

impl Links {
    /// In no list.
    pub const NONE: Links = Links { next: [END; 2], prev: [END; 2] };
}

/// An edge kept in its two ends' lists.
pub(crate) trait Edge {
    /// Which end `node` is, 0 or 1 (`node` must be one of the two).
    fn side(&self, node: u32) -> usize;
    fn links(&self) -> &Links;
    fn links_mut(&mut self) -> &mut Links;

    /// The edge after this one in `node`'s list, or [`END`].
    #[inline]
    fn next_in(&self, node: u32) -> u32 {
        self.links().next[self.side(node)]
    }
}

/// Where a node keeps the first edge of its list.
pub(crate) trait Head {
    fn first(&self) -> u32;
    fn set_first(&mut self, edge: u32);
}

impl Head for u32 {
    #[inline]
    fn first(&self) -> u32 {
        *self
    }

    #[inline]
    fn set_first(&mut self, edge: u32) {
        *self = edge;
    }
}

/// Puts edge `id` between `ends` at the front of both ends' lists: the
/// old first edges point back at it and the heads at it. Returns the
/// links the caller stores with the edge in slot `id` (which may not
/// exist yet: it is not in any list, so it is not touched here).
#[inline]
pub(crate) fn link_front<E: Edge, H: Head>(edges: &mut [E], heads: &mut [H], id: u32, ends: [u32; 2]) -> Links {
    let next = [heads[ends[0] as usize].first(), heads[ends[1] as usize].first()];
    for (s, node) in ends.into_iter().enumerate() {
        let head = next[s];
        if head != END {
            let h = &mut edges[head as usize];
            let hs = h.side(node);
            h.links_mut().prev[hs] = id;
        }
        heads[node as usize].set_first(id);
    }
    Links { next, prev: [END; 2] }
}

/// Takes the edge between `ends` whose links are `links` out of both
/// lists: its neighbours (or the heads) skip it. Its own slot is not
/// touched.
#[inline]
pub(crate) fn unlink<E: Edge, H: Head>(edges: &mut [E], heads: &mut [H], ends: [u32; 2], links: Links) {
    for (s, node) in ends.into_iter().enumerate() {
        let (prev, next) = (links.prev[s], links.next[s]);
        if prev == END {
            heads[node as usize].set_first(next);
        } else {
            let p = &mut edges[prev as usize];
            let ps = p.side(node);
            p.links_mut().next[ps] = next;
        }
        if next != END {
            let n = &mut edges[next as usize];
            let ns = n.side(node);
            n.links_mut().prev[ns] = prev;
        }
    }
}

/// Walks `node`'s list from `first`, calling `visit` on each edge before
/// it asserts the edge's back link; returns the list's length. For the
/// `validate` checks.
pub(crate) fn check_list<E: Edge>(edges: &[E], node: u32, first: u32, mut visit: impl FnMut(u32, &E)) -> usize {
    let (mut prev, mut id, mut len) = (END, first, 0);
    while id != END {
        let e = &edges[id as usize];
        visit(id, e);
        assert_eq!(e.links().prev[e.side(node)], prev, "back link of {id} on the list of {node}");
        len += 1;
        prev = id;
        id = e.next_in(node);
    }
    len
}

crate::snapshot::codec::persist!(Links { next, prev });
