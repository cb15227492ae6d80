//! Marks that fade: things the viewer shows for a while after they happen
//! (a broken bond's mark, a fresh piece's flash), kept oldest first, each
//! with what is left of its time, and at most so many at once so that a
//! wall blown apart in one step cannot fill the frame with them.

use std::collections::VecDeque;

/// Something that happened at a simulated time.
pub trait Stamped {
    /// When, simulated seconds.
    fn time(&self) -> f64;
}

/// The marks of the last `seconds` of simulated time, oldest first, at
/// most `most` (the oldest go first).
#[derive(Clone, Debug)]
pub struct Fading<T> {
    marks: VecDeque<T>,
    seconds: f64,
    most: usize,
}

impl<T: Stamped> Fading<T> {
    /// Marks that last `seconds`, at most `most` of them.
    pub fn new(seconds: f64, most: usize) -> Self {
        Self { marks: VecDeque::new(), seconds, most }
    }

    /// Adds a mark (not older than the marks already kept), dropping the
    /// oldest when there are `most`.
    pub fn push(&mut self, mark: T) {
        if self.marks.len() == self.most {
            self.marks.pop_front();
        }
        self.marks.push_back(mark);
    }

    /// Drops the marks whose time is over at simulated time `now`.
    pub fn expire(&mut self, now: f64) {
        while self.marks.front().is_some_and(|m| now - m.time() >= self.seconds) {
            self.marks.pop_front();
        }
    }

    /// The marks still shown at `now`, each with what is left of its time,
    /// from 1 when it happened to 0 when it goes.
    pub fn visible(&self, now: f64) -> impl Iterator<Item = (&T, f32)> {
        self.marks.iter().filter_map(move |m| {
            let left = 1.0 - (now - m.time()) / self.seconds;
            (left > 0.0).then_some((m, left.min(1.0) as f32))
        })
    }

    /// Marks kept.
    pub fn len(&self) -> usize {
        self.marks.len()
    }

    /// True when no mark is kept.
    pub fn is_empty(&self) -> bool {
        self.marks.is_empty()
    }
}
