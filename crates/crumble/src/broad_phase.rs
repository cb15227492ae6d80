//! Broad phase: an incremental dynamic AABB tree that reports which pairs of
//! colliders begin and stop being close enough to need a narrow-phase test.
//!
//! # Model
//!
//! Every collider is a *proxy*: a leaf of a binary tree of axis-aligned boxes.
//! A leaf does not store the collider's tight box but a *fat* one, grown by
//! the margin given to [`BroadPhase::new`] (or the proxy's own, see
//! [`BroadPhase::insert_with_margin`]) on every side (and optionally
//! stretched along the collider's displacement). While a collider's tight box
//! stays inside its fat box, [`BroadPhase::update`] does nothing; only when it
//! leaves is the leaf re-inserted with a fresh fat box and the proxy marked as
//! *moved*. Most resting or slowly moving bodies therefore cost nothing per
//! step.
//!
//! The pair set is exactly the set of proxy pairs whose **fat** boxes overlap
//! (touching counts), minus static–static pairs, minus pairs rejected by the
//! filter of [`BroadPhase::update_pairs_filtered`]. [`BroadPhase::update_pairs`]
//! brings it up to date by looking only at moved proxies: it drops their
//! known pairs whose fat boxes separated ([`BroadPhase::lost_pairs`]) and
//! tests the tree against itself, over the subtrees that hold a moved proxy,
//! for pairs not yet known ([`BroadPhase::new_pairs`]). Pairs between
//! proxies that did not move cannot have changed, so they are not looked at.
//!
//! # Tree
//!
//! Nodes live in a `Vec` arena with a free list, so inserting and removing
//! proxies allocates only when the arena grows past its high-water mark. A new
//! leaf descends from the root towards the child whose box grows the least in
//! surface area (the surface-area heuristic) and becomes the sibling of the
//! node where it stops. On the way back up every ancestor is refitted and
//! rotated:
//!
//! - a *height rotation* when its two subtrees differ in height by more than
//!   [`MAX_IMBALANCE`]: the taller child is lifted and hands its shorter
//!   child down. Children of a node are unordered, so this single rotation
//!   always restores the bound, which caps the height at about
//!   `2.5 · log2 n` in the worst case;
//! - otherwise a *surface-area rotation*: a child swaps places with a
//!   grandchild under its sibling when that shrinks the sibling's box and
//!   keeps the height bound. These undo the poor groupings that insertion
//!   order and motion leave behind; in practice the height stays near
//!   `1.5 · log2 n`.
//!
//! A proxy keeps its [`ProxyId`] for its whole life, including across
//! re-insertions and rotations.
//!
//! Each internal node also knows whether a static or kinematic proxy lies
//! below it, so that [`BroadPhase::query_fixed`] (what the continuous
//! sweep of a fast body asks for) visits only the subtrees that hold one,
//! not the thousands of moving bricks around them.
//!
//! Each proxy also heads an intrusive, doubly linked list of its pairs
//! (`edge_list`; pairs live in their own arena with a free list), which lets
//! `update_pairs` visit only the pairs of moved proxies and remove any pair in
//! constant time.
//!
//! # Cost
//!
//! With `n` proxies:
//!
//! - [`BroadPhase::insert`] and [`BroadPhase::remove`]: O(log n) (the descent
//!   and the walk back up are bounded by the height, which is O(log n) in the
//!   worst case); `remove` also pays O(d) for the proxy's `d` pairs.
//! - [`BroadPhase::update`]: O(1) when the proxy stays inside its fat box,
//!   O(log n) when it is re-inserted.
//! - [`BroadPhase::update_pairs`]: O(m log n + k) expected for `m` moved
//!   proxies and `k` pairs involving them (found or dropped), plus
//!   O(k' log k') to sort the `k'` reported events and the lists of known
//!   partners longer than a few (each candidate pair is looked up in one).
//!   The self-test marks the paths from the moved proxies to the root and
//!   then meets O(k) pairs of overlapping subtrees when boxes are of similar
//!   size and not piled on top of each other; nothing in a step is ever
//!   O(n²), and subtrees without a moved proxy are tested only against ones
//!   with.
//! - [`BroadPhase::query`]: O(log n + hits) under the same assumption.
//! - Memory: O(n + k) for `n` proxies and `k` current pairs (`2n - 1` tree
//!   nodes, one record per pair, and scratch buffers that are reused).
//!
//! In steady state (no growth past previous high-water marks) no method
//! allocates.
//!
//! # Determinism
//!
//! There is no hashing. All state lives in arenas whose slots are handed out
//! in an order that depends only on the sequence of calls, so two runs that
//! make the same calls produce the same tree, the same `pairs()` order and
//! the same events. The event lists are additionally sorted.
//!
//! # Limits
//!
//! Boxes must be finite: keep infinite shapes such as the ground half-space
//! out of the tree and test them against every body directly. A [`ProxyId`]
//! must not be used after [`BroadPhase::remove`]; its slot is recycled by
//! later insertions.

use crate::aabb::{Aabb, AabbProbe};
use crate::edge_list::{self, Edge, Head, Links};
use crate::math::Vec3;

/// The most by which the heights of the two subtrees of any tree node may
/// differ. Insertion, removal and every rotation keep this bound, which caps
/// the height of a tree of `n` proxies at about `2.5 · log2 n` (a bound of 1
/// would be an AVL tree, but forcing that tight a balance spoils the spatial
/// grouping the surface-area heuristic builds; with 4 the rotations that
/// shrink boxes have room to act).
pub const MAX_IMBALANCE: u32 = 4;

/// Sentinel for "no node" / "no pair".
const NULL: u32 = u32::MAX;

/// Up to this many known partners, `update_pairs` looks a candidate up in a
/// moved proxy's partner list by reading it through; a longer list is
/// sorted and searched by halves. A brick in a wall has about eight.
const LINEAR_PARTNERS: usize = 16;

/// Handle to a proxy in a [`BroadPhase`]. Stable from insertion to removal.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ProxyId(u32);

impl ProxyId {
    /// The slot index of the proxy in the broad phase's node arena.
    #[inline]
    pub fn index(self) -> u32 {
        self.0
    }
}

/// Node flag: the slot is on the free list.
const FREE: u8 = 1;
/// Node flag: the proxy was inserted or re-inserted since the last
/// `update_pairs`.
const MOVED: u8 = 2;
/// Node flag: the proxy belongs to a static collider.
const STATIC: u8 = 4;
/// Node flag: the proxy belongs to a collider that moves but that
/// contacts do not push (a kinematic body's).
const KINEMATIC: u8 = 16;
/// Node flag, internal nodes only: some leaf below is [`STATIC`] or
/// [`KINEMATIC`]. A query for those alone ([`BroadPhase::query_fixed`])
/// skips the subtrees without it: the continuous sweep of a fast body asks
/// only for what its contacts cannot push, and a pile's moving bricks fill
/// the tree around it.
const HAS_FIXED: u8 = 8;

/// A tree node: an internal node (two children) or a leaf (a proxy).
#[derive(Clone, Copy, Debug)]
struct Node {
    /// The fat box for a leaf; the union of the children's boxes otherwise.
    aabb: Aabb,
    /// Parent node, or [`NULL`] for the root. For a free slot: the next free
    /// slot.
    parent: u32,
    /// Children, or [`NULL`] for a leaf.
    child: [u32; 2],
    /// 0 for a leaf, 1 + the taller child's height otherwise.
    height: u32,
    /// Leaf only: the caller's id.
    user: u32,
    /// Leaf only: first pair in this proxy's pair list.
    first_pair: u32,
    /// Leaf only: how far its fat box extends beyond its tight box.
    margin: f32,
    /// [`FREE`], [`MOVED`], [`STATIC`], [`KINEMATIC`], [`HAS_FIXED`].
    flags: u8,
}

