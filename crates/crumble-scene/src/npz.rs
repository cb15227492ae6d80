//! The `.npz` output: NumPy's archive of arrays (`numpy.load` reads it),
//! a zip file of `.npy` arrays, written uncompressed so that it is quick
//! to write and to read.
//!
//! The arrays (`docs/output-formats.md`, "NumPy"):
//!
//! | name | dtype | shape | what |
//! |---|---|---|---|
//! | `poses` | float32 | (frames, bodies, 7) | x, y, z, qx, qy, qz, qw (glTF's order) |
//! | `t` | float64 | (frames,) | each frame's time, seconds |
//! | `frame` | int64 | (frames,) | each frame's number (`t = frame / fps`) |
//! | `fps`, `dt` | float64 | () | the sampling rate and the step |
//! | `names` | unicode | (bodies,) | the bodies' names, in the JSON's order |
//! | `shapes` | unicode | (bodies,) | `box`, `sphere` or `plane` |
//! | `sizes` | float32 | (bodies, 3) | a box's full size, a ball's diameter three times, a plane's zeros |
//! | `static` | bool | (bodies,) | whether the body never moves |
//! | `parent` | int32 | (bodies,) | the row a piece broke from, -1 for others |
//! | `appears`, `disappears` | float64 | (bodies,) | when it enters / leaves the world, seconds; 0 / -1 for a body there from the start / to the end |
//! | `event_t` | float64 | (events,) | when each event happened, seconds |
//! | `event_kind` | unicode | (events,) | `launch`, `split`, `bond_broken`, `joint_broken` |
//! | `event_a`, `event_b` | int32 | (events,) | the rows involved, -1 where none (a joint's world side) |
//!
//! The file is the same bytes for the same run: no dates, entries in a
//! fixed order.

use std::io::{self, Write};

use crate::BodyShape;

use crate::record::Recording;

/// The `.npy` header of an array of `descr` and `shape`: the magic, format
/// 1.0, and the dictionary padded with spaces so that the data starts on
/// a 64-byte boundary (as NumPy writes it).
fn npy_header(descr: &str, shape: &[usize]) -> Vec<u8> {
    let dims = match shape {
        [] => String::new(),
        [n] => format!("{n},"),
        _ => shape.iter().map(|d| d.to_string()).collect::<Vec<_>>().join(", "),
    };
    let mut dict = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': ({dims}), }}");
    let unpadded = 10 + dict.len() + 1;
    dict.push_str(&" ".repeat(unpadded.next_multiple_of(64) - unpadded));
    dict.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&u16::try_from(dict.len()).expect("a short header").to_le_bytes());
    out.extend_from_slice(dict.as_bytes());
    out
}

/// One array: its `.npy` bytes.
fn npy(descr: &str, shape: &[usize], data: impl IntoIterator<Item = u8>) -> Vec<u8> {
    let mut out = npy_header(descr, shape);
    out.extend(data);
    out
}

fn f32s(xs: impl IntoIterator<Item = f32>) -> impl Iterator<Item = u8> {
    xs.into_iter().flat_map(f32::to_le_bytes)
}

fn f64s(xs: impl IntoIterator<Item = f64>) -> impl Iterator<Item = u8> {
    xs.into_iter().flat_map(f64::to_le_bytes)
}

fn i32s(xs: impl IntoIterator<Item = i32>) -> impl Iterator<Item = u8> {
    xs.into_iter().flat_map(i32::to_le_bytes)
}

/// Strings as NumPy's fixed-width unicode (`<U{n}`: UTF-32 code points,
/// zero-padded to the longest).
fn strings<S: AsRef<str>>(xs: &[S]) -> Vec<u8> {
    let width = xs.iter().map(|s| s.as_ref().chars().count()).max().unwrap_or(0).max(1);
    let mut data = Vec::with_capacity(xs.len() * width * 4);
    for s in xs {
        let mut n = 0;
        for c in s.as_ref().chars() {
            data.extend_from_slice(&(c as u32).to_le_bytes());
            n += 1;
        }
        data.extend(std::iter::repeat_n(0u8, (width - n) * 4));
    }
    npy(&format!("<U{width}"), &[xs.len()], data)
}

/// The row of a body handle or `-1`.
fn row(x: Option<usize>) -> i32 {
    x.map_or(-1, |i| i32::try_from(i).expect("fewer than 2^31 bodies"))
}

