//! Contact events: which contacts began or stopped touching in a step,
//! found at its end (`World::report_events`), plus the ends of contacts
//! removed between steps, reported after the next one.

use super::World;
use crate::body::BodyHandle;
use crate::collider::ColliderHandle;
use crate::contact::{Contact, ContactEvent, ContactEventKind, REPORT_NEEDS, REPORT_TOUCHING};

/// The step's events and the ones held back for the next step.
#[derive(Default)]
pub(super) struct Events {
    /// Events of the last step.
    pub(super) list: Vec<ContactEvent>,
    /// Ends of touching contacts removed since the last step (with a
    /// collider or a body), reported after the next step.
    pub(super) pending: Vec<ContactEvent>,
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
    ///
    /// What a contact needs at the end of the step (an event when it
    /// began or stopped touching, its records cleared when its manifold is
    /// empty) is its mark ([`Contact::report_mark`]), which the solver
    /// wrote into `contacts.report` where it had the contact in the cache,
    /// and a broken bond rewrote. Few contacts need anything, so the scan
    /// reads one byte a contact, and the contact itself only for those.
    pub(super) fn report_events(&mut self) {
        self.scratch.visits.contacts += self.contacts.active.len();
        for k in 0..self.contacts.active.len() {
            let i = self.contacts.active[k] as usize;
            let mark = self.contacts.report[i];
            debug_assert_eq!(mark, self.contacts.list[i].report_mark(), "contact {i}'s mark is stale");
            if mark & REPORT_NEEDS != 0 {
                self.settle_contact(i, mark & REPORT_TOUCHING != 0);
            }
        }
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

crate::snapshot::codec::persist!(Events { pending } scratch { list });