impl Node {
    #[inline]
    fn is_leaf(&self) -> bool {
        self.child[0] == NULL
    }
}

/// A current pair: two proxies and its links in their pair lists
/// (`edge_list`: index `s` belongs to the list of `proxy[s]`).
#[derive(Clone, Copy, Debug)]
struct Pair {
    /// The two proxies, `proxy[0] < proxy[1]`; `proxy[0] == NULL` marks a
    /// free slot, whose `links.next[0]` is then the next free slot.
    proxy: [u32; 2],
    links: Links,
}

impl Edge for Pair {
    /// Which side of the pair `p` is on (`p` must be one of the two).
    #[inline]
    fn side(&self, p: u32) -> usize {
        debug_assert!(self.proxy[0] == p || self.proxy[1] == p);
        usize::from(self.proxy[1] == p)
    }

    #[inline]
    fn links(&self) -> &Links {
        &self.links
    }

    #[inline]
    fn links_mut(&mut self) -> &mut Links {
        &mut self.links
    }
}

impl Head for Node {
    #[inline]
    fn first(&self) -> u32 {
        self.first_pair
    }

    #[inline]
    fn set_first(&mut self, pair: u32) {
        self.first_pair = pair;
    }
}

/// A depth-first traversal stack that lives on the call stack: a traversal
/// holds at most `height + 1` entries, and the [`MAX_IMBALANCE`] bound keeps
/// the height under 80 even for `u32::MAX` proxies. It spills to the heap
/// only if that ever failed.
struct Stack {
    inline: [u32; 96],
    len: usize,
    spill: Vec<u32>,
}

impl Stack {
    fn new(first: u32) -> Self {
        let mut s = Stack { inline: [NULL; 96], len: 0, spill: Vec::new() };
        s.push(first);
        s
    }

    #[inline]
    fn push(&mut self, v: u32) {
        if self.len < self.inline.len() {
            self.inline[self.len] = v;
            self.len += 1;
        } else {
            self.spill.push(v);
        }
    }

    #[inline]
    fn pop(&mut self) -> Option<u32> {
        if let Some(v) = self.spill.pop() {
            return Some(v);
        }
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        Some(self.inline[self.len])
    }
}

/// The incremental broad phase: a dynamic AABB tree of fat boxes plus the set
/// of overlapping pairs. See the [module documentation](self) for the model
/// and the costs.
#[derive(Clone, Debug)]
pub struct BroadPhase {
    margin: f32,
    nodes: Vec<Node>,
    root: u32,
    free_node: u32,
    proxy_count: usize,

    pairs: Vec<Pair>,
    free_pair: u32,
    pair_count: usize,
    /// Most pairs kept at once ([`BroadPhase::set_pair_limit`]).
    pair_limit: usize,
    /// Pairs the last `update_pairs` found but did not create: the limit
    /// was reached.
    refused_pairs: usize,

    /// Proxies flagged [`MOVED`] since the last `update_pairs` (may hold
    /// stale entries for removed proxies; those are skipped).
    move_buffer: Vec<u32>,
    /// Per node slot: the last `update_pairs` (its `epoch`) in which the
    /// node was a moved leaf or an internal node with one below.
    stamp: Vec<u32>,
    epoch: u32,
    /// Scratch of `update_pairs`: per moved leaf, its place in the move
    /// buffer; per place, where its known partners start in `partners`.
    slot: Vec<u32>,
    partner_start: Vec<u32>,
    partners: Vec<u32>,
    /// Scratch of `update_pairs`: the pairs of subtrees still to test.
    pair_stack: Vec<(u32, u32)>,

    new_pairs: Vec<(u32, u32)>,
    lost_pairs: Vec<(u32, u32)>,
    /// Pairs dropped by `remove` since the last `update_pairs`.
    pending_lost: Vec<(u32, u32)>,
    /// Proxies processed by the last `update_pairs`.
    moved_count: usize,
}

impl Default for BroadPhase {
    /// A broad phase with a 5 cm margin.
    fn default() -> Self {
        Self::new(0.05)
    }
}

#[inline]
fn ordered(a: u32, b: u32) -> (u32, u32) {
    if a <= b {
        (a, b)
    } else {
        (b, a)
    }
}

/// [`HAS_FIXED`] for an internal node whose children's flags, or-ed,
/// are `children`, else 0.
#[inline]
fn subtree_fixed(children: u8) -> u8 {
    if children & (STATIC | KINEMATIC | HAS_FIXED) != 0 {
        HAS_FIXED
    } else {
        0
    }
}

impl BroadPhase {
    /// An empty broad phase.
    ///
    /// `margin` (metres, finite and `>= 0`) is how far each fat box extends
    /// beyond the tight box on every side. A larger margin means fewer
    /// re-insertions of moving bodies but more pairs for the narrow phase; a
    /// few centimetres suits bodies of decimetre to metre size. Contacts are
    /// reported through pairs of fat boxes, so a pair is known before the
    /// tight boxes come within `2 · margin` of touching.
    ///
    /// # Panics
    ///
    /// If `margin` is negative or not finite.
    pub fn new(margin: f32) -> Self {
        assert!(margin.is_finite() && margin >= 0.0, "broad-phase margin must be finite and >= 0, got {margin}");
        Self {
            margin,
            nodes: Vec::new(),
            root: NULL,
            free_node: NULL,
            proxy_count: 0,
            pairs: Vec::new(),
            free_pair: NULL,
            pair_count: 0,
            pair_limit: usize::MAX,
            refused_pairs: 0,
            move_buffer: Vec::new(),
            stamp: Vec::new(),
            epoch: 0,
            slot: Vec::new(),
            partner_start: Vec::new(),
            partners: Vec::new(),
            pair_stack: Vec::new(),
            new_pairs: Vec::new(),
            lost_pairs: Vec::new(),
            pending_lost: Vec::new(),
            moved_count: 0,
        }
    }

    /// The fattening margin in metres that proxies inserted without one of
    /// their own take.
    #[inline]
    pub fn margin(&self) -> f32 {
        self.margin
    }

    /// Changes the margin that proxies inserted from now on without one of
    /// their own take ([`insert`](Self::insert),
    /// [`insert_static`](Self::insert_static)). Every proxy already in the
    /// tree keeps the margin it was given, and no fat box changes now.
    ///
    /// # Panics
    ///
    /// If `margin` is negative or not finite.
    pub fn set_margin(&mut self, margin: f32) {
        assert!(margin.is_finite() && margin >= 0.0, "broad-phase margin must be finite and >= 0, got {margin}");
        self.margin = margin;
    }

    /// Number of proxies.
    #[inline]
    pub fn len(&self) -> usize {
        self.proxy_count
    }

