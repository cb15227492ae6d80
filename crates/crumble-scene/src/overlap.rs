//! The overlap check of a scene's planned bodies: every pair that overlaps
//! by more than the tolerance is an error, found in O(n log n) with a
//! bounding-volume tree so that a column of a million boxes is checked in
//! seconds.

use std::collections::HashSet;

use crumble::collision::contact_manifold;
use crumble::{Aabb, Pose, Shape};

use crate::error::{at_path, KeyPath, SceneError};
use crate::spec::Scene;

/// Overlap tolerated between two planned bodies near the origin, metres:
/// bodies that exactly touch (bricks in a wall) are fine, and so is the
/// rounding of their computed positions.
pub const OVERLAP_TOLERANCE: f32 = 1e-4;

/// The overlap tolerated for a body whose largest coordinate is `scale`
/// metres (in absolute value): [`OVERLAP_TOLERANCE`], or two `f32`
/// epsilons of `scale` (2 to 4 units in the last place of the coordinate)
/// when that is more. Far from the origin an `f32` position is rounded by
/// more than 0.1 mm (by 0.24 mm at 2048 m, by 7.8 mm at 100 km), so
/// bricks laid edge to edge there overlap by up to a unit in the last
/// place; from about 420 m on the tolerance follows the coordinates.
pub fn overlap_tolerance(scale: f32) -> f32 {
    OVERLAP_TOLERANCE.max(2.0 * f32::EPSILON * scale.abs())
}

/// The tolerance of a body whose bounding box is `bb`.
fn tolerance_of(bb: &Aabb) -> f32 {
    overlap_tolerance(bb.min.abs().max(bb.max.abs()).max_element())
}

/// Bodies that a joint keeps from colliding (`collide_connected = false`),
/// and so may overlap at the start: pairs of indices into the checked
/// bodies (lower first), and bodies joined to the ground.
#[derive(Default)]
pub(crate) struct Joined {
    pub pairs: HashSet<(usize, usize)>,
    pub to_ground: HashSet<usize>,
}

/// A body to check: where it is, what it is called, and what made it.
pub(crate) struct Placed<'a> {
    pub shape: &'a Shape,
    pub pose: &'a Pose,
    pub name: &'a str,
    pub path: &'a KeyPath,
}

/// Rejects the plan when two bodies, or a body and the ground, overlap by
/// more than their tolerance ([`overlap_tolerance`], the larger of the
/// pair's). Candidate pairs are those whose bounding boxes, each shrunk by
/// a quarter of its tolerance, still overlap (a pair that overlaps by more
/// than the tolerance overlaps by at least as much along every axis); each
/// is checked exactly with the narrow phase, so that rotated walls whose
/// bricks only touch pass. Reports the pair whose first body comes first
/// in the plan (then the second), at the second body's key. Pairs in
/// `joined` are not checked: they never collide.
pub(crate) fn check_overlaps(
    scene: &Scene,
    bodies: &[Placed],
    ground: Option<&(f32, KeyPath)>,
    joined: &Joined,
) -> Result<(), SceneError> {
    let aabbs: Vec<Aabb> = bodies.iter().map(|b| b.shape.aabb(b.pose)).collect();
    let tolerances: Vec<f32> = aabbs.iter().map(tolerance_of).collect();
    if let Some((height, gpath)) = ground {
        for (i, ((b, bb), &tol)) in bodies.iter().zip(&aabbs).zip(&tolerances).enumerate() {
            if joined.to_ground.contains(&i) {
                continue;
            }
            let depth = height - bb.min.y;
            if depth > tol {
                let msg = format!("body `{}` reaches {depth:.4} m into the ground (`{gpath}` at y = {height})", b.name);
                return Err(at_path(&scene.file, &scene.source, b.path, msg));
            }
        }
    }
    let shrunk: Vec<Aabb> = aabbs.iter().zip(&tolerances).map(|(bb, &tol)| bb.expanded(-0.25 * tol)).collect();
    // A body smaller than its tolerance cannot overlap anything by more.
    let items: Vec<u32> =
        (0..bodies.len() as u32).filter(|&i| shrunk[i as usize].min.cmplt(shrunk[i as usize].max).all()).collect();
    let tree = BoxTree::new(&shrunk, items.clone());
    let mut candidates = Vec::new();
    for &i in &items {
        let i = i as usize;
        candidates.clear();
        tree.query(&shrunk[i], |j| {
            if j as usize > i {
                candidates.push(j as usize);
            }
        });
        candidates.sort_unstable();
        for &j in &candidates {
            if joined.pairs.contains(&(i, j)) {
                continue;
            }
            let (a, b) = (&bodies[i], &bodies[j]);
            let tol = tolerances[i].max(tolerances[j]);
            let m = contact_manifold(a.shape, a.pose, b.shape, b.pose, 0.0);
            let Some(sep) = m.min_separation() else { continue };
            if sep < -tol {
                let at = |b: &Placed| {
                    let p = b.pose.position;
                    format!("`{}` (from `{}`, at [{:.3}, {:.3}, {:.3}])", b.name, b.path, p.x, p.y, p.z)
                };
                let msg = format!(
                    "generated bodies overlap by {:.4} m (more than the {tol:.4} m tolerated there): {} and {}",
                    -sep,
                    at(a),
                    at(b)
                );
                return Err(at_path(&scene.file, &scene.source, b.path, msg));
            }
        }
    }
    Ok(())
}

