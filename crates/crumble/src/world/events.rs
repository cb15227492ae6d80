//! Contact events: which contacts began or stopped touching in a step,
//! found at its end (`World::report_events`), plus the ends of contacts
//! removed between steps, reported after the next one.

use rayon::prelude::*;

use super::World;
use crate::body::BodyHandle;
use crate::collider::ColliderHandle;
use crate::contact::{Contact, ContactEvent, ContactEventKind, SCAN_AHEAD};
use crate::narrow_phase::CONTACT_CHUNK;
use crate::narrow_phase::PARALLEL_MIN_CONTACTS;
use crate::threads::workers;

/// The step's events, the ones held back for the next step, and the
/// scan's marks (kept so that steady state does not allocate).
#[derive(Default)]
pub(super) struct Events {
    /// Events of the last step.
    pub(super) list: Vec<ContactEvent>,
    /// Ends of touching contacts removed since the last step (with a
    /// collider or a body), reported after the next step.
    pub(super) pending: Vec<ContactEvent>,
    /// What `report_events` found of each active contact, with threads.
    pub(super) marks: Vec<u8>,
}

impl Events {
    /// A step begins: the held-back events become its first.
    pub(super) fn begin_step(&mut self) {
        self.list.clear();
        self.list.append(&mut self.pending);
    }
}

impl World {
    /// Removes a contact because one of its colliders goes; a touching one
    /// is reported as ended after the next step.
    pub(super) fn drop_contact(&mut self, id: u32) {
        let removed = self.contacts.remove_at(id);
        if removed.touching {
            if let Some(e) = self.event_for(&removed, ContactEventKind::Ended, 0.0) {
                self.events.pending.push(e);
            }
        }
    }

    /// The event of `kind` for contact `c`, if its colliders and bodies
    /// are still there.
    pub(super) fn event_for(&self, c: &Contact, kind: ContactEventKind, impulse: f32) -> Option<ContactEvent> {
        Some(ContactEvent {
            kind,
            collider_a: ColliderHandle(self.colliders.handle_at(c.collider_a)?),
            collider_b: ColliderHandle(self.colliders.handle_at(c.collider_b)?),
            body_a: BodyHandle(self.bodies.handle_at(c.body_a)?),
            body_b: BodyHandle(self.bodies.handle_at(c.body_b)?),
            normal_impulse: impulse,
        })
    }

    /// Updates each active contact's touching flag and reports the changes
    /// (contacts of islands that just fell asleep keep theirs).
    pub(super) fn report_events(&mut self) {
        self.scratch.visits.contacts += self.contacts.active.len();
        // What a contact needs at the end of the step: an event when it
        // began or stopped touching, its records cleared when its
        // manifold is empty. Few contacts need either, and finding them
        // reads every active contact, so with threads the scan is shared
        // out, writing one byte a contact into a buffer kept from step to
        // step (no allocation), and only the contacts it marks are handled
        // here, in the active list's order.
        let active = &self.contacts.active;
        let parallel =
            workers(self.settings.threads, self.pool.as_deref()) > 1 && active.len() >= PARALLEL_MIN_CONTACTS;
        if !parallel {
            // One pass: each contact handled as it is read.
            for k in 0..self.contacts.active.len() {
                self.contacts.prefetch_active(k + SCAN_AHEAD);
                let i = self.contacts.active[k] as usize;
                let mark = report_mark(&self.contacts.list[i]);
                if mark & REPORT_NEEDS != 0 {
                    self.settle_contact(i, mark & REPORT_TOUCHING != 0);
                }
            }
            return;
        }
        let list = &self.contacts.list;
        let mut marks = std::mem::take(&mut self.events.marks);
        marks.clear();
        marks.resize(active.len(), 0);
        let mut run = || {
            marks
                .par_iter_mut()
                .zip(active.par_iter())
                .with_min_len(CONTACT_CHUNK)
                .for_each(|(m, &i)| *m = report_mark(&list[i as usize]))
        };
        match self.pool.as_deref() {
            Some(pool) => pool.install(run),
            None => run(),
        }
        for (k, &mark) in marks.iter().enumerate() {
            if mark & REPORT_NEEDS != 0 {
                self.settle_contact(self.contacts.active[k] as usize, mark & REPORT_TOUCHING != 0);
            }
        }
        self.events.marks = marks;
    }

    /// Contact `i`'s end of step (see `report_events`): its event if it
    /// began (`touching`) or stopped touching, its records cleared if its
    /// manifold is empty.
    fn settle_contact(&mut self, i: usize, touching: bool) {
        let c = &self.contacts.list[i];
        if touching != c.touching {
            let kind = if touching { ContactEventKind::Began } else { ContactEventKind::Ended };
            let imp = if touching { c.step_impulse } else { 0.0 };
            if let Some(e) = self.event_for(c, kind, imp) {
                self.events.list.push(e);
            }
            self.contacts.list[i].touching = touching;
        }
        if self.contacts.list[i].manifold.is_empty() {
            self.contacts.list[i].max_normal_impulse = 0.0;
            self.contacts.list[i].step_impulse = 0.0;
        }
    }
}

/// What `report_events` needs to do with a contact, as bits: whether it
/// needs anything (`REPORT_NEEDS`: its touching changed or its manifold
/// is empty) and whether it touches now (`REPORT_TOUCHING`).
fn report_mark(c: &Contact) -> u8 {
    // A bond touches while it holds, pulling or pushing.
    let touching = c.bond != crate::contact::NONE
        || c.max_normal_impulse > 0.0
        || c.manifold.min_separation().is_some_and(|s| s < 0.0);
    let needs = touching != c.touching || c.manifold.is_empty();
    (u8::from(needs) * REPORT_NEEDS) | (u8::from(touching) * REPORT_TOUCHING)
}
const REPORT_NEEDS: u8 = 1;
const REPORT_TOUCHING: u8 = 2;

crate::snapshot::codec::persist!(Events { pending } scratch { list, marks });