    /// True when there are no proxies.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.proxy_count == 0
    }

    /// Height of the tree: 0 when empty or with one proxy, otherwise the
    /// number of edges on the longest root-to-leaf path.
    #[inline]
    pub fn height(&self) -> u32 {
        if self.root == NULL {
            0
        } else {
            self.nodes[self.root as usize].height
        }
    }

    /// The sum of the internal nodes' half surface areas: what a query
    /// pays, up to a constant, by the surface-area heuristic (a diagnostic
    /// of the tree's quality, for tests and tuning). O(nodes).
    pub fn internal_area(&self) -> f32 {
        self.nodes.iter().filter(|n| n.flags & FREE == 0 && !n.is_leaf()).map(|n| n.aabb.half_area()).sum()
    }

    /// Number of current pairs.
    #[inline]
    pub fn pair_count(&self) -> usize {
        self.pair_count
    }

    /// Adds a dynamic proxy for a collider with tight box `aabb` and the
    /// caller's id `user` (typically a collider or body index). The proxy
    /// counts as moved, so its pairs appear at the next `update_pairs`.
    /// O(log n).
    pub fn insert(&mut self, aabb: Aabb, user: u32) -> ProxyId {
        self.insert_proxy(aabb, user, 0, self.margin)
    }

    /// Like [`insert`](Self::insert), with the proxy's own fattening margin
    /// (metres) instead of the broad phase's: a large body that moves a
    /// lot per step can take a wider margin, so that it leaves its fat box
    /// less often, without widening every small body's.
    ///
    /// # Panics
    ///
    /// If `margin` is negative or not finite.
    pub fn insert_with_margin(&mut self, aabb: Aabb, user: u32, margin: f32) -> ProxyId {
        assert!(margin.is_finite() && margin >= 0.0, "broad-phase margin must be finite and >= 0, got {margin}");
        self.insert_proxy(aabb, user, 0, margin)
    }

    /// Adds a static proxy: like [`insert`](Self::insert), but a pair of two
    /// static proxies is never reported. A static proxy is only looked at by
    /// `update_pairs` when it is inserted or [`update`](Self::update)d out of
    /// its fat box; dynamic proxies find it through their own queries.
    pub fn insert_static(&mut self, aabb: Aabb, user: u32) -> ProxyId {
        self.insert_proxy(aabb, user, STATIC, self.margin)
    }

    /// Like [`insert_with_margin`](Self::insert_with_margin), for a
    /// collider that moves but that contacts do not push (a kinematic
    /// body's): pairs as any moving proxy, and is found by
    /// [`query_fixed`](Self::query_fixed) beside the static ones.
    ///
    /// # Panics
    ///
    /// If `margin` is negative or not finite.
    pub fn insert_kinematic(&mut self, aabb: Aabb, user: u32, margin: f32) -> ProxyId {
        assert!(margin.is_finite() && margin >= 0.0, "broad-phase margin must be finite and >= 0, got {margin}");
        self.insert_proxy(aabb, user, KINEMATIC, margin)
    }

    fn insert_proxy(&mut self, aabb: Aabb, user: u32, flags: u8, margin: f32) -> ProxyId {
        debug_assert!(aabb.is_finite(), "broad-phase boxes must be finite");
        debug_assert!(aabb.min.cmple(aabb.max).all(), "inverted box {aabb:?}");
        let leaf = self.alloc_node();
        {
            let n = &mut self.nodes[leaf as usize];
            n.aabb = aabb.expanded(margin);
            n.margin = margin;
            n.user = user;
            n.flags = flags;
        }
        self.insert_leaf(leaf);
        self.proxy_count += 1;
        self.mark_moved(leaf);
        ProxyId(leaf)
    }

    /// Removes a proxy. Its current pairs are reported in
    /// [`lost_pairs`](Self::lost_pairs) after the next `update_pairs`.
    /// O(log n + d) for its `d` pairs.
    ///
    /// # Panics
    ///
    /// If `id` is not a live proxy (detected for ids whose slot is free).
    pub fn remove(&mut self, id: ProxyId) {
        let leaf = self.check_proxy(id);
        // Drop every pair of the proxy now and remember them as lost.
        let mut j = self.nodes[leaf as usize].first_pair;
        while j != NULL {
            let pair = self.pairs[j as usize];
            let next = pair.next_in(leaf);
            let a = self.nodes[pair.proxy[0] as usize].user;
            let b = self.nodes[pair.proxy[1] as usize].user;
            self.pending_lost.push(ordered(a, b));
            self.destroy_pair(j);
            j = next;
        }
        self.remove_leaf(leaf);
        // A stale move-buffer entry is skipped: the slot is free, or reused
        // by a proxy whose own entry comes later (`update_pairs` keeps each
        // moved slot's first entry only).
        self.free_node(leaf);
        self.proxy_count -= 1;
    }

    /// Tells the broad phase where a proxy's collider now is. If `tight_aabb`
    /// still lies inside the proxy's fat box, and that box is at most four
    /// margins longer on any axis than a fresh one would be, nothing happens
    /// and `false` is returned. Otherwise the leaf is re-inserted with a
    /// fresh fat box (`tight_aabb` grown by the margin), the proxy is marked
    /// as moved for the next `update_pairs`, and `true` is returned.
    /// O(1) or O(log n).
    ///
    /// # Panics
    ///
    /// If `id` is not a live proxy (detected for ids whose slot is free).
    pub fn update(&mut self, id: ProxyId, tight_aabb: Aabb) -> bool {
        self.update_with_displacement(id, tight_aabb, Vec3::ZERO)
    }

    /// Like [`update`](Self::update), but a re-inserted fat box is also
    /// stretched by `displacement` (for example the distance the body is
    /// expected to travel in the next step or two) on the side it moves
    /// towards, so that a fast body is re-inserted less often.
    pub fn update_with_displacement(&mut self, id: ProxyId, tight_aabb: Aabb, displacement: Vec3) -> bool {
        let leaf = self.check_proxy(id);
        let margin = self.nodes[leaf as usize].margin;
        self.update_leaf(leaf, tight_aabb, displacement, margin)
    }

    /// Like [`update`](Self::update), but with a new fattening margin for
    /// this proxy (metres), used from now on: for the test that keeps an
    /// oversized box and for any fat box built here or later. A wider margin
    /// alone never re-inserts the proxy; a narrower one does when the old
    /// fat box is now more than four margins too long.
    ///
    /// # Panics
    ///
    /// If `margin` is negative or not finite, or `id` is not a live proxy.
    pub fn update_with_margin(&mut self, id: ProxyId, tight_aabb: Aabb, margin: f32) -> bool {
        assert!(margin.is_finite() && margin >= 0.0, "broad-phase margin must be finite and >= 0, got {margin}");
        let leaf = self.check_proxy(id);
        self.nodes[leaf as usize].margin = margin;
        self.update_leaf(leaf, tight_aabb, Vec3::ZERO, margin)
    }

    fn update_leaf(&mut self, leaf: u32, tight_aabb: Aabb, displacement: Vec3, margin: f32) -> bool {
        debug_assert!(tight_aabb.is_finite(), "broad-phase boxes must be finite");
        debug_assert!(displacement.is_finite());
        let current = self.nodes[leaf as usize].aabb;

        let mut fat = tight_aabb.expanded(margin);
        let d = displacement;
        fat.min += d.min(Vec3::ZERO);
        fat.max += d.max(Vec3::ZERO);

        if current.contains(&tight_aabb) {
            // Still inside. Keep the old box unless it is more than four
            // margins longer along some axis than the one we would build now
            // (a fast body that stopped, or a box that shrank), since an
            // oversized box only breeds pairs. Comparing sizes rather than
            // positions lets a body that keeps its speed and its displacement
            // hint travel through its stretched box without re-insertion.
            let excess = (current.max - current.min) - (fat.max - fat.min);
            if excess.max_element() <= 4.0 * margin {
                return false;
            }
        }

        self.remove_leaf(leaf);
        self.nodes[leaf as usize].aabb = fat;
        self.insert_leaf(leaf);
        self.mark_moved(leaf);
        true
    }

    /// Marks a proxy as moved without moving it: the next `update_pairs`
    /// asks the filter again about every overlap it has that is not a
    /// pair (a pair the filter refused may be wanted now).
    pub fn requery(&mut self, id: ProxyId) {
        let leaf = self.check_proxy(id);
        self.mark_moved(leaf);
    }

    /// Forgets the pair of proxies `a` and `b`, if there is one, without
    /// reporting it lost (the caller drops what it kept for it); returns
    /// whether there was. The pair is proposed again, through the filter,
    /// when one of the two next moves. O(pairs of `a`).
    pub fn forget_pair(&mut self, a: ProxyId, b: ProxyId) -> bool {
        let (la, lb) = (self.check_proxy(a), self.check_proxy(b));
        let mut j = self.nodes[la as usize].first_pair;
        while j != NULL {
            let pair = self.pairs[j as usize];
            if pair.proxy.contains(&lb) {
                self.destroy_pair(j);
                return true;
            }
            j = pair.next_in(la);
        }
        false
    }

    /// The caller's id of a proxy.
    pub fn user(&self, id: ProxyId) -> u32 {
        let leaf = self.check_proxy(id);
        self.nodes[leaf as usize].user
    }

    /// The fat box the tree holds for a proxy.
    pub fn fat_aabb(&self, id: ProxyId) -> Aabb {
        let leaf = self.check_proxy(id);
        self.nodes[leaf as usize].aabb
    }

    /// Whether the proxy was inserted with [`insert_static`](Self::insert_static).
    pub fn is_static(&self, id: ProxyId) -> bool {
        let leaf = self.check_proxy(id);
        self.nodes[leaf as usize].flags & STATIC != 0
    }

    /// Whether the proxy was inserted with
    /// [`insert_kinematic`](Self::insert_kinematic).
    pub fn is_kinematic(&self, id: ProxyId) -> bool {
        let leaf = self.check_proxy(id);
        self.nodes[leaf as usize].flags & KINEMATIC != 0
    }

    /// Brings the pair set up to date; see
    /// [`update_pairs_filtered`](Self::update_pairs_filtered). Accepts every
    /// pair that is not static–static.
    pub fn update_pairs(&mut self) {
        self.update_pairs_filtered(|_, _| true);
    }

    /// Brings the pair set up to date with the proxies moved (inserted or
    /// re-inserted) since the last call, and fills [`new_pairs`](Self::new_pairs)
    /// and [`lost_pairs`](Self::lost_pairs).
    ///
    /// A candidate pair (fat boxes overlapping, not yet known, not
    /// static–static, two different proxies) is added only if
    /// `filter(a, b)` returns true, where `a <= b` are the two user ids; use
    /// it to skip, for example, two colliders of the same body. The filter is
    /// consulted only for candidates: a rejected pair is asked about again the
    /// next time one of its proxies moves, and an accepted pair stays until
    /// its fat boxes separate or a proxy is removed.
    ///
    /// Events from one call are meant to be applied lost-first: if a proxy
    /// was removed and another inserted with the same user id, the same user
    /// pair can appear in both lists.
    pub fn update_pairs_filtered(&mut self, mut filter: impl FnMut(u32, u32) -> bool) {
        self.refused_pairs = 0;
        self.new_pairs.clear();
        self.lost_pairs.clear();
        self.lost_pairs.append(&mut self.pending_lost);
        let n = self.nodes.len();
        if self.stamp.len() < n {
            self.stamp.resize(n, 0);
        }
        if self.slot.len() < n {
            self.slot.resize(n, 0);
        }
        // A new epoch; on wrap-around, every old stamp is forgotten so that
        // none can be mistaken for the current one.
        self.epoch = self.epoch.wrapping_add(1);
        if self.epoch == 0 {
            self.stamp.fill(0);
            self.epoch = 1;
        }
        let epoch = self.epoch;

        self.stamp_moved(epoch);
        self.drop_separated_pairs();
        self.pair_moved_subtrees(epoch, &mut filter);

        for &p in &self.move_buffer {
            self.nodes[p as usize].flags &= !MOVED;
        }
        self.move_buffer.clear();

        self.new_pairs.sort_unstable();
        self.lost_pairs.sort_unstable();
    }

    /// Keeps each moved proxy once in the move buffer and stamps it and
    /// every internal node above it with `epoch`.
    ///
    /// A removed proxy's entry, or a second entry of a slot removed and
    /// reused, is dropped; the others keep the order they moved in.
    fn stamp_moved(&mut self, epoch: u32) {
        let (nodes, stamp) = (&self.nodes, &mut self.stamp);
        self.move_buffer.retain(|&p| {
            let fresh = nodes[p as usize].flags & (FREE | MOVED) == MOVED && stamp[p as usize] != epoch;
            if fresh {
                stamp[p as usize] = epoch;
            }
            fresh
        });
        self.moved_count = self.move_buffer.len();
        for &p in &self.move_buffer {
            let mut a = self.nodes[p as usize].parent;
            while a != NULL && self.stamp[a as usize] != epoch {
                self.stamp[a as usize] = epoch;
                a = self.nodes[a as usize].parent;
            }
        }
    }

    /// Each moved proxy's known pairs whose fat boxes separated are
    /// dropped (and reported lost); the partners of the others are listed
    /// for [`pair_leaves`](Self::pair_leaves).
    fn drop_separated_pairs(&mut self) {
        self.partners.clear();
        self.partner_start.clear();
        for k in 0..self.move_buffer.len() {
            let p = self.move_buffer[k];
            self.slot[p as usize] = k as u32;
            self.partner_start.push(self.partners.len() as u32);
            let node = &self.nodes[p as usize];
            let (probe, user_p) = (AabbProbe::new(&node.aabb), node.user);
            let mut j = node.first_pair;
            while j != NULL {
                let pair = self.pairs[j as usize];
                let s = pair.side(p);
                let next = pair.links.next[s];
                let q = pair.proxy[1 - s];
                let other = &self.nodes[q as usize];
                if probe.overlaps(&other.aabb) {
                    self.partners.push(q);
                } else {
                    self.lost_pairs.push(ordered(user_p, other.user));
                    self.destroy_pair(j);
                }
                j = next;
            }
            // A long list is sorted, to be searched by halves: a pile of
            // boxes over one point, all moving, would otherwise scan each
            // proxy's hundreds of partners for each of its hundreds of
            // candidates.
            let start = self.partner_start[k] as usize;
            if self.partners.len() - start > LINEAR_PARTNERS {
                self.partners[start..].sort_unstable();
            }
        }
        self.partner_start.push(self.partners.len() as u32);
    }

    /// Makes the new pairs of the moved proxies (stamped with `epoch`).
    fn pair_moved_subtrees(&mut self, epoch: u32, filter: &mut impl FnMut(u32, u32) -> bool) {
        // The new pairs: the tree against itself, over the subtrees that
        // hold a moved proxy. Each pair of leaves is reached once, at its
        // lowest common ancestor (a node's two subtrees are tested against
        // each other, and each against itself); a pair of subtrees is left
        // as soon as neither holds a moved proxy or their boxes are apart.
        // Every pair of overlapping fat boxes with a moved proxy in it is
        // found this way, at the cost of the descent that the two share,
        // where one query a moved proxy would walk down from the root.
        let mut stack = std::mem::take(&mut self.pair_stack);
        stack.clear();
        if self.root != NULL && !self.nodes[self.root as usize].is_leaf() && self.stamp[self.root as usize] == epoch {
            stack.push((self.root, self.root));
        }
        while let Some((a, b)) = stack.pop() {
            let (na, nb) = (&self.nodes[a as usize], &self.nodes[b as usize]);
            if a == b {
                // Internal, with a moved proxy below: its children against
                // each other, and each with one inside against itself.
                let [c0, c1] = na.child;
                stack.push((c0, c1));
                for c in [c1, c0] {
                    if self.stamp[c as usize] == epoch && !self.nodes[c as usize].is_leaf() {
                        stack.push((c, c));
                    }
                }
                continue;
            }
            if self.stamp[a as usize] != epoch && self.stamp[b as usize] != epoch {
                continue;
            }
            if !AabbProbe::new(&na.aabb).overlaps(&nb.aabb) {
                continue;
            }
            // Which node to open: the only internal one; else the one with
            // a moved proxy below when the other has none (its children
            // without one then meet the other and stop at once); else the
            // taller.
            let open_a = match (na.is_leaf(), nb.is_leaf()) {
                (true, true) => {
                    self.pair_leaves(a, b, epoch, filter);
                    continue;
                }
                (false, true) => true,
                (true, false) => false,
                (false, false) => match (self.stamp[a as usize] == epoch, self.stamp[b as usize] == epoch) {
                    (true, false) => true,
                    (false, true) => false,
                    _ => na.height >= nb.height,
                },
            };
            if open_a {
                stack.push((na.child[1], b));
                stack.push((na.child[0], b));
            } else {
                stack.push((a, nb.child[1]));
                stack.push((a, nb.child[0]));
            }
        }
        self.pair_stack = stack;
    }

    /// Leaves `x` and `y`, whose fat boxes overlap and one of which moved
    /// (its stamp is `epoch`), become a pair unless they are one already,
    /// are both static, or the filter or the limit refuses them.
    fn pair_leaves(&mut self, x: u32, y: u32, epoch: u32, filter: &mut impl FnMut(u32, u32) -> bool) {
        let (nx, ny) = (&self.nodes[x as usize], &self.nodes[y as usize]);
        if nx.flags & ny.flags & STATIC != 0 {
            return;
        }
        // A known pair is in the partner list of its moved proxy.
        let (moved, other) = if self.stamp[x as usize] == epoch { (x, y) } else { (y, x) };
        let k = self.slot[moved as usize] as usize;
        let known = &self.partners[self.partner_start[k] as usize..self.partner_start[k + 1] as usize];
        let is_known =
            if known.len() > LINEAR_PARTNERS { known.binary_search(&other).is_ok() } else { known.contains(&other) };
        if is_known {
            return;
        }
        let (a, b) = ordered(nx.user, ny.user);
        if !filter(a, b) {
            return;
        }
        if self.pair_count >= self.pair_limit {
            self.refused_pairs += 1;
            return;
        }
        self.create_pair(x, y);
        self.new_pairs.push((a, b));
    }

    /// Caps the pairs kept at once (default: no cap). A pair found beyond
    /// it is not created, only counted ([`BroadPhase::refused_pairs`]),
    /// and found again when one of its proxies next moves: colliders
    /// created overlapping at one point would otherwise pair every one
    /// with every other, memory growing as the square of their number.
    pub fn set_pair_limit(&mut self, limit: usize) {
        self.pair_limit = limit;
    }

    /// Pairs the last `update_pairs` found but did not create because the
    /// limit was reached ([`BroadPhase::set_pair_limit`]).
    #[inline]
    pub fn refused_pairs(&self) -> usize {
        self.refused_pairs
    }

    /// Number of moved (inserted or re-inserted) proxies the last
    /// `update_pairs` looked at: its cost is proportional to this, not to
    /// the number of proxies.
    #[inline]
    pub fn moved_count(&self) -> usize {
        self.moved_count
    }

    /// Pairs (user ids, smaller first) that appeared at the last
    /// `update_pairs`, sorted.
    #[inline]
    pub fn new_pairs(&self) -> &[(u32, u32)] {
        &self.new_pairs
    }

    /// Pairs (user ids, smaller first) that disappeared at the last
    /// `update_pairs` because their fat boxes separated or one of their
    /// proxies was removed, sorted.
    #[inline]
    pub fn lost_pairs(&self) -> &[(u32, u32)] {
        &self.lost_pairs
    }

    /// The current pair set as user ids, smaller first. The order depends
    /// only on the sequence of calls made on this broad phase, so it is the
    /// same from run to run; it is not sorted (collect and sort for a
    /// canonical order). O(k) for `k` pairs plus free pair slots.
    pub fn pairs(&self) -> impl Iterator<Item = (u32, u32)> + '_ {
        self.pairs
            .iter()
            .filter(|p| p.proxy[0] != NULL)
            .map(|p| ordered(self.nodes[p.proxy[0] as usize].user, self.nodes[p.proxy[1] as usize].user))
    }

    /// Calls `callback` with the user id of every proxy whose fat box
    /// overlaps `aabb`, in a deterministic order, until it returns false.
    pub fn query(&self, aabb: &Aabb, mut callback: impl FnMut(u32) -> bool) {
        self.query_where(aabb, 0, |leaf| callback(self.nodes[leaf as usize].user));
    }

    /// Like [`query`](Self::query), for the proxies inserted with
    /// [`insert_static`](Self::insert_static) or
    /// [`insert_kinematic`](Self::insert_kinematic) only, in the same
    /// order; subtrees without one are not visited.
    pub fn query_fixed(&self, aabb: &Aabb, mut callback: impl FnMut(u32) -> bool) {
        self.query_where(aabb, STATIC | KINEMATIC | HAS_FIXED, |leaf| callback(self.nodes[leaf as usize].user));
    }

    /// Calls `callback` with every leaf overlapping `aabb`, among the nodes
    /// that have one of the flags `wanted` (all nodes for 0), until it
    /// returns false.
    #[inline(always)]
    fn query_where(&self, aabb: &Aabb, wanted: u8, mut callback: impl FnMut(u32) -> bool) {
        if self.root == NULL {
            return;
        }
        let probe = AabbProbe::new(aabb);
        let mut stack = Stack::new(self.root);
        while let Some(i) = stack.pop() {
            let node = &self.nodes[i as usize];
            if (wanted != 0 && node.flags & wanted == 0) || !probe.overlaps(&node.aabb) {
                continue;
            }
            if node.is_leaf() {
                if !callback(i) {
                    return;
                }
            } else {
                // Push the second child first so the first is visited first.
                stack.push(node.child[1]);
                stack.push(node.child[0]);
            }
        }
    }

    /// Checks every internal invariant and panics with a message on the
    /// first violation: parent/child links, heights, the AVL balance, boxes
    /// that hold their children, the free lists, proxy and pair counts, the
    /// per-proxy pair lists and that every pair's fat boxes overlap. O(n + k).
    /// Meant for tests and debugging.
    pub fn validate(&self) {
        let mut leaves = 0usize;
        if self.root != NULL {
            assert_eq!(self.nodes[self.root as usize].parent, NULL, "root has a parent");
            let mut stack = vec![self.root];
            while let Some(i) = stack.pop() {
                let n = &self.nodes[i as usize];
                assert_eq!(n.flags & FREE, 0, "free node {i} in the tree");
                if n.is_leaf() {
                    assert_eq!(n.child[1], NULL);
                    assert_eq!(n.height, 0, "leaf {i} height");
                    assert_eq!(n.flags & HAS_FIXED, 0, "leaf {i} flagged as a subtree");
                    leaves += 1;
                    continue;
                }
                let [c0, c1] = n.child;
                let (a, b) = (&self.nodes[c0 as usize], &self.nodes[c1 as usize]);
                assert_eq!(a.parent, i, "child {c0} of {i} has parent {}", a.parent);
                assert_eq!(b.parent, i, "child {c1} of {i} has parent {}", b.parent);
                assert_eq!(n.height, 1 + a.height.max(b.height), "height of {i}");
                assert!(a.height.abs_diff(b.height) <= MAX_IMBALANCE, "node {i} unbalanced");
                assert_eq!(n.aabb, a.aabb.union(&b.aabb), "box of {i}");
                assert_eq!(n.flags & HAS_FIXED, subtree_fixed(a.flags | b.flags), "fixed-subtree flag of {i}");
                stack.push(c0);
                stack.push(c1);
            }
        }
        assert_eq!(leaves, self.proxy_count, "leaf count");
        let internal = leaves.saturating_sub(1);
        let mut free = 0usize;
        let mut f = self.free_node;
        while f != NULL {
            assert_ne!(self.nodes[f as usize].flags & FREE, 0, "free list");
            free += 1;
            f = self.nodes[f as usize].parent;
        }
        assert_eq!(leaves + internal + free, self.nodes.len(), "node slots");

        let mut live = 0usize;
        let mut seen = Vec::new();
        for (j, pair) in self.pairs.iter().enumerate() {
            if pair.proxy[0] == NULL {
                continue;
            }
            live += 1;
            let [p, q] = pair.proxy;
            assert!(p < q, "pair {j} not ordered");
            let (np, nq) = (&self.nodes[p as usize], &self.nodes[q as usize]);
            assert!(np.is_leaf() && nq.is_leaf() && (np.flags | nq.flags) & FREE == 0);
            assert!(np.aabb.overlaps(&nq.aabb), "pair {j} does not overlap");
            assert!(np.flags & nq.flags & STATIC == 0, "static-static pair {j}");
            seen.push((p, q));
        }
        assert_eq!(live, self.pair_count, "pair count");
        seen.sort_unstable();
        assert!(seen.windows(2).all(|w| w[0] != w[1]), "duplicate pair");

        // Each pair sits in exactly the lists of its two proxies.
        let mut listed = 0usize;
        for (i, n) in self.nodes.iter().enumerate() {
            if n.flags & FREE != 0 || !n.is_leaf() {
                continue;
            }
            let i = i as u32;
            listed += edge_list::check_list(&self.pairs, i, n.first_pair, |j, pair| {
                assert!(pair.proxy.contains(&i), "pair {j} in the wrong list");
            });
        }
        assert_eq!(listed, 2 * self.pair_count, "pair list entries");
    }

    // ----- proxies and pairs -------------------------------------------------

    fn check_proxy(&self, id: ProxyId) -> u32 {
        let n = self.nodes.get(id.0 as usize);
        assert!(n.is_some_and(|n| n.flags & FREE == 0 && n.is_leaf()), "{id:?} is not a live proxy");
        id.0
    }

    fn mark_moved(&mut self, leaf: u32) {
        let n = &mut self.nodes[leaf as usize];
        if n.flags & MOVED == 0 {
            n.flags |= MOVED;
            self.move_buffer.push(leaf);
        }
    }

    /// Adds the pair `{a, b}` to both proxies' lists.
    fn create_pair(&mut self, a: u32, b: u32) {
        let (p, q) = ordered(a, b);
        let j = if self.free_pair != NULL {
            let j = self.free_pair;
            self.free_pair = self.pairs[j as usize].links.next[0];
            j
        } else {
            self.pairs.len() as u32
        };
        let links = edge_list::link_front(&mut self.pairs, &mut self.nodes, j, [p, q]);
        let pair = Pair { proxy: [p, q], links };
        if j as usize == self.pairs.len() {
            self.pairs.push(pair);
        } else {
            self.pairs[j as usize] = pair;
        }
        self.pair_count += 1;
    }

    /// Unlinks pair `j` from both lists and frees its slot.
    fn destroy_pair(&mut self, j: u32) {
        let pair = self.pairs[j as usize];
        edge_list::unlink(&mut self.pairs, &mut self.nodes, pair.proxy, pair.links);
        let free = Links { next: [self.free_pair, NULL], prev: [NULL, NULL] };
        self.pairs[j as usize] = Pair { proxy: [NULL, NULL], links: free };
        self.free_pair = j;
        self.pair_count -= 1;
    }

    // ----- tree ----------------------------------------------------------------

    fn alloc_node(&mut self) -> u32 {
        let fresh = Node {
            aabb: Aabb::new(Vec3::ZERO, Vec3::ZERO),
            parent: NULL,
            child: [NULL, NULL],
            height: 0,
            user: 0,
            first_pair: NULL,
            margin: 0.0,
            flags: 0,
        };
        if self.free_node != NULL {
            let i = self.free_node;
            self.free_node = self.nodes[i as usize].parent;
            self.nodes[i as usize] = fresh;
            i
        } else {
            assert!(self.nodes.len() < NULL as usize, "broad phase is full");
            self.nodes.push(fresh);
            (self.nodes.len() - 1) as u32
        }
    }

    fn free_node(&mut self, i: u32) {
        let n = &mut self.nodes[i as usize];
        n.parent = self.free_node;
        n.child = [NULL, NULL];
        n.flags = FREE;
        n.first_pair = NULL;
        self.free_node = i;
    }

    /// Links the (detached) leaf into the tree.
    fn insert_leaf(&mut self, leaf: u32) {
        if self.root == NULL {
            self.root = leaf;
            self.nodes[leaf as usize].parent = NULL;
            return;
        }
        let bx = self.nodes[leaf as usize].aabb;

        // Descend by the surface-area heuristic. Stopping at a node makes the
        // leaf its sibling under a new parent; to keep that new parent within
        // the balance bound we only stop at nodes of height <= MAX_IMBALANCE.
        // Ties go to the shorter child, so that a pile of identical boxes
        // still builds a shallow tree.
        let mut at = self.root;
        loop {
            let n = self.nodes[at as usize];
            if n.is_leaf() {
                break;
            }
            let joined = n.aabb.union(&bx).half_area();
            // Cost of pairing with `at` here: one new node of that size.
            let here = joined;
            // Going down enlarges `at` itself, then costs at least the growth
            // of the chosen child (or a new parent, if the child is a leaf).
            let growth = joined - n.aabb.half_area();
            let down = n.child.map(|c| {
                let cn = &self.nodes[c as usize];
                let with = cn.aabb.union(&bx).half_area();
                growth + if cn.is_leaf() { with } else { with - cn.aabb.half_area() }
            });
            if n.height <= MAX_IMBALANCE && here < down[0] && here < down[1] {
                break;
            }
            at = if down[1] < down[0] { n.child[1] } else { n.child[0] };
        }

        // Give `at` and the leaf a new common parent in `at`'s place.
        let sibling = at;
        let old_parent = self.nodes[sibling as usize].parent;
        let parent = self.alloc_node();
        {
            let s = self.nodes[sibling as usize];
            let leaf_flags = self.nodes[leaf as usize].flags;
            let p = &mut self.nodes[parent as usize];
            p.parent = old_parent;
            p.child = [sibling, leaf];
            p.aabb = s.aabb.union(&bx);
            p.height = s.height + 1;
            p.flags = subtree_fixed(s.flags | leaf_flags);
        }
        self.nodes[sibling as usize].parent = parent;
        self.nodes[leaf as usize].parent = parent;
        if old_parent == NULL {
            self.root = parent;
        } else {
            self.replace_child(old_parent, sibling, parent);
        }
        self.fix_upwards(old_parent);
    }

    /// Unlinks the leaf from the tree (the leaf slot itself stays allocated).
    fn remove_leaf(&mut self, leaf: u32) {
        if self.root == leaf {
            self.root = NULL;
            self.nodes[leaf as usize].parent = NULL;
            return;
        }
        let parent = self.nodes[leaf as usize].parent;
        let grand = self.nodes[parent as usize].parent;
        let pc = self.nodes[parent as usize].child;
        let sibling = if pc[0] == leaf { pc[1] } else { pc[0] };
        self.nodes[sibling as usize].parent = grand;
        if grand == NULL {
            self.root = sibling;
        } else {
            self.replace_child(grand, parent, sibling);
        }
        self.free_node(parent);
        self.nodes[leaf as usize].parent = NULL;
        self.fix_upwards(grand);
    }

    fn replace_child(&mut self, parent: u32, old: u32, new: u32) {
        let c = &mut self.nodes[parent as usize].child;
        if c[0] == old {
            c[0] = new;
        } else {
            debug_assert_eq!(c[1], old);
            c[1] = new;
        }
    }

    /// Walks from `i` towards the root, rebalancing and refitting each
    /// node, and stops at the first whose box, height and [`HAS_FIXED`]
    /// come out as they were: everything above it is then up to date
    /// already. (Re-inserting
    /// a body that moved a little changes the boxes of a few ancestors
    /// only, and walking on to the root, with a surface-area rotation tried
    /// at each, is a large share of the broad phase. The rotations above
    /// are only improvements of the tree's shape, which decides the cost of
    /// queries, never which pairs they find.)
    fn fix_upwards(&mut self, mut i: u32) {
        while i != NULL {
            let n = &self.nodes[i as usize];
            let before = (n.aabb, n.height, n.flags & HAS_FIXED);
            i = self.balance(i);
            self.refit(i);
            let n = &self.nodes[i as usize];
            if (n.aabb, n.height, n.flags & HAS_FIXED) == before {
                break;
            }
            i = n.parent;
        }
    }

    /// Recomputes an internal node's box, height and [`HAS_FIXED`] from
    /// its children.
    #[inline]
    fn refit(&mut self, i: u32) {
        let [c0, c1] = self.nodes[i as usize].child;
        let (a, b) = (&self.nodes[c0 as usize], &self.nodes[c1 as usize]);
        let aabb = a.aabb.union(&b.aabb);
        let height = 1 + a.height.max(b.height);
        let has_fixed = subtree_fixed(a.flags | b.flags);
        let n = &mut self.nodes[i as usize];
        n.aabb = aabb;
        n.height = height;
        n.flags = (n.flags & !HAS_FIXED) | has_fixed;
    }

    /// If the children of internal node `a` differ in height by more than
    /// [`MAX_IMBALANCE`], lifts the taller child into `a`'s place and returns
    /// it; otherwise tries a surface-area rotation ([`Self::improve`]) and
    /// returns `a`. The children of `a` must be up to date.
    fn balance(&mut self, a: u32) -> u32 {
        let [b, c] = self.nodes[a as usize].child;
        let hb = self.nodes[b as usize].height;
        let hc = self.nodes[c as usize].height;
        if hc > hb + MAX_IMBALANCE {
            self.rotate(a, c, b)
        } else if hb > hc + MAX_IMBALANCE {
            self.rotate(a, b, c)
        } else {
            self.improve(a);
            a
        }
    }

    /// Surface-area rotation at internal node `a` with children `x` and `y`:
    /// if moving `x` down into `y` in exchange for one of `y`'s children
    /// shrinks `y`'s box, and both `a` and `y` stay within
    /// [`MAX_IMBALANCE`], does the best such exchange. The set of leaves
    /// under `a` (and so `a`'s box) does not change; `a` is not refitted.
    fn improve(&mut self, a: u32) {
        let [b, c] = self.nodes[a as usize].child;
        let mut best_gain = 0.0f32;
        // (x: child moving down, y: the other child, up: y's child moving up,
        //  stay: y's child staying)
        let mut best: Option<[u32; 4]> = None;
        for (x, y) in [(b, c), (c, b)] {
            let yn = self.nodes[y as usize];
            if yn.is_leaf() {
                continue;
            }
            let xn = &self.nodes[x as usize];
            let y_area = yn.aabb.half_area();
            for (up, stay) in [(yn.child[0], yn.child[1]), (yn.child[1], yn.child[0])] {
                let sn = &self.nodes[stay as usize];
                let gain = y_area - xn.aabb.union(&sn.aabb).half_area();
                if gain <= best_gain {
                    continue;
                }
                let new_y_height = 1 + xn.height.max(sn.height);
                let up_height = self.nodes[up as usize].height;
                if xn.height.abs_diff(sn.height) > MAX_IMBALANCE || up_height.abs_diff(new_y_height) > MAX_IMBALANCE {
                    continue;
                }
                best_gain = gain;
                best = Some([x, y, up, stay]);
            }
        }
        if let Some([x, y, up, stay]) = best {
            self.nodes[a as usize].child = [up, y];
            self.nodes[up as usize].parent = a;
            self.nodes[y as usize].child = [x, stay];
            self.nodes[x as usize].parent = y;
            self.refit(y);
        }
    }

    /// Height rotation at `a`, whose child `tall` is `MAX_IMBALANCE + 1`
    /// levels taller than its other child `short`: `tall` takes `a`'s place with children `a`
    /// and the taller of its own two children; `a` keeps `short` and takes
    /// the other grandchild. When the grandchildren are equally tall, the one
    /// handed down is the one that makes `a`'s new box smaller.
    fn rotate(&mut self, a: u32, tall: u32, short: u32) -> u32 {
        let [f, g] = self.nodes[tall as usize].child;
        let hf = self.nodes[f as usize].height;
        let hg = self.nodes[g as usize].height;
        let (keep, give) = if hf > hg {
            (f, g)
        } else if hg > hf {
            (g, f)
        } else {
            let s = self.nodes[short as usize].aabb;
            let with_f = s.union(&self.nodes[f as usize].aabb).half_area();
            let with_g = s.union(&self.nodes[g as usize].aabb).half_area();
            if with_g <= with_f {
                (f, g)
            } else {
                (g, f)
            }
        };

        let up = self.nodes[a as usize].parent;
        self.nodes[tall as usize].parent = up;
        if up == NULL {
            self.root = tall;
        } else {
            self.replace_child(up, a, tall);
        }

        self.nodes[tall as usize].child = [a, keep];
        self.nodes[a as usize].parent = tall;
        self.nodes[a as usize].child = [short, give];
        self.nodes[give as usize].parent = a;
        self.refit(a);
        self.refit(tall);
        tall
    }
}