/// The arrays of `rec`, by name, in the order the archive lists them.
pub fn arrays(rec: &Recording) -> Vec<(&'static str, Vec<u8>)> {
    let (frames, bodies) = (rec.frames.len(), rec.bodies.len());
    let poses = rec.frames.iter().flat_map(|f| {
        f.positions.iter().zip(&f.rotations).flat_map(|(p, q)| [p[0], p[1], p[2], q[0], q[1], q[2], q[3]])
    });
    let sizes = rec.bodies.iter().flat_map(|b| match b.shape {
        BodyShape::Box { half_extents } => (half_extents * 2.0).to_array(),
        BodyShape::Sphere { radius } => [2.0 * radius; 3],
        BodyShape::Plane { .. } => [0.0; 3],
    });
    let shapes: Vec<&str> = rec
        .bodies
        .iter()
        .map(|b| match b.shape {
            BodyShape::Box { .. } => "box",
            BodyShape::Sphere { .. } => "sphere",
            BodyShape::Plane { .. } => "plane",
        })
        .collect();
    let names: Vec<&str> = rec.bodies.iter().map(|b| b.name.as_str()).collect();
    let appears = rec.bodies.iter().map(|b| if b.parent.is_some() || b.spawn_time > 0.0 { b.spawn_time } else { 0.0 });
    let disappears = rec.bodies.iter().map(|b| b.despawn.map_or(-1.0, |(t, _)| t));
    let events = &rec.events;
    let kinds: Vec<&str> = events.iter().map(|e| e.kind.name()).collect();
    vec![
        ("poses", npy("<f4", &[frames, bodies, 7], f32s(poses))),
        ("t", npy("<f8", &[frames], f64s(rec.frames.iter().map(|f| f.t)))),
        ("frame", npy("<i8", &[frames], (rec.first..).take(frames).flat_map(|k| (k as i64).to_le_bytes()))),
        ("fps", npy("<f8", &[], f64s([rec.fps as f64]))),
        ("dt", npy("<f8", &[], f64s([rec.dt as f64]))),
        ("names", strings(&names)),
        ("shapes", strings(&shapes)),
        ("sizes", npy("<f4", &[bodies, 3], f32s(sizes))),
        ("static", npy("|b1", &[bodies], rec.bodies.iter().map(|b| u8::from(b.is_static)))),
        ("parent", npy("<i4", &[bodies], i32s(rec.bodies.iter().map(|b| row(b.parent.map(|(p, _)| p)))))),
        ("appears", npy("<f8", &[bodies], f64s(appears))),
        ("disappears", npy("<f8", &[bodies], f64s(disappears))),
        ("event_t", npy("<f8", &[events.len()], f64s(events.iter().map(|e| e.t)))),
        ("event_kind", strings(&kinds)),
        ("event_a", npy("<i4", &[events.len()], i32s(events.iter().map(|e| row(e.a))))),
        ("event_b", npy("<i4", &[events.len()], i32s(events.iter().map(|e| row(e.b))))),
    ]
}

/// Writes `rec` as an `.npz`: a zip archive of stored (uncompressed)
/// `NAME.npy` entries. An archive past the 4 GiB a plain zip addresses is
/// refused (a run's frames are bounded at 2 GiB, `MAX_RECORDING_BYTES`).
pub fn write_npz(rec: &Recording, w: &mut impl Write) -> io::Result<()> {
    let entries = arrays(rec);
    let mut central = Vec::new();
    let mut offset: u64 = 0;
    let too_big = || io::Error::other("more than the 4 GiB a zip file without ZIP64 holds");
    for (name, data) in &entries {
        let file = format!("{name}.npy");
        let crc = crc32fast::hash(data);
        let size = u32::try_from(data.len()).map_err(|_| too_big())?;
        let at = u32::try_from(offset).map_err(|_| too_big())?;
        // Version 2.0, no flags, stored, 1980-01-01 00:00 (the zip epoch).
        let common = |out: &mut Vec<u8>| {
            for x in [20u16, 0, 0, 0, 0x21] {
                out.extend_from_slice(&x.to_le_bytes());
            }
            for x in [crc, size, size] {
                out.extend_from_slice(&x.to_le_bytes());
            }
            out.extend_from_slice(&(file.len() as u16).to_le_bytes());
            out.extend_from_slice(&0u16.to_le_bytes());
        };
        let mut local = 0x0403_4b50u32.to_le_bytes().to_vec();
        common(&mut local);
        local.extend_from_slice(file.as_bytes());
        w.write_all(&local)?;
        w.write_all(data)?;
        central.extend_from_slice(&0x0201_4b50u32.to_le_bytes());
        central.extend_from_slice(&20u16.to_le_bytes());
        common(&mut central);
        // Comment length, disk, internal and external attributes.
        central.extend_from_slice(&[0; 10]);
        central.extend_from_slice(&at.to_le_bytes());
        central.extend_from_slice(file.as_bytes());
        offset += (local.len() + data.len()) as u64;
    }
    let count = entries.len() as u16;
    let mut end = 0x0605_4b50u32.to_le_bytes().to_vec();
    end.extend_from_slice(&[0; 4]);
    end.extend_from_slice(&count.to_le_bytes());
    end.extend_from_slice(&count.to_le_bytes());
    end.extend_from_slice(&(central.len() as u32).to_le_bytes());
    end.extend_from_slice(&u32::try_from(offset).map_err(|_| too_big())?.to_le_bytes());
    end.extend_from_slice(&0u16.to_le_bytes());
    w.write_all(&central)?;
    w.write_all(&end)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headers_end_on_a_64_byte_boundary_with_numpys_shape_syntax() {
        for (shape, text) in [(&[][..], "()"), (&[5][..], "(5,)"), (&[2, 3, 7][..], "(2, 3, 7)")] {
            let h = npy_header("<f4", shape);
            assert_eq!(h.len() % 64, 0, "{shape:?}");
            let dict = std::str::from_utf8(&h[10..]).unwrap();
            assert!(dict.contains(&format!("'shape': {text}")), "{dict}");
            assert!(dict.ends_with('\n'));
        }
    }

    #[test]
    fn strings_are_padded_utf32() {
        let a = strings(&["ab", "é"]);
        let data = &a[a.len() - 16..];
        assert_eq!(data, [b'a', 0, 0, 0, b'b', 0, 0, 0, 0xe9, 0, 0, 0, 0, 0, 0, 0]);
        assert!(std::str::from_utf8(&a[10..a.len() - 16]).unwrap().contains("'<U2'"));
    }
}
