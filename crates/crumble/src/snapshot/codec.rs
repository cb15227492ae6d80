//! The snapshot's encoding: a [`Writer`] and a [`Reader`] of little-endian
//! numbers (floats as their bits), and [`Persist`], which every part of the
//! world implements to save itself, load itself, describe its layout and
//! wipe its per-step scratch.
//!
//! Most implementations come from [`persist!`](crate::snapshot::persist):
//! a struct names every field once, either as saved or as scratch, and the
//! macro writes the four functions from that list. The struct literal the
//! macro builds on loading names every field, so a field added to a struct
//! and forgotten in its `persist!` list is a compile error: each field is
//! decided to be state or scratch by whoever adds it.

use super::SnapshotError;
use crate::math::{Mat3, Quat, Vec3};

/// Bytes of a snapshot being written.
pub(crate) struct Writer {
    pub bytes: Vec<u8>,
}

impl Writer {
    #[inline]
    pub fn u8(&mut self, x: u8) {
        self.bytes.push(x);
    }
    #[inline]
    pub fn u32(&mut self, x: u32) {
        self.bytes.extend_from_slice(&x.to_le_bytes());
    }
    #[inline]
    pub fn u64(&mut self, x: u64) {
        self.bytes.extend_from_slice(&x.to_le_bytes());
    }
    #[inline]
    pub fn f32(&mut self, x: f32) {
        self.u32(x.to_bits());
    }
    /// A length or a count (as a `u32`: no list of the world reaches 2³²).
    #[inline]
    pub fn len(&mut self, n: usize) {
        self.u32(u32::try_from(n).expect("a list of the world has fewer than 2^32 items"));
    }
}

/// Bytes of a snapshot being read: every read checks that the bytes are
/// there, and every list's length is checked against the bytes left
/// before anything is allocated for it.
pub(crate) struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    pub fn new(bytes: &'a [u8]) -> Self {
        Reader { bytes, at: 0 }
    }

    /// Bytes not read yet.
    pub fn left(&self) -> usize {
        self.bytes.len() - self.at
    }

    #[inline]
    pub fn take<const N: usize>(&mut self) -> Result<[u8; N], SnapshotError> {
        let end = self.at.checked_add(N).filter(|&e| e <= self.bytes.len());
        let Some(end) = end else {
            return Err(SnapshotError::Truncated { needed: self.at + N, len: self.bytes.len() });
        };
        let out = self.bytes[self.at..end].try_into().expect("N bytes");
        self.at = end;
        Ok(out)
    }

    #[inline]
    pub fn u8(&mut self) -> Result<u8, SnapshotError> {
        Ok(self.take::<1>()?[0])
    }
    #[inline]
    pub fn u32(&mut self) -> Result<u32, SnapshotError> {
        Ok(u32::from_le_bytes(self.take()?))
    }
    #[inline]
    pub fn u64(&mut self) -> Result<u64, SnapshotError> {
        Ok(u64::from_le_bytes(self.take()?))
    }
    #[inline]
    pub fn f32(&mut self) -> Result<f32, SnapshotError> {
        Ok(f32::from_bits(self.u32()?))
    }

    /// A list's length: each item takes at least one byte, so a length
    /// beyond the bytes left is refused before any allocation.
    pub fn len(&mut self) -> Result<usize, SnapshotError> {
        let n = self.u32()? as usize;
        if n > self.left() {
            return Err(invalid(format!("a list of {n} items in the {} bytes left", self.left())));
        }
        Ok(n)
    }
}

/// [`SnapshotError::Invalid`] with `what`.
pub(crate) fn invalid(what: impl Into<String>) -> SnapshotError {
    SnapshotError::Invalid { what: what.into() }
}

/// A part of the world that a snapshot carries.
pub(crate) trait Persist: Sized {
    /// Appends the saved fields.
    fn save(&self, w: &mut Writer);
    /// Reads what [`save`](Self::save) wrote; scratch starts empty.
    fn load(r: &mut Reader) -> Result<Self, SnapshotError>;
    /// Appends a description of the saved layout (field names and types),
    /// hashed into the snapshot's header so that a snapshot of another
    /// layout is refused.
    fn layout(out: &mut String);
    /// Empties the per-step scratch, here and in the saved fields' parts.
    #[cfg_attr(not(test), allow(dead_code))]
    fn wipe(&mut self) {}
}

/// A part's saved bytes under its name (tests that say where two worlds
/// differ).
#[cfg(test)]
pub(crate) fn saved(name: &'static str, x: &impl Persist) -> (&'static str, Vec<u8>) {
    let mut w = Writer { bytes: Vec::new() };
    x.save(&mut w);
    (name, w.bytes)
}

/// One field's entry in a struct's layout (the field's type comes from the
/// accessor, so the macro need not name it).
pub(crate) fn field_layout<S, T: Persist>(out: &mut String, name: &str, _field: fn(&S) -> &T) {
    out.push_str(name);
    out.push(':');
    T::layout(out);
    out.push(',');
}