crate::snapshot::codec::persist!(Node { aabb, parent, child, height, user, first_pair, margin, flags });
crate::snapshot::codec::persist!(Pair { proxy, links });
crate::snapshot::codec::persist!(BroadPhase {
    margin, nodes, root, free_node, proxy_count, pairs, free_pair, pair_count, pair_limit, refused_pairs,
    move_buffer, epoch, new_pairs, lost_pairs, pending_lost, moved_count,
} scratch { stamp, slot, partner_start, partners, pair_stack });

impl crate::snapshot::codec::Persist for ProxyId {
    fn save(&self, w: &mut crate::snapshot::codec::Writer) {
        w.u32(self.0);
    }
    fn load(r: &mut crate::snapshot::codec::Reader) -> Result<Self, crate::snapshot::SnapshotError> {
        Ok(ProxyId(r.u32()?))
    }
    fn layout(out: &mut String) {
        out.push_str("ProxyId");
    }
}

impl BroadPhase {
    /// Checks a restored tree and pair list: every link in range, the
    /// tree reached from its root once per node, its leaves the proxies,
    /// every free node and pair on its free list, each pair in both its
    /// proxies' lists. What fails is named.
    pub(crate) fn check_restored(&self) -> Result<(), String> {
        let n = self.nodes.len();
        let in_nodes = |i: u32| (i as usize) < n;
        if !(self.margin.is_finite() && self.margin >= 0.0) {
            return Err(format!("broad phase margin {}", self.margin));
        }
        let mut seen = vec![0u8; n];
        // The free nodes, chained through `parent`.
        let mut free = self.free_node;
        let mut steps = 0;
        while free != NULL {
            if !in_nodes(free) || seen[free as usize] != 0 || self.nodes[free as usize].flags & FREE == 0 {
                return Err(format!("broad phase free node {free}"));
            }
            seen[free as usize] = 1;
            free = self.nodes[free as usize].parent;
            steps += 1;
            if steps > n {
                return Err("broad phase free nodes in a loop".into());
            }
        }
        let mut leaves = 0;
        if self.root != NULL {
            if !in_nodes(self.root) || self.nodes[self.root as usize].parent != NULL {
                return Err(format!("broad phase root {}", self.root));
            }
            let mut stack = vec![self.root];
            while let Some(i) = stack.pop() {
                let node = &self.nodes[i as usize];
                if seen[i as usize] != 0 || node.flags & FREE != 0 {
                    return Err(format!("broad phase node {i} reached twice or free"));
                }
                seen[i as usize] = 2;
                if node.is_leaf() {
                    leaves += 1;
                    if node.child[1] != NULL || node.height != 0 {
                        return Err(format!("broad phase leaf {i} with one child or a height"));
                    }
                } else {
                    for c in node.child {
                        if !in_nodes(c) || self.nodes[c as usize].parent != i {
                            return Err(format!("broad phase node {i}: child {c}"));
                        }
                        stack.push(c);
                    }
                }
            }
        }
        if seen.contains(&0) {
            return Err("a broad phase node neither in the tree nor free".into());
        }
        // Heights (the rotations that balance the tree read them): one more
        // than the taller child's.
        for (i, node) in self.nodes.iter().enumerate().filter(|&(i, n)| seen[i] == 2 && !n.is_leaf()) {
            let [a, b] = node.child.map(|c| self.nodes[c as usize].height);
            // (Checked: a forged child may stand at `u32::MAX`.)
            if a.max(b).checked_add(1) != Some(node.height) {
                return Err(format!("broad phase node {i}: height {}", node.height));
            }
        }
        if leaves != self.proxy_count {
            return Err(format!("broad phase: {leaves} leaves for {} proxies", self.proxy_count));
        }
        // Pairs: the free ones chained through `links.next[0]`, the live
        // ones in both proxies' lists.
        let np = self.pairs.len();
        let mut live = vec![true; np];
        let mut free = self.free_pair;
        let mut steps = 0;
        while free != NULL {
            if free as usize >= np || !live[free as usize] {
                return Err(format!("broad phase free pair {free}"));
            }
            live[free as usize] = false;
            free = self.pairs[free as usize].links.next[0];
            steps += 1;
            if steps > np {
                return Err("broad phase free pairs in a loop".into());
            }
        }
        let mut count = 0;
        for (k, p) in self.pairs.iter().enumerate().filter(|&(k, _)| live[k]) {
            count += 1;
            for (s, &q) in p.proxy.iter().enumerate() {
                let leaf = self.nodes.get(q as usize).is_some_and(|node| seen[q as usize] == 2 && node.is_leaf());
                let links_ok = [p.links.next[s], p.links.prev[s]].iter().all(|&l| l == NULL || (l as usize) < np);
                if !leaf || !links_ok {
                    return Err(format!("broad phase pair {k}: proxy {q}"));
                }
            }
            if p.proxy[0] == p.proxy[1] {
                return Err(format!("broad phase pair {k} of a proxy with itself"));
            }
        }
        if count != self.pair_count {
            return Err(format!("broad phase: {count} pairs for {}", self.pair_count));
        }
        // Each proxy's pairs: a chain from its first pair, both ways,
        // reaching every live pair once from each of its two proxies.
        let mut visits = vec![0u8; np];
        for (i, node) in self.nodes.iter().enumerate() {
            let proxy = i as u32;
            let (mut k, mut prev, mut steps) = (node.first_pair, NULL, 0);
            if k != NULL && !(seen[i] == 2 && node.is_leaf()) {
                return Err(format!("broad phase node {i} has pairs but is no proxy"));
            }
            while k != NULL {
                let Some(p) = self.pairs.get(k as usize).filter(|_| live[k as usize]) else {
                    return Err(format!("broad phase proxy {i}: pair {k}"));
                };
                if p.proxy[0] != proxy && p.proxy[1] != proxy {
                    return Err(format!("broad phase proxy {i}: pair {k} of other proxies"));
                }
                let side = p.side(proxy);
                if p.links.prev[side] != prev {
                    return Err(format!("broad phase pair {k}: its link back in proxy {i}'s list"));
                }
                visits[k as usize] += 1;
                steps += 1;
                if steps > np {
                    return Err(format!("broad phase proxy {i}'s pairs loop"));
                }
                (prev, k) = (k, p.links.next[side]);
            }
        }
        if (0..np).any(|k| live[k] && visits[k] != 2) {
            return Err("a broad phase pair not in both its proxies' lists".into());
        }
        let proxies = |list: &[u32]| list.iter().all(|&i| (i as usize) < n);
        let pairs = |list: &[(u32, u32)]| list.iter().all(|&(a, b)| (a as usize) < n && (b as usize) < n);
        if !proxies(&self.move_buffer)
            || !pairs(&self.new_pairs)
            || !pairs(&self.lost_pairs)
            || !pairs(&self.pending_lost)
        {
            return Err("broad phase moved proxies or pairs out of range".into());
        }
        Ok(())
    }

