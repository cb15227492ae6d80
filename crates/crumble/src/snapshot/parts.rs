//! `Persist` for the public types whose fields the crate reaches: handles,
//! bodies, colliders, materials, joints, bonds and events.

use super::codec::{invalid, persist, persist_enum, Persist, Reader, Writer};
use super::SnapshotError;
use crate::arena::RawHandle;
use crate::body::{Body, BodyHandle, BodyType};
use crate::bond::{Bond, BondHandle, BondMode, BondSpec, FaceBond};
use crate::collider::{Collider, ColliderHandle, Material, Strength};
use crate::contact::{ContactEvent, ContactEventKind};
use crate::fracture::FractureMode;
use crate::joint::{Joint, JointHandle, JointKind, JointOptions};

macro_rules! persist_handle {
    ($($ty:ident),*) => {$(
        impl Persist for $ty {
            fn save(&self, w: &mut Writer) {
                self.0.save(w);
            }
            fn load(r: &mut Reader) -> Result<Self, SnapshotError> {
                Ok($ty(RawHandle::load(r)?))
            }
            fn layout(out: &mut String) {
                out.push_str(stringify!($ty));
            }
        }
    )*};
}
persist_handle!(BodyHandle, ColliderHandle, JointHandle, BondHandle);

persist_enum!(BodyType { Static, Dynamic, Kinematic });
persist_enum!(JointKind { Spherical, Revolute, Fixed, Distance, Rope });
persist_enum!(BondMode { Tension, Shear, Separated });
persist_enum!(FractureMode { Tension, Shear });
persist_enum!(ContactEventKind { Began, Ended });

persist!(Body {
    body_type,
    pose,
    local_com,
    linear_velocity,
    angular_velocity,
    force,
    torque,
    mass,
    inv_mass,
    local_inertia,
    local_inv_inertia,
    linear_damping,
    angular_damping,
    gravity_scale,
    can_sleep,
    sleeping,
    sleep_time,
    bullet,
    user_data,
    colliders,
    max_extent,
    min_extent,
    solver_index,
    faulted,
});
persist!(Collider { shape, local_pose, material, body, proxy, world_pose });
persist!(Strength { tensile, shear });
persist!(Joint {
    kind,
    a,
    b,
    handle_a,
    handle_b,
    local_a,
    local_b,
    axis_a,
    axis_b,
    ref_a,
    ref_b,
    relative,
    options,
    linear_impulse,
    angular_impulse,
    extra_impulse,
    force,
    torque,
    separation,
});
persist!(JointOptions { limits, length, spring, break_force, break_torque, collide_connected, user_data });
persist!(BondSpec { tensile_strength, shear_strength, friction, user_data });
persist!(FaceBond { normal, points, gap, area });
persist!(Bond {
    body_a,
    body_b,
    handle_a,
    handle_b,
    collider_a,
    collider_b,
    collider_handles,
    spec,
    face,
    local_a,
    local_b,
    normal_a,
    contact_friction,
    contact_restitution,
    normal_force,
    shear_force,
    twist_torque,
    utilisation,
    opening,
    slide,
    radius,
});
persist!(ContactEvent { kind, collider_a, collider_b, body_a, body_b, normal_impulse });

/// A material is checked as `Material::validate` checks a new one.
impl Persist for Material {
    fn save(&self, w: &mut Writer) {
        self.density.save(w);
        self.friction.save(w);
        self.restitution.save(w);
        self.rolling_resistance.save(w);
        self.strength.save(w);
    }
    fn load(r: &mut Reader) -> Result<Self, SnapshotError> {
        let m = Material {
            density: Persist::load(r)?,
            friction: Persist::load(r)?,
            restitution: Persist::load(r)?,
            rolling_resistance: Persist::load(r)?,
            strength: Persist::load(r)?,
        };
        m.validate().map_err(|e| invalid(format!("a material: {e}")))?;
        Ok(m)
    }
    fn layout(out: &mut String) {
        out.push_str("Material{density,friction,restitution,rolling_resistance,strength:Option<Strength>}");
    }
}
