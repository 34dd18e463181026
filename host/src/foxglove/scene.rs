//! The live view's state, fed by [`Update`]s, and the Foxglove messages
//! drawn from it: pure (updates in, messages out, no I/O), so it is
//! tested without a server.
//!
//! Everything is placed in one frame, `world` ([`layout`]): a cell's cube
//! is coloured by what it feels (grey at rest, blue as something comes
//! near, red under force, the stronger the more) and grows in height with
//! its force; a cell at a tactile level above 0 also gets a sphere.

use std::collections::BTreeMap;

use foxglove::messages::{
    Color, CubePrimitive, FrameTransform, FrameTransforms, KeyValuePair, LinePrimitive, Log, Point3, Pose, Quaternion,
    SceneEntity, SceneUpdate, SpherePrimitive, Timestamp, Vector3,
};
use nalgebra::Isometry3;
use serde::Serialize;
use skin_model::robot::Robot as Description;
use skin_protocol::message::Channel;
use skin_protocol::Sample;

use super::layout::{self, Skeleton};
use crate::control::grasp::{Cause, State};
use crate::explore::KinematicTree;
use crate::interface::{tactile_text, EventKind};
use crate::robot::DofKind;
use crate::ros::skin::CellPose;
use crate::view::Update;

/// The frame everything is drawn in.
pub const WORLD: &str = "world";
/// Edge of a cell's cube, m.
const CELL_EDGE_M: f64 = 0.02;
/// A cube's height at rest and its growth at full force, m.
const CELL_HEIGHT_M: (f64, f64) = (0.004, 0.03);
/// Normalized force (the largest of a cell's three) below which a cell counts as untouched.
const FORCE_SEEN: f32 = 0.02;
/// Log lines kept between two publications (the rest is counted).
const LOG_LINES: usize = 1000;

/// The grasp state as the view's JSON channel carries it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GraspState {
    /// The state entered.
    pub state: State,
    /// The state left.
    pub from: State,
    /// Why.
    pub cause: Cause,
    /// The controller's time, s.
    pub time_s: f64,
}

/// What the view knows.
#[derive(Debug, Default)]
pub struct Scene {
    dof_names: Vec<String>,
    positions: Vec<f64>,
    description: Option<Box<Description>>,
    tree: Option<(Box<KinematicTree>, Vec<DofKind>)>,
    poses: BTreeMap<u16, CellPose>,
    latest: BTreeMap<u16, Sample>,
    /// Tactile levels above 0, by cell and sensor.
    levels: BTreeMap<(u16, u8), u8>,
    logs: Vec<Log>,
    /// Log lines not kept because too many came at once.
    logs_dropped: u64,
    grasp: Vec<GraspState>,
}

fn colour(r: f64, g: f64, b: f64) -> Option<Color> {
    Some(Color { r, g, b, a: 1.0 })
}

fn vector(v: &nalgebra::Vector3<f64>) -> Option<Vector3> {
    Some(Vector3 { x: v.x, y: v.y, z: v.z })
}

fn pose(p: &Isometry3<f64>) -> Option<Pose> {
    let q = p.rotation.quaternion();
    Some(Pose {
        position: vector(&p.translation.vector),
        orientation: Some(Quaternion { x: q.i, y: q.j, z: q.k, w: q.w }),
    })
}

fn point(p: &nalgebra::Point3<f64>) -> Point3 {
    Point3 { x: p.x, y: p.y, z: p.z }
}

/// A cell's largest normalized force and its proximity, each in [0, 1].
fn felt(s: &Sample) -> (f32, f32) {
    let force = s.force_norm().into_iter().fold(0.0f32, f32::max).clamp(0.0, 1.0);
    (force, s.proximity_norm().clamp(0.0, 1.0))
}

/// Grey at rest, towards blue with proximity, red with force.
fn cell_colour(s: &Sample) -> Option<Color> {
    let (force, near) = felt(s);
    if force >= FORCE_SEEN {
        let f = f64::from(force);
        return colour(0.6 + 0.4 * f, 0.3 * (1.0 - f), 0.1);
    }
    let p = f64::from(near);
    colour(0.6 - 0.5 * p, 0.6 - 0.2 * p, 0.6 + 0.4 * p)
}

fn channel_index(c: Channel) -> u8 {
    match c {
        Channel::Proximity => 0,
        Channel::Force0 => 1,
        Channel::Force1 => 2,
        Channel::Force2 => 3,
    }
}

impl Scene {
    /// Nothing known yet.
    pub fn new() -> Scene {
        Scene::default()
    }