    /// Derives the flags that steer [`query_fixed`](Self::query_fixed)
    /// afresh, after a restore that [`check_restored`](Self::check_restored)
    /// passed (so that a tree whose heights hold is processed children
    /// first): each leaf's [`KINEMATIC`] from `kinematic(user)`, each
    /// internal node's [`HAS_FIXED`] from its leaves: a snapshot's own are
    /// not trusted (a snapshot of an earlier build has none; [`STATIC`],
    /// which decides pairs too, is checked against the bodies instead).
    pub(crate) fn restored(&mut self, kinematic: impl Fn(u32) -> bool) {
        let mut inner: Vec<u32> = (0..self.nodes.len() as u32)
            .filter(|&i| {
                let n = &self.nodes[i as usize];
                n.flags & FREE == 0 && !n.is_leaf()
            })
            .collect();
        for n in self.nodes.iter_mut() {
            n.flags &= !(HAS_FIXED | KINEMATIC);
            if n.flags & FREE == 0 && n.is_leaf() && kinematic(n.user) {
                n.flags |= KINEMATIC;
            }
        }
        inner.sort_by_key(|&i| self.nodes[i as usize].height);
        for i in inner {
            self.refit_fixed(i);
        }
    }

    /// [`HAS_FIXED`] of internal node `i` from its children's flags.
    fn refit_fixed(&mut self, i: u32) {
        let [c0, c1] = self.nodes[i as usize].child;
        let has_fixed = subtree_fixed(self.nodes[c0 as usize].flags | self.nodes[c1 as usize].flags);
        self.nodes[i as usize].flags |= has_fixed;
    }