/// `Persist` for a struct: the fields it saves, in order, then (optional)
/// the fields that are per-step scratch, which load as their `Default`
/// and which [`Persist::wipe`] resets. Used in the struct's own module
/// (the fields may be private).
macro_rules! persist {
    ($ty:ident { $($f:ident),* $(,)? } $(scratch { $($s:ident),* $(,)? })?) => {
        impl $crate::snapshot::codec::Persist for $ty {
            fn save(&self, w: &mut $crate::snapshot::codec::Writer) {
                $( $crate::snapshot::codec::Persist::save(&self.$f, w); )*
            }
            fn load(
                r: &mut $crate::snapshot::codec::Reader,
            ) -> Result<Self, $crate::snapshot::SnapshotError> {
                Ok($ty {
                    $( $f: $crate::snapshot::codec::Persist::load(r)?, )*
                    $($( $s: Default::default(), )*)?
                })
            }
            fn layout(out: &mut String) {
                out.push_str(concat!(stringify!($ty), "{"));
                $( $crate::snapshot::codec::field_layout(out, stringify!($f), |s: &$ty| &s.$f); )*
                out.push('}');
            }
            fn wipe(&mut self) {
                $( $crate::snapshot::codec::Persist::wipe(&mut self.$f); )*
                $($( self.$s = Default::default(); )*)?
            }
        }
    };
}
pub(crate) use persist;

/// `Persist` for an enum without data: its variant's number, in the
/// order listed.
macro_rules! persist_enum {
    ($ty:ident { $($v:ident),* $(,)? }) => {
        impl $crate::snapshot::codec::Persist for $ty {
            fn save(&self, w: &mut $crate::snapshot::codec::Writer) {
                const ALL: &[$ty] = &[$($ty::$v),*];
                w.u8(ALL.iter().position(|v| v == self).expect("listed") as u8);
            }
            fn load(
                r: &mut $crate::snapshot::codec::Reader,
            ) -> Result<Self, $crate::snapshot::SnapshotError> {
                const ALL: &[$ty] = &[$($ty::$v),*];
                let k = r.u8()?;
                ALL.get(k as usize).copied().ok_or_else(|| {
                    $crate::snapshot::codec::invalid(format!(concat!("a ", stringify!($ty), " numbered {}"), k))
                })
            }
            fn layout(out: &mut String) {
                out.push_str(concat!(stringify!($ty), "(", $(stringify!($v), ","),* , ")"));
            }
        }
    };
}
pub(crate) use persist_enum;

macro_rules! persist_int {
    ($($t:ty => $w:ident, $name:literal);* $(;)?) => {$(
        impl Persist for $t {
            #[inline]
            fn save(&self, w: &mut Writer) {
                w.$w(*self as _);
            }
            #[inline]
            fn load(r: &mut Reader) -> Result<Self, SnapshotError> {
                let x = r.$w()?;
                <$t>::try_from(x).map_err(|_| invalid(concat!("a ", $name, " out of range")))
            }
            fn layout(out: &mut String) {
                out.push_str($name);
            }
        }
    )*};
}

persist_int! {
    u8 => u8, "u8";
    u32 => u32, "u32";
    u64 => u64, "u64";
    usize => u64, "usize";
}

impl Persist for f32 {
    #[inline]
    fn save(&self, w: &mut Writer) {
        w.f32(*self);
    }
    #[inline]
    fn load(r: &mut Reader) -> Result<Self, SnapshotError> {
        r.f32()
    }
    fn layout(out: &mut String) {
        out.push_str("f32");
    }
}

impl Persist for f64 {
    fn save(&self, w: &mut Writer) {
        w.u64(self.to_bits());
    }
    fn load(r: &mut Reader) -> Result<Self, SnapshotError> {
        Ok(f64::from_bits(r.u64()?))
    }
    fn layout(out: &mut String) {
        out.push_str("f64");
    }
}

impl Persist for bool {
    #[inline]
    fn save(&self, w: &mut Writer) {
        w.u8(*self as u8);
    }
    #[inline]
    fn load(r: &mut Reader) -> Result<Self, SnapshotError> {
        match r.u8()? {
            0 => Ok(false),
            1 => Ok(true),
            x => Err(invalid(format!("a flag of {x} (0 or 1)"))),
        }
    }
    fn layout(out: &mut String) {
        out.push_str("bool");
    }
}

impl Persist for Vec3 {
    #[inline]
    fn save(&self, w: &mut Writer) {
        self.to_array().save(w);
    }
    #[inline]
    fn load(r: &mut Reader) -> Result<Self, SnapshotError> {
        Ok(Vec3::from_array(Persist::load(r)?))
    }
    fn layout(out: &mut String) {
        out.push_str("Vec3");
    }
}

impl Persist for Quat {
    #[inline]
    fn save(&self, w: &mut Writer) {
        self.to_array().save(w);
    }
    #[inline]
    fn load(r: &mut Reader) -> Result<Self, SnapshotError> {
        Ok(Quat::from_array(Persist::load(r)?))
    }
    fn layout(out: &mut String) {
        out.push_str("Quat");
    }
}

