//! A generational arena: slots in a `Vec`, reused through a free list, each
//! tagged with a generation that is bumped on removal so that a stale handle
//! to a removed (and possibly reused) slot is detected instead of silently
//! pointing at another object.

/// Index plus generation. Wrapped by the typed handles of the public API.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub(crate) struct RawHandle {
    pub index: u32,
    pub generation: u32,
}

#[derive(Clone, Debug)]
struct Slot<T> {
    generation: u32,
    value: Option<T>,
}

/// Storage for `T` addressed by [`RawHandle`].
#[derive(Clone, Debug)]
pub(crate) struct Arena<T> {
    slots: Vec<Slot<T>>,
    free: Vec<u32>,
    len: usize,
}

impl<T> Default for Arena<T> {
    fn default() -> Self {
        Self { slots: Vec::new(), free: Vec::new(), len: 0 }
    }
}

impl<T> Arena<T> {
    pub fn insert(&mut self, value: T) -> RawHandle {
        self.len += 1;
        if let Some(index) = self.free.pop() {
            let slot = &mut self.slots[index as usize];
            slot.value = Some(value);
            RawHandle { index, generation: slot.generation }
        } else {
            let index = self.slots.len() as u32;
            self.slots.push(Slot { generation: 0, value: Some(value) });
            RawHandle { index, generation: 0 }
        }
    }

    /// The slot index the next `insert` will use.
    pub fn next_index(&self) -> u32 {
        self.free.last().copied().unwrap_or(self.slots.len() as u32)
    }

    pub fn remove(&mut self, h: RawHandle) -> Option<T> {
        let slot = self.slots.get_mut(h.index as usize)?;
        if slot.generation != h.generation || slot.value.is_none() {
            return None;
        }
        slot.generation = slot.generation.wrapping_add(1);
        self.free.push(h.index);
        self.len -= 1;
        slot.value.take()
    }

    pub fn get(&self, h: RawHandle) -> Option<&T> {
        let slot = self.slots.get(h.index as usize)?;
        if slot.generation != h.generation {
            return None;
        }
        slot.value.as_ref()
    }

    pub fn get_mut(&mut self, h: RawHandle) -> Option<&mut T> {
        let slot = self.slots.get_mut(h.index as usize)?;
        if slot.generation != h.generation {
            return None;
        }
        slot.value.as_mut()
    }

    /// The live value in slot `index`, whatever its generation.
    #[inline]
    pub fn at(&self, index: u32) -> Option<&T> {
        self.slots.get(index as usize)?.value.as_ref()
    }

    #[inline]
    pub fn at_mut(&mut self, index: u32) -> Option<&mut T> {
        self.slots.get_mut(index as usize)?.value.as_mut()
    }

    /// The handle of the live value in slot `index`.
    pub fn handle_at(&self, index: u32) -> Option<RawHandle> {
        let slot = self.slots.get(index as usize)?;
        slot.value.as_ref().map(|_| RawHandle { index, generation: slot.generation })
    }

    pub fn len(&self) -> usize {
        self.len
    }

    /// Slots, live or free: one past the largest index in use.
    pub fn slot_count(&self) -> usize {
        self.slots.len()
    }

    /// Live values in slot order (deterministic).
    pub fn iter(&self) -> impl Iterator<Item = (RawHandle, &T)> {
        self.slots
            .iter()
            .enumerate()
            .filter_map(|(i, s)| s.value.as_ref().map(|v| (RawHandle { index: i as u32, generation: s.generation }, v)))
    }
}

/// An arena's slots shared by threads that each reach different indices
/// ([`Arena::shared`]): the step's per-body loops split the awake bodies
/// between threads, and each body is in the awake list once.
pub(crate) struct SharedArena<'a, T> {
    slots: crate::solver::SharedItems<'a, Slot<T>>,
}

impl<T> Arena<T> {
    /// The slots, for threads that reach disjoint indices
    /// ([`SharedArena::at_mut`]).
    pub fn shared(&mut self) -> SharedArena<'_, T> {
        SharedArena { slots: crate::solver::SharedItems::new(&mut self.slots) }
    }
}

impl<T> SharedArena<'_, T> {
    /// The live value in slot `index` (as [`Arena::at_mut`]).
    ///
    /// # Safety
    /// No other thread reaches slot `index` meanwhile.
    #[inline]
    #[allow(clippy::mut_from_ref)]
    pub unsafe fn at_mut(&self, index: u32) -> Option<&mut T> {
        if index as usize >= self.slots.len() {
            return None;
        }
        // SAFETY: in bounds, and the caller's promise.
        unsafe { self.slots.part(index as usize..index as usize + 1)[0].value.as_mut() }
    }
}

impl<T: crate::snapshot::codec::Persist> crate::snapshot::codec::Persist for Arena<T> {
    fn save(&self, w: &mut crate::snapshot::codec::Writer) {
        w.len(self.slots.len());
        for s in &self.slots {
            s.generation.save(w);
            s.value.save(w);
        }
        self.free.save(w);
    }

    /// The slots and the free list (whose order decides the slots of the
    /// next insertions); the free list must name each empty slot once.
    fn load(r: &mut crate::snapshot::codec::Reader) -> Result<Self, crate::snapshot::SnapshotError> {
        use crate::snapshot::codec::{invalid, Persist};
        let n = r.len()?;
        let mut slots = Vec::with_capacity(n.min(1 << 16));
        for _ in 0..n {
            slots.push(Slot { generation: u32::load(r)?, value: Option::load(r)? });
        }
        let free: Vec<u32> = Persist::load(r)?;
        let mut seen = vec![false; n];
        for &i in &free {
            match slots.get(i as usize) {
                Some(s) if s.value.is_none() && !seen[i as usize] => seen[i as usize] = true,
                _ => return Err(invalid(format!("free slot {i} of an arena of {n}"))),
            }
        }
        let len = slots.iter().filter(|s| s.value.is_some()).count();
        if len + free.len() != n {
            return Err(invalid("an arena's empty slot missing from its free list"));
        }
        Ok(Arena { slots, free, len })
    }

    fn layout(out: &mut String) {
        out.push_str("Arena<");
        T::layout(out);
        out.push('>');
    }

    fn wipe(&mut self) {
        self.slots.iter_mut().filter_map(|s| s.value.as_mut()).for_each(T::wipe);
    }
}

impl crate::snapshot::codec::Persist for RawHandle {
    fn save(&self, w: &mut crate::snapshot::codec::Writer) {
        w.u32(self.index);
        w.u32(self.generation);
    }
    fn load(r: &mut crate::snapshot::codec::Reader) -> Result<Self, crate::snapshot::SnapshotError> {
        Ok(RawHandle { index: r.u32()?, generation: r.u32()? })
    }
    fn layout(out: &mut String) {
        out.push_str("Handle");
    }
}