    /// The collider of leaf `proxy`, if it is a leaf in the tree.
    pub(crate) fn leaf_user(&self, proxy: ProxyId) -> Option<u32> {
        let node = self.nodes.get(proxy.0 as usize)?;
        (node.is_leaf() && node.flags & FREE == 0).then_some(node.user)
    }
}

#[cfg(test)]
impl BroadPhase {
    /// Tests: sets node `proxy`'s height, to forge a snapshot's tree.
    pub(crate) fn set_height(&mut self, proxy: ProxyId, height: u32) {
        self.nodes[proxy.0 as usize].height = height;
    }

    /// Tests: forges the flags `restored` derives: `kinematic` loses its
    /// flag, every internal node its [`HAS_FIXED`], and the leaf
    /// `dynamic` takes one.
    pub(crate) fn forge_fixed_flags(&mut self, kinematic: ProxyId, dynamic: ProxyId) {
        self.nodes[kinematic.0 as usize].flags &= !KINEMATIC;
        for n in self.nodes.iter_mut() {
            n.flags &= !HAS_FIXED;
        }
        self.nodes[dynamic.0 as usize].flags |= HAS_FIXED;
    }

    /// Tests: flags leaf `proxy` static, to forge a snapshot's tree.
    pub(crate) fn forge_static(&mut self, proxy: ProxyId) {
        self.nodes[proxy.0 as usize].flags |= STATIC;
    }

    /// Tests: sets the height of every node in the tree that is not a
    /// leaf, to forge a snapshot's tree.
    pub(crate) fn set_inner_heights(&mut self, height: u32) {
        for node in self.nodes.iter_mut().filter(|n| n.flags & FREE == 0 && !n.is_leaf()) {
            node.height = height;
        }
    }
}