    /// Takes one update.
    pub fn take(&mut self, update: Update) {
        match update {
            Update::Events(events) => {
                for e in events {
                    match e.kind {
                        EventKind::Sample(s) => {
                            self.latest.insert(e.cell.0, s);
                        }
                        EventKind::Tactile(t) => {
                            let key = (e.cell.0, channel_index(t.channel));
                            if t.level == 0 {
                                self.levels.remove(&key);
                            } else {
                                self.levels.insert(key, t.level);
                            }
                            self.log(format!("{}: {}", e.cell, tactile_text(&t)));
                        }
                        _ => {}
                    }
                }
            }
            Update::Dofs(names) => self.dof_names = names,
            Update::Positions(q) => self.positions = q,
            Update::Description(model) => self.description = Some(model),
            Update::Tree(tree, kinds) => self.tree = Some((tree, kinds)),
            Update::Poses(poses) => self.poses = poses.into_iter().map(|p| (p.id, p)).collect(),
            Update::Grasp(t) => {
                self.log(format!("grasp: {:?} -> {:?} ({:?})", t.from, t.to, t.cause));
                self.grasp.push(GraspState { state: t.to, from: t.from, cause: t.cause, time_s: t.time_s });
            }
        }
    }

    fn log(&mut self, message: String) {
        if self.logs.len() >= LOG_LINES {
            self.logs_dropped += 1;
            return;
        }
        self.logs.push(Log {
            timestamp: Some(Timestamp::now()),
            level: foxglove::messages::log::Level::Info as i32,
            message,
            name: "skin".to_owned(),
            file: String::new(),
            line: 0,
        });
    }

    /// The log lines (tactile events, grasp states) since the last call.
    pub fn take_logs(&mut self) -> Vec<Log> {
        std::mem::take(&mut self.logs)
    }

    /// Log lines dropped because too many came between two publications.
    pub fn logs_dropped(&self) -> u64 {
        self.logs_dropped
    }

    /// The grasp states entered since the last call.
    pub fn take_grasp(&mut self) -> Vec<GraspState> {
        std::mem::take(&mut self.grasp)
    }

    /// The robot now: its description's links if given, else the learned tree's schematic, else nothing.
    pub fn skeleton(&self) -> Skeleton {
        match (&self.description, &self.tree) {
            (Some(model), _) => layout::described(model, &self.dof_names, &self.positions),
            (None, Some((tree, kinds))) => layout::learned(tree, kinds, &self.positions),
            (None, None) => Skeleton::default(),
        }
    }

    /// Every frame of the robot in `world`.
    pub fn transforms(skeleton: &Skeleton) -> FrameTransforms {
        let timestamp = Some(Timestamp::now());
        FrameTransforms {
            transforms: skeleton
                .frames
                .iter()
                .map(|(name, p)| {
                    let q = p.rotation.quaternion();
                    FrameTransform {
                        timestamp,
                        parent_frame_id: WORLD.to_owned(),
                        child_frame_id: name.clone(),
                        translation: vector(&p.translation.vector),
                        rotation: Some(Quaternion { x: q.i, y: q.j, z: q.k, w: q.w }),
                    }
                })
                .collect(),
        }
    }

    fn entity(id: &str) -> SceneEntity {
        SceneEntity {
            timestamp: Some(Timestamp::now()),
            frame_id: WORLD.to_owned(),
            id: id.to_owned(),
            ..Default::default()
        }
    }

    /// The robot's bones as lines, with a sphere at every frame.
    pub fn robot(skeleton: &Skeleton) -> SceneUpdate {
        let mut robot = Scene::entity("robot");
        robot.lines.push(LinePrimitive {
            r#type: foxglove::messages::line_primitive::Type::LineList as i32,
            pose: pose(&Isometry3::identity()),
            thickness: 0.01,
            scale_invariant: false,
            points: skeleton.bones.iter().flatten().map(point).collect(),
            color: Some(Color { r: 0.8, g: 0.8, b: 0.75, a: 1.0 }),
            ..Default::default()
        });
        robot.spheres = skeleton
            .frames
            .iter()
            .map(|(_, p)| SpherePrimitive {
                pose: pose(p),
                size: vector(&nalgebra::Vector3::repeat(0.03)),
                color: Some(Color { r: 0.5, g: 0.5, b: 0.5, a: 0.6 }),
            })
            .collect();
        SceneUpdate { deletions: Vec::new(), entities: vec![robot] }
    }

