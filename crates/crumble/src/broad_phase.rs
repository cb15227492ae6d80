//! TEMPORARY brute-force stand-in with the agreed API; replaced by the
//! dynamic AABB tree from the broad-phase branch.
use crate::aabb::Aabb;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ProxyId(pub u32);

#[derive(Default)]
pub struct BroadPhase {
    margin: f32,
    proxies: Vec<Option<(Aabb, u32)>>,
    pairs: std::collections::BTreeSet<(u32, u32)>,
    new_pairs: Vec<(u32, u32)>,
    lost_pairs: Vec<(u32, u32)>,
}

impl BroadPhase {
    pub fn new(margin: f32) -> Self {
        Self { margin, ..Default::default() }
    }
    pub fn insert(&mut self, aabb: Aabb, user: u32) -> ProxyId {
        self.proxies.push(Some((aabb.expanded(self.margin), user)));
        ProxyId(self.proxies.len() as u32 - 1)
    }
    pub fn remove(&mut self, id: ProxyId) {
        self.proxies[id.0 as usize] = None;
    }
    pub fn update(&mut self, id: ProxyId, aabb: Aabb) -> bool {
        let p = self.proxies[id.0 as usize].as_mut().unwrap();
        if p.0.contains(&aabb) {
            return false;
        }
        p.0 = aabb.expanded(self.margin);
        true
    }
    pub fn update_pairs_filtered(&mut self, filter: impl Fn(u32, u32) -> bool) {
        let mut now = std::collections::BTreeSet::new();
        for (i, a) in self.proxies.iter().enumerate() {
            let Some(a) = a else { continue };
            for b in self.proxies[i + 1..].iter().flatten() {
                if a.0.overlaps(&b.0) {
                    let k = (a.1.min(b.1), a.1.max(b.1));
                    if filter(k.0, k.1) {
                        now.insert(k);
                    }
                }
            }
        }
        self.new_pairs = now.difference(&self.pairs).copied().collect();
        self.lost_pairs = self.pairs.difference(&now).copied().collect();
        self.pairs = now;
    }
    pub fn new_pairs(&self) -> &[(u32, u32)] {
        &self.new_pairs
    }
    pub fn lost_pairs(&self) -> &[(u32, u32)] {
        &self.lost_pairs
    }
}
