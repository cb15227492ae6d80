//! Snapshots: the whole state of a [`World`] as bytes, and a world
//! restored from them that continues bit for bit.
//!
//! [`World::snapshot`] writes everything that can change a future bit:
//! the bodies, colliders, joints and bonds in their arenas (with each
//! slot's generation and the free lists, so that handles stay valid and
//! the next insertions take the same slots), the broad phase's tree and
//! pairs, the contacts with their slots, order, links, manifolds,
//! recycling caches and warm-start impulses, the awake set and sleeping
//! islands, and what the solver keeps between steps (each body's
//! reference orientation, the partition of the constraints, and every
//! kept constraint's geometry). What a step rebuilds from these is
//! per-step scratch, and is not written.
//!
//! [`World::restore`] reads them back, refusing anything it cannot
//! vouch for with a [`SnapshotError`]: bytes of another kind, version or
//! layout, a truncated or corrupted file, and indices or numbers that
//! do not hold together. It never panics on any input.
//!
//! The format (`docs/snapshot.md` documents it field by field):
//!
//! | bytes | what |
//! |---|---|
//! | 8 | magic, `CRUMBLE` and a 0 byte |
//! | 4 | format version ([`SNAPSHOT_VERSION`]) |
//! | 8 | hash of the layout: every saved field's name and type, in order |
//! | 8 | payload length |
//! | … | payload: the world's state, little-endian, floats as their bits |
//! | 8 | checksum of everything before it |
//!
//! Every struct of the world lists each of its fields once, as saved or
//! as scratch (`persist!` in `codec.rs`); the layout hash is made from
//! those lists, so a build whose saved fields differ refuses the other's
//! snapshots instead of misreading them.
//!
//! The number of threads is not part of a snapshot: a world restored
//! runs on the default threads ([`WorldSettings::threads`] 0), and
//! [`World::set_threads`] changes them without changing a bit.
//!
//! [`WorldSettings::threads`]: crate::WorldSettings::threads

pub(crate) mod codec;
mod parts;
#[cfg(test)]
mod tests;

use std::sync::OnceLock;

use crate::World;
use codec::{Persist, Reader, Writer};

/// The format's checksum of `bytes` (see the module docs): what the last
/// eight bytes of a snapshot hold for every byte before them. For tools
/// that write or inspect snapshots (the fuzz target seals arbitrary
/// payloads with it).
pub fn checksum(bytes: &[u8]) -> u64 {
    codec::checksum(bytes)
}

/// `payload` sealed as a snapshot of this build: the header (magic,
/// version, layout hash, length) before it and the checksum after, as
/// [`World::snapshot`] writes them; the payload is then what restore
/// decodes. For tools that make snapshot contents (the fuzz target seals
/// arbitrary bytes with it, and `examples/fuzz_seeds.rs` checks its seeds).
pub fn seal(payload: &[u8]) -> Vec<u8> {
    let mut w = Writer { bytes: Vec::with_capacity(HEADER + payload.len() + 8) };
    write_header(&mut w, payload.len() as u64);
    w.bytes.extend_from_slice(payload);
    let sum = checksum(&w.bytes);
    w.u64(sum);
    w.bytes
}

/// The header of a snapshot whose payload is `payload` bytes long.
fn write_header(w: &mut Writer, payload: u64) {
    w.bytes.extend_from_slice(&SNAPSHOT_MAGIC);
    w.u32(SNAPSHOT_VERSION);
    w.u64(snapshot_layout_hash());
    w.u64(payload);
}

/// The format version a snapshot is written in and the one restore reads.
pub const SNAPSHOT_VERSION: u32 = 1;

/// The first bytes of every snapshot.
pub const SNAPSHOT_MAGIC: [u8; 8] = *b"CRUMBLE\0";

/// Magic, version, layout hash and payload length.
const HEADER: usize = 8 + 4 + 8 + 8;