    /// The cells: one cube each (in the order of the `ids` metadata),
    /// coloured and sized by what it feels; and one sphere per cell at a
    /// tactile level above 0, larger the higher the level (entity `contacts`).
    pub fn cells(&self, skeleton: &Skeleton) -> SceneUpdate {
        let ids: Vec<u16> = self.latest.keys().copied().collect();
        let at = layout::cells(&ids, &self.poses, self.tree.as_ref().map(|(t, _)| &**t), skeleton);
        let mut cells = Scene::entity("cells");
        let mut force = Vec::with_capacity(ids.len());
        let mut proximity = Vec::with_capacity(ids.len());
        for (s, place) in self.latest.values().zip(&at) {
            let (f, p) = felt(s);
            force.push(format!("{f:.3}"));
            proximity.push(format!("{p:.3}"));
            let height = CELL_HEIGHT_M.0 + CELL_HEIGHT_M.1 * f64::from(f);
            cells.cubes.push(CubePrimitive {
                pose: pose(place),
                size: vector(&nalgebra::Vector3::new(CELL_EDGE_M, CELL_EDGE_M, height)),
                color: cell_colour(s),
            });
        }
        let list = |v: Vec<String>| v.join(",");
        cells.metadata = vec![
            KeyValuePair { key: "ids".into(), value: list(ids.iter().map(u16::to_string).collect()) },
            KeyValuePair { key: "force".into(), value: list(force) },
            KeyValuePair { key: "proximity".into(), value: list(proximity) },
        ];
        let mut contacts = Scene::entity("contacts");
        let mut touched: BTreeMap<u16, u8> = BTreeMap::new();
        for (&(cell, _), &level) in &self.levels {
            let top = touched.entry(cell).or_default();
            *top = (*top).max(level);
        }
        for (cell, level) in touched {
            let Some(place) = ids.iter().position(|&i| i == cell).and_then(|k| at.get(k)) else { continue };
            let size = 0.02 + 0.01 * f64::from(level);
            contacts.spheres.push(SpherePrimitive {
                pose: pose(place),
                size: vector(&nalgebra::Vector3::repeat(size)),
                color: Some(Color { r: 1.0, g: 0.8, b: 0.1, a: 0.25 + 0.15 * f64::from(level.min(4)) }),
            });
        }
        SceneUpdate { deletions: Vec::new(), entities: vec![cells, contacts] }
    }
}

#[cfg(test)]
mod tests {
    use skin_protocol::message::TactileEvent;
    use skin_protocol::Address;

    use super::*;
    use crate::interface::Event;

    fn sample(force: u16, proximity: u16) -> Sample {
        Sample::new(proximity, [force, 0, 0], [0, 0, 256], 800, 0).unwrap()
    }

    fn event(cell: u16, kind: EventKind) -> Event {
        Event { interface: 0, timestamp_us: 0, cell: Address(cell), kind }
    }

    #[test]
    fn cells_are_drawn_in_id_order_coloured_by_what_they_feel() {
        let mut scene = Scene::new();
        scene.take(Update::Events(vec![
            event(9, EventKind::Sample(sample(0, 0))),
            event(3, EventKind::Sample(sample(4095, 0))),
            event(5, EventKind::Sample(sample(0, u16::MAX))),
        ]));
        let update = scene.cells(&Skeleton::default());
        let cells = &update.entities[0];
        assert_eq!(cells.metadata[0].value, "3,5,9");
        assert_eq!(cells.metadata[1].value, "1.000,0.000,0.000");
        let c: Vec<Color> = cells.cubes.iter().map(|c| c.color.unwrap()).collect();
        assert!(c[0].r > 0.9 && c[0].b < 0.2, "full force is red: {:?}", c[0]);
        assert!(c[1].b > 0.9 && c[1].r < 0.2, "close proximity is blue: {:?}", c[1]);
        assert_eq!((c[2].r, c[2].g, c[2].b), (0.6, 0.6, 0.6), "at rest, grey");
        let height = |k: usize| cells.cubes[k].size.unwrap().z;
        assert!(height(0) > 5.0 * height(2), "force makes the cube taller");
        let spots: Vec<(f64, f64)> =
            cells.cubes.iter().map(|c| c.pose.unwrap().position.unwrap()).map(|p| (p.x, p.y)).collect();
        assert!(spots[0] != spots[1] && spots[1] != spots[2], "loose cells do not overlap: {spots:?}");
    }

    #[test]
    fn tactile_levels_come_and_go_as_contacts_and_are_logged() {
        let mut scene = Scene::new();
        let touch = |level| EventKind::Tactile(TactileEvent { channel: Channel::Force1, level, value: 0 });
        scene.take(Update::Events(vec![event(4, EventKind::Sample(sample(2000, 0))), event(4, touch(3))]));
        let contacts = |s: &Scene| s.cells(&Skeleton::default()).entities[1].spheres.len();
        assert_eq!(contacts(&scene), 1);
        scene.take(Update::Events(vec![event(4, touch(0))]));
        assert_eq!(contacts(&scene), 0);
        let logs: Vec<String> = scene.take_logs().into_iter().map(|l| l.message).collect();
        assert_eq!(logs, ["cell 4: force 1 level 3 (high force)", "cell 4: force 1 level 0 (no force)"]);
        assert!(scene.take_logs().is_empty(), "taken once");
    }

    #[test]
    fn a_flood_of_events_is_logged_up_to_a_bound_and_counted() {
        let mut scene = Scene::new();
        let touch = EventKind::Tactile(TactileEvent { channel: Channel::Proximity, level: 1, value: 0 });
        scene.take(Update::Events(vec![event(1, touch); LOG_LINES + 7]));
        assert_eq!((scene.take_logs().len(), scene.logs_dropped()), (LOG_LINES, 7));
    }
}
