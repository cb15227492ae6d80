//! Islands: groups of awake dynamic bodies linked by touching contacts,
//! found with union-find each step. An island falls asleep as a unit and
//! wakes as a unit; static bodies never link islands (a wall and a pile of
//! rubble both resting on the ground are separate islands).

/// Union-find over body slot indices with path halving and union by size.
/// Buffers are kept between steps (no allocation in steady state).
#[derive(Default)]
pub(crate) struct UnionFind {
    parent: Vec<u32>,
    size: Vec<u32>,
}

impl UnionFind {
    /// Resets for `n` elements, each its own set.
    pub fn reset(&mut self, n: usize) {
        self.parent.clear();
        self.parent.extend(0..n as u32);
        self.size.clear();
        self.size.resize(n, 1);
    }

    pub fn find(&mut self, mut x: u32) -> u32 {
        while self.parent[x as usize] != x {
            let p = self.parent[x as usize];
            self.parent[x as usize] = self.parent[p as usize];
            x = self.parent[x as usize];
        }
        x
    }

    pub fn union(&mut self, a: u32, b: u32) {
        let (mut ra, mut rb) = (self.find(a), self.find(b));
        if ra == rb {
            return;
        }
        // Deterministic tie-break keeps the result independent of anything
        // but the order of unions, which is itself deterministic.
        if self.size[ra as usize] < self.size[rb as usize]
            || (self.size[ra as usize] == self.size[rb as usize] && rb < ra)
        {
            std::mem::swap(&mut ra, &mut rb);
        }
        self.parent[rb as usize] = ra;
        self.size[ra as usize] += self.size[rb as usize];
    }
}