/// Why [`World::restore`] refused its bytes.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum SnapshotError {
    /// No bytes at all.
    #[error("the snapshot is empty")]
    Empty,
    /// The bytes do not begin as a snapshot does.
    #[error("not a crumble snapshot (its first bytes are not \"CRUMBLE\\0\")")]
    NotASnapshot,
    /// A snapshot of another format version.
    #[error("a snapshot of format version {found}; this crumble reads version {supported}")]
    Version {
        /// The snapshot's version.
        found: u32,
        /// The version this build reads.
        supported: u32,
    },
    /// A snapshot written by a build whose saved fields differ.
    #[error("a snapshot of another layout (hash {found:#018x}; this build's is {expected:#018x}): written by another version of crumble")]
    Layout {
        /// The snapshot's layout hash.
        found: u64,
        /// This build's.
        expected: u64,
    },
    /// The bytes end before the snapshot does.
    #[error("the snapshot is truncated: {len} bytes where at least {needed} are needed")]
    Truncated {
        /// Bytes needed to go on reading.
        needed: usize,
        /// Bytes there are.
        len: usize,
    },
    /// The bytes are not those that were written (the checksum differs).
    #[error("the snapshot is corrupted (its checksum does not match its contents)")]
    Corrupted,
    /// The bytes read back as a world whose parts do not hold together.
    #[error("the snapshot does not describe a valid world: {what}")]
    Invalid {
        /// What does not hold, and where.
        what: String,
    },
}

/// This build's layout hash (see the module docs).
pub fn snapshot_layout_hash() -> u64 {
    static HASH: OnceLock<u64> = OnceLock::new();
    *HASH.get_or_init(|| {
        let mut layout = String::new();
        World::layout(&mut layout);
        checksum(layout.as_bytes())
    })
}

impl World {
    /// The world's whole state as bytes (see the [module docs](self)):
    /// [`restore`](Self::restore) gives back a world that continues bit for
    /// bit as this one does, on any number of threads. A snapshot of a
    /// restored world, before it steps, is the same bytes.
    ///
    /// About 1 KB per body for a wall of bricks mid-collapse
    /// (`docs/snapshot.md` measures it); a sleeping world takes less.
    pub fn snapshot(&self) -> Vec<u8> {
        let mut w = Writer { bytes: Vec::with_capacity(self.snapshot_size_hint()) };
        // The payload's length is filled in once it is written.
        write_header(&mut w, 0);
        self.save(&mut w);
        let payload = (w.bytes.len() - HEADER) as u64;
        w.bytes[HEADER - 8..HEADER].copy_from_slice(&payload.to_le_bytes());
        let sum = checksum(&w.bytes);
        w.u64(sum);
        w.bytes
    }

    /// A world from [`snapshot`](Self::snapshot)'s bytes, on the default
    /// threads ([`set_threads`](Self::set_threads) changes them). Refuses
    /// bytes of another kind, version or layout, a truncated or corrupted
    /// snapshot, and one whose contents do not hold together, with an
    /// error that says which; never panics.
    pub fn restore(bytes: &[u8]) -> Result<World, SnapshotError> {
        if bytes.is_empty() {
            return Err(SnapshotError::Empty);
        }
        let magic = &bytes[..bytes.len().min(8)];
        if magic != &SNAPSHOT_MAGIC[..magic.len()] {
            return Err(SnapshotError::NotASnapshot);
        }
        let mut r = Reader::new(bytes);
        r.take::<8>()?;
        let version = r.u32()?;
        if version != SNAPSHOT_VERSION {
            return Err(SnapshotError::Version { found: version, supported: SNAPSHOT_VERSION });
        }
        let layout = r.u64()?;
        if layout != snapshot_layout_hash() {
            return Err(SnapshotError::Layout { found: layout, expected: snapshot_layout_hash() });
        }
        let payload = r.u64()?;
        let total = usize::try_from(payload).ok().and_then(|p| p.checked_add(HEADER + 8));
        match total {
            Some(total) if total == bytes.len() => {}
            Some(total) if total > bytes.len() => {
                return Err(SnapshotError::Truncated { needed: total, len: bytes.len() });
            }
            _ => {
                return Err(SnapshotError::Invalid {
                    what: format!("a payload of {payload} bytes in a file of {}", bytes.len()),
                })
            }
        }
        let (body, sum) = bytes.split_at(bytes.len() - 8);
        if checksum(body) != u64::from_le_bytes(sum.try_into().expect("8 bytes")) {
            return Err(SnapshotError::Corrupted);
        }
        let mut r = Reader::new(&body[HEADER..]);
        let world = World::load(&mut r)?;
        if r.left() != 0 {
            return Err(SnapshotError::Invalid { what: format!("{} bytes after the world", r.left()) });
        }
        Ok(world)
    }

    /// Empties every part's per-step scratch, as a restored world's is:
    /// the world must go on bit for bit (`snapshot/tests.rs` checks it
    /// mid-run).
    #[cfg(test)]
    pub(crate) fn wipe_scratch(&mut self) {
        Persist::wipe(self);
    }
}