/// Most boxes in a leaf of [`BoxTree`].
const LEAF_SIZE: usize = 4;

/// A node of [`BoxTree`]: its bounds and either its children or (a leaf)
/// its range of `order`.
struct Node {
    bounds: Aabb,
    /// Children, or `None` for a leaf.
    children: Option<(u32, u32)>,
    /// The leaf's boxes: `order[start..end]`.
    start: u32,
    end: u32,
}

/// A bounding-volume tree over fixed boxes, built by median splits along
/// the longest axis of the boxes' centres: height about log2(n / 4), so a
/// query costs O(log n) plus the boxes it finds, whatever the layout
/// (columns, walls and grids alike).
struct BoxTree<'a> {
    boxes: &'a [Aabb],
    order: Vec<u32>,
    nodes: Vec<Node>,
}

impl<'a> BoxTree<'a> {
    /// A tree over `boxes[i]` for each `i` of `items`.
    fn new(boxes: &'a [Aabb], items: Vec<u32>) -> Self {
        let mut tree = BoxTree { boxes, nodes: Vec::with_capacity(2 * items.len() / LEAF_SIZE + 1), order: items };
        if !tree.order.is_empty() {
            tree.build(0, tree.order.len());
        }
        tree
    }

    /// Builds the node over `order[start..end]`; returns its index.
    fn build(&mut self, start: usize, end: usize) -> u32 {
        let boxes = self.boxes;
        let slice = &mut self.order[start..end];
        let first = boxes[slice[0] as usize];
        let bounds = slice.iter().fold(first, |acc, &i| acc.union(&boxes[i as usize]));
        let index = self.nodes.len() as u32;
        self.nodes.push(Node { bounds, children: None, start: start as u32, end: end as u32 });
        if end - start <= LEAF_SIZE {
            return index;
        }
        let c0 = first.center();
        let (lo, hi) = slice.iter().fold((c0, c0), |(lo, hi), &i| {
            let c = boxes[i as usize].center();
            (lo.min(c), hi.max(c))
        });
        let spread = hi - lo;
        let axis = if spread.x >= spread.y && spread.x >= spread.z {
            0
        } else if spread.y >= spread.z {
            1
        } else {
            2
        };
        let mid = (end - start) / 2;
        slice.select_nth_unstable_by(mid, |&a, &b| {
            boxes[a as usize].center()[axis].total_cmp(&boxes[b as usize].center()[axis])
        });
        let left = self.build(start, start + mid);
        let right = self.build(start + mid, end);
        self.nodes[index as usize].children = Some((left, right));
        index
    }

    /// Calls `found` with every box that overlaps `query` with a positive
    /// depth along every axis (touching is not overlapping).
    fn query(&self, query: &Aabb, mut found: impl FnMut(u32)) {
        let deep = |a: &Aabb, b: &Aabb| a.min.cmplt(b.max).all() && b.min.cmplt(a.max).all();
        if self.nodes.is_empty() {
            return;
        }
        let mut stack = vec![0u32];
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n as usize];
            if !deep(&node.bounds, query) {
                continue;
            }
            match node.children {
                Some((left, right)) => stack.extend([left, right]),
                None => {
                    for &i in &self.order[node.start as usize..node.end as usize] {
                        if deep(&self.boxes[i as usize], query) {
                            found(i);
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crumble::Vec3;

    /// The tree finds exactly the pairs a test of every pair finds, for a
    /// jumble of boxes of mixed sizes.
    #[test]
    fn the_tree_finds_every_overlapping_pair() {
        let mut seed = 12345u32;
        let mut next = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32
        };
        let boxes: Vec<Aabb> = (0..500)
            .map(|_| {
                let c = Vec3::new(next(), next(), next()) * 10.0;
                let h = Vec3::new(next(), next(), next()) * if next() < 0.05 { 3.0 } else { 0.4 };
                Aabb::from_center_half_extents(c, h)
            })
            .collect();
        let tree = BoxTree::new(&boxes, (0..boxes.len() as u32).collect());
        let deep = |a: &Aabb, b: &Aabb| a.min.cmplt(b.max).all() && b.min.cmplt(a.max).all();
        let mut pairs = 0;
        for i in 0..boxes.len() {
            let mut found = Vec::new();
            tree.query(&boxes[i], |j| found.push(j as usize));
            found.sort_unstable();
            let want: Vec<usize> = (0..boxes.len()).filter(|&j| deep(&boxes[i], &boxes[j])).collect();
            assert_eq!(found, want, "box {i}");
            pairs += want.len();
        }
        assert!(pairs > 2 * boxes.len(), "too few overlaps to test: {pairs}");
    }
}