impl Persist for Mat3 {
    fn save(&self, w: &mut Writer) {
        self.to_cols_array().save(w);
    }
    fn load(r: &mut Reader) -> Result<Self, SnapshotError> {
        Ok(Mat3::from_cols_array(&Persist::load(r)?))
    }
    fn layout(out: &mut String) {
        out.push_str("Mat3");
    }
}

impl<T: Persist + Default, const N: usize> Persist for [T; N] {
    #[inline]
    fn save(&self, w: &mut Writer) {
        self.iter().for_each(|x| x.save(w));
    }
    #[inline]
    fn load(r: &mut Reader) -> Result<Self, SnapshotError> {
        let mut out: [T; N] = std::array::from_fn(|_| T::default());
        for x in &mut out {
            *x = T::load(r)?;
        }
        Ok(out)
    }
    fn layout(out: &mut String) {
        out.push('[');
        T::layout(out);
        out.push_str(&format!(";{N}]"));
    }
    fn wipe(&mut self) {
        self.iter_mut().for_each(T::wipe);
    }
}

impl<T: Persist> Persist for Vec<T> {
    fn save(&self, w: &mut Writer) {
        w.len(self.len());
        self.iter().for_each(|x| x.save(w));
    }
    fn load(r: &mut Reader) -> Result<Self, SnapshotError> {
        let n = r.len()?;
        // Grown as items arrive: never more than the bytes read justify.
        let mut out = Vec::with_capacity(n.min(1 << 16));
        for _ in 0..n {
            out.push(T::load(r)?);
        }
        Ok(out)
    }
    fn layout(out: &mut String) {
        out.push_str("Vec<");
        T::layout(out);
        out.push('>');
    }
    fn wipe(&mut self) {
        self.iter_mut().for_each(T::wipe);
    }
}

impl<T: Persist> Persist for Option<T> {
    fn save(&self, w: &mut Writer) {
        match self {
            None => w.u8(0),
            Some(x) => {
                w.u8(1);
                x.save(w);
            }
        }
    }
    fn load(r: &mut Reader) -> Result<Self, SnapshotError> {
        match r.u8()? {
            0 => Ok(None),
            1 => Ok(Some(T::load(r)?)),
            x => Err(invalid(format!("an option tagged {x} (0 or 1)"))),
        }
    }
    fn layout(out: &mut String) {
        out.push_str("Option<");
        T::layout(out);
        out.push('>');
    }
    fn wipe(&mut self) {
        if let Some(x) = self {
            x.wipe();
        }
    }
}

/// `Persist` for tuples: their items in order.
macro_rules! persist_tuple {
    ($($t:ident . $i:tt),+) => {
        impl<$($t: Persist),+> Persist for ($($t,)+) {
            fn save(&self, w: &mut Writer) {
                $( self.$i.save(w); )+
            }
            fn load(r: &mut Reader) -> Result<Self, SnapshotError> {
                Ok(($($t::load(r)?,)+))
            }
            fn layout(out: &mut String) {
                out.push('(');
                $( $t::layout(out); out.push(','); )+
                out.push(')');
            }
        }
    };
}
persist_tuple!(A.0, B.1);
persist_tuple!(A.0, B.1, C.2);
persist_tuple!(A.0, B.1, C.2, D.3);

impl Persist for std::ops::Range<usize> {
    fn save(&self, w: &mut Writer) {
        self.start.save(w);
        self.end.save(w);
    }
    fn load(r: &mut Reader) -> Result<Self, SnapshotError> {
        let (start, end) = (usize::load(r)?, usize::load(r)?);
        if start > end {
            return Err(invalid(format!("a range {start}..{end}")));
        }
        Ok(start..end)
    }
    fn layout(out: &mut String) {
        out.push_str("Range");
    }
}

/// A 64-bit hash of `bytes`, eight at a time on four independent lanes
/// (so that a snapshot of tens of megabytes hashes at memory speed): each
/// word is multiplied into its lane, the lanes are folded, and the length
/// and the tail bytes enter last. It detects corruption, not tampering.
pub(crate) fn checksum(bytes: &[u8]) -> u64 {
    const K: [u64; 4] = [0x9E37_79B9_7F4A_7C15, 0xC2B2_AE3D_27D4_EB4F, 0x1656_67B1_9E37_79F9, 0x27D4_EB2F_1656_67C5];
    let mix = |h: u64, x: u64, k: u64| (h ^ x).wrapping_mul(k).rotate_left(29);
    let mut lanes = K;
    let mut chunks = bytes.chunks_exact(32);
    for c in &mut chunks {
        for (i, lane) in lanes.iter_mut().enumerate() {
            let x = u64::from_le_bytes(c[8 * i..8 * i + 8].try_into().expect("8 bytes"));
            *lane = mix(*lane, x, K[i]);
        }
    }
    let mut h = lanes.iter().fold(bytes.len() as u64, |h, &l| mix(h, l, K[0]));
    for (i, &b) in chunks.remainder().iter().enumerate() {
        h = mix(h, b as u64 | ((i as u64) << 8), K[1]);
    }
    // Final avalanche (as in SplitMix64).
    h ^= h >> 30;
    h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    h ^= h >> 27;
    h = h.wrapping_mul(0x94D0_49BB_1331_11EB);
    h ^ (h >> 31)
}
