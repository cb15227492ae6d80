//! Small rigs the bond and fracture tests share: a world with some
//! settings changed, and a static block of brick.

use crumble::scenes::BRICK;
use crumble::{BodyBuilder, BodyHandle, ColliderBuilder, Vec3, World, WorldSettings};

/// A world with the default settings as `f` changes them.
pub fn world_with(f: impl FnOnce(&mut WorldSettings)) -> World {
    let mut s = WorldSettings::default();
    f(&mut s);
    World::new(s).expect("settings")
}

/// A static box of brick, `size` its full edges, centred at `position`.
pub fn static_box(w: &mut World, size: Vec3, position: Vec3) -> BodyHandle {
    let b = w.insert_body(BodyBuilder::fixed().position(position)).unwrap();
    w.insert_collider(ColliderBuilder::cuboid(size.x / 2.0, size.y / 2.0, size.z / 2.0).unwrap().material(BRICK), b)
        .unwrap();
    b
}
