//! Islands: groups of awake dynamic bodies linked by touching contacts,
//! found with union-find each step. An island falls asleep as a unit and
//! wakes as a unit; static bodies never link islands (a wall and a pile of
//! rubble both resting on the ground are separate islands).

/// Union-find over body slot indices with path halving and union by size.
/// Buffers are kept between steps (no allocation in steady state).
#[derive(Clone, Default)]
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

/// How many layers of bodies the deepest stack of the step has: the
/// longest shortest path, counted in contacts, from an immovable body
/// (static, kinematic) to a moving one, through the contacts handed to the
/// solver. One box on the ground is 1, the 10-row wall is 10.
///
/// Gauss–Seidel moves a load one contact per pass, so the passes a substep
/// needs before the velocities of a stack are consistent grow with this
/// depth (see `WorldSettings::relax_per_layer`). Bodies that no path
/// reaches (a cluster in flight) do not count: nothing holds them up.
///
/// A breadth-first search over the contact graph stored in compressed rows:
/// O(bodies + contacts) per step, buffers kept between steps.
#[derive(Default)]
pub(crate) struct StackDepth {
    start: Vec<u32>,
    adjacent: Vec<u32>,
    level: Vec<u32>,
    queue: Vec<u32>,
}

impl StackDepth {
    /// The deepest layer among `bodies` solver slots linked by `pairs`;
    /// `immovable(i)` says whether slot `i` holds the stack up.
    pub fn deepest(
        &mut self,
        bodies: usize,
        pairs: impl Iterator<Item = (u32, u32)> + Clone,
        immovable: impl Fn(usize) -> bool,
    ) -> u32 {
        // Compressed rows: count each body's contacts, prefix-sum, fill.
        self.start.clear();
        self.start.resize(bodies + 1, 0);
        for (a, b) in pairs.clone() {
            self.start[a as usize + 1] += 1;
            self.start[b as usize + 1] += 1;
        }
        for i in 0..bodies {
            self.start[i + 1] += self.start[i];
        }
        self.adjacent.clear();
        self.adjacent.resize(self.start[bodies] as usize, 0);
        // `level` doubles as the fill cursor before it holds the levels.
        self.level.clear();
        self.level.extend_from_slice(&self.start[..bodies]);
        for (a, b) in pairs {
            let (a, b) = (a as usize, b as usize);
            self.adjacent[self.level[a] as usize] = b as u32;
            self.level[a] += 1;
            self.adjacent[self.level[b] as usize] = a as u32;
            self.level[b] += 1;
        }
        // Breadth-first from every immovable body at level 0.
        self.queue.clear();
        for i in 0..bodies {
            if immovable(i) {
                self.level[i] = 0;
                self.queue.push(i as u32);
            } else {
                self.level[i] = u32::MAX;
            }
        }
        let (mut head, mut deepest) = (0, 0);
        while head < self.queue.len() {
            let i = self.queue[head] as usize;
            head += 1;
            let next = self.level[i] + 1;
            for k in self.start[i]..self.start[i + 1] {
                let j = self.adjacent[k as usize] as usize;
                if self.level[j] == u32::MAX {
                    self.level[j] = next;
                    deepest = deepest.max(next);
                    self.queue.push(j as u32);
                }
            }
        }
        deepest
    }

    /// The layer of slot `i` found by the last [`deepest`](Self::deepest):
    /// 0 for an immovable body, 0 too for a body that no path reaches
    /// (nothing holds it up).
    pub fn layer(&self, i: usize) -> u32 {
        match self.level.get(i) {
            Some(&l) if l != u32::MAX => l,
            _ => 0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::StackDepth;

    /// A column of three on the ground (slot 0), a pair in flight (4, 5)
    /// and a body alone (6): the column's top is layer 3; the pair and the
    /// lone body are not held up, so they do not count.
    #[test]
    fn depth_counts_layers_from_the_support() {
        let pairs = [(0u32, 1u32), (1, 2), (3, 2), (4, 5)];
        let mut d = StackDepth::default();
        assert_eq!(d.deepest(7, pairs.iter().copied(), |i| i == 0), 3);
        assert_eq!([0, 1, 2, 3, 4, 5, 6].map(|i| d.layer(i)), [0, 1, 2, 3, 0, 0, 0]);
        // Slot 3 made kinematic holds the top up directly: 1 layer.
        assert_eq!(d.deepest(7, pairs.iter().copied(), |i| i == 0 || i == 3), 1);
        // Nothing immovable: nothing is a stack.
        assert_eq!(d.deepest(7, pairs.iter().copied(), |_| false), 0);
        // No contacts at all.
        assert_eq!(d.deepest(3, std::iter::empty(), |i| i == 0), 0);
    }
}

crate::snapshot::codec::persist!(UnionFind { parent, size });

impl UnionFind {
    /// Checks a restored union–find over `n` items: parents in range and
    /// every chain ending at a root (no loop).
    pub(crate) fn check_restored(&self, n: usize) -> Result<(), String> {
        let len = self.parent.len();
        if len != n || self.size.len() != len || self.parent.iter().any(|&p| p as usize >= len) {
            return Err("islands' union–find out of range".into());
        }
        // Depth of each item's chain, memoised: a chain longer than `len`
        // loops.
        let mut depth = vec![u32::MAX; len];
        for start in 0..len {
            let mut x = start;
            let mut path = Vec::new();
            while depth[x] == u32::MAX && self.parent[x] as usize != x {
                path.push(x);
                if path.len() > len {
                    return Err("islands' union–find loops".into());
                }
                x = self.parent[x] as usize;
            }
            let base = if self.parent[x] as usize == x { 0 } else { depth[x] };
            depth[x] = base;
            for (k, &y) in path.iter().rev().enumerate() {
                depth[y] = base + k as u32 + 1;
            }
        }
        Ok(())
    }
}
