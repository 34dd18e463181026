//! The scene as the world's tactile model, shared with whoever runs the
//! experiment.
//!
//! The world owns its tactile model and asks it, tick by tick, what every
//! cell feels; the experiment must meanwhile move the hand and watch the
//! objects. Both hold the one scene through a shared handle; the world's
//! side adds the sensors' noise from a seed of its own.

use std::cell::{Ref, RefCell, RefMut};
use std::rc::Rc;

use nalgebra::Isometry3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::hand::Hand;
use super::object::Object;
use super::stage::{Look, Stage};
use super::{person, Scene, SkinModel};
use crate::world::{Tactile, Touch};

/// A scene shared between the world and the experiment.
#[derive(Clone, Debug)]
pub struct SharedScene(Rc<RefCell<Scene>>);

impl SharedScene {
    /// Shares a scene.
    pub fn new(scene: Scene) -> SharedScene {
        SharedScene(Rc::new(RefCell::new(scene)))
    }

    /// Reads the scene.
    pub fn get(&self) -> Ref<'_, Scene> {
        self.0.borrow()
    }

    /// Changes the scene (between ticks).
    pub fn get_mut(&self) -> RefMut<'_, Scene> {
        self.0.borrow_mut()
    }

    /// The world's side: raw counts with noise drawn from `seed`.
    pub fn tactile(&self, seed: u64) -> Box<dyn Tactile> {
        Box::new(Sensors { scene: self.0.clone(), rng: ChaCha8Rng::seed_from_u64(seed) })
    }
}

/// The built-in scene as the person's stage: the object stands on a table
/// that stays, and the skin's surface is where hands press.
impl Stage for SharedScene {
    fn skin(&self) -> SkinModel {
        self.get().skin().clone()
    }

    fn pat(&self, cell: &Isometry3<f64>, depth_m: f64) -> Hand {
        person::pat(cell, self.get().skin().surface_offset_m, depth_m)
    }

    fn set_hands(&self, hands: Vec<Hand>) {
        self.get_mut().set_hands(hands);
    }

    fn put(&self, object: Option<(Object, Isometry3<f64>)>) {
        let mut scene = self.get_mut();
        scene.clear_objects();
        if let Some((object, pose)) = object {
            scene.place(object, pose);
        }
        scene.reset_max_force();
    }

    fn lower_support(&self, _down_m: f64) {}

    fn let_go(&self) {}

    fn take_back(&self) {}

    fn carry_away(&self) {}

    fn look(&self) -> Look {
        let scene = self.get();
        Look {
            max_force_n: scene.max_force_n(),
            grip_force_max_n: scene.max_object_force_n(),
            hand_force_max_n: scene.max_hand_force_n(),
            bare_force_max_n: Some(scene.max_bare_force_n()),
            object: scene.objects().first().cloned(),
            contacts: scene.contacts().to_vec(),
            resting: None,
            support_n: None,
            fallen: false,
        }
    }
}

struct Sensors {
    scene: Rc<RefCell<Scene>>,
    rng: ChaCha8Rng,
}

impl Tactile for Sensors {
    fn sense(&mut self, time_s: f64, poses: &[Isometry3<f64>], out: &mut [Touch]) {
        let mut scene = self.scene.borrow_mut();
        scene.sense(time_s, poses);
        let scene = &*scene;
        for (touch, sense) in out.iter_mut().zip(scene.sensed()) {
            let (proximity, force) = scene.skin().counts(sense, &mut self.rng);
            *touch = Touch { proximity, force };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::experiment::Setup;
    use crate::scene::{person, SkinModel};
    use crate::world::{World, WorldConfig};
    use skin_model::robot::hrp2;

    #[test]
    fn a_pat_reaches_the_samples_of_the_patted_cell() {
        let robot = hrp2::robot();
        let setup = Setup::new(&robot, 2).unwrap();
        let id = setup.skin.cells()[setup.pat_cell].id;
        let mut world = World::new(robot, setup.skin.clone(), WorldConfig::default());
        let scene = SharedScene::new(Scene::new(SkinModel::default()));
        world.set_tactile(scene.tactile(5));
        let mut out = Vec::new();
        world.step(&mut out);
        let offset = scene.get().skin().surface_offset_m;
        scene.get_mut().set_hands(vec![person::pat(&world.cell_poses()[setup.pat_cell], offset, 0.0015)]);
        out.clear();
        world.step(&mut out);
        let (_, s) = out.iter().find(|(a, _)| *a == id).unwrap();
        let f = s.force_norm();
        assert!(f.iter().all(|f| *f > 0.04), "a low-force pat at least: {f:?}");
        let others = out.iter().filter(|(a, s)| *a != id && s.force().iter().any(|f| *f > 20)).count();
        assert_eq!(others, 0, "no other cell is pressed");
    }
}
