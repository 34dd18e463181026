//! Reading the parts of a URDF document the simulator needs.
//!
//! Tolerant by design: only `<robot name>` and its `<link>` (inertial
//! origin and mass; visual and collision origin and geometry) and `<joint>`
//! (type, parent, child, origin, axis, limit with effort, mimic) children are read.
//! Every other element and attribute (materials and textures, gazebo,
//! transmissions, sensors, safety controllers, calibration, dynamics,
//! ros2_control, xacro leftovers, mesh file names) is skipped unread, so
//! what the method does not need cannot make a file fail. Defaults are the
//! URDF specification's: identity origin, axis `1 0 0`, zero mass, limits
//! 0, velocity and effort 0 (none). Every number read is checked ([`Quantity`]).

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use roxmltree::{Document, Node, ParsingOptions};

use super::limits::{Quantity, MAX_BYTES, MAX_DEPTH, MAX_LINKS, MAX_NODES};
use super::UrdfError;
use crate::robot::Shape;

/// An `<origin>`: translation and roll-pitch-yaw.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Pose {
    /// Translation, m.
    pub xyz: [f64; 3],
    /// Roll, pitch, yaw, rad.
    pub rpy: [f64; 3],
}

impl Pose {
    pub fn isometry(&self) -> Isometry3<f64> {
        let [r, p, y] = self.rpy;
        Isometry3::from_parts(Translation3::from(Vector3::from(self.xyz)), UnitQuaternion::from_euler_angles(r, p, y))
    }
}

/// A `<visual>` or `<collision>`: where it is and, for a primitive, its shape
/// (`None` for a mesh, whose file is never read).
pub(super) type Geometry = (Pose, Option<Shape>);

/// A `<link>`.
#[derive(Clone, Debug)]
pub(super) struct LinkDesc {
    pub name: String,
    /// `<inertial><mass value>`, kg.
    pub mass: f64,
    /// `<inertial><origin>`: the centre of mass.
    pub com: Pose,
    pub visuals: Vec<Geometry>,
    pub collisions: Vec<Geometry>,
}

/// The joint types the simulator runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum JointType {
    Fixed,
    Revolute,
    Continuous,
    Prismatic,
}

/// A `<limit>`: position range (rad or m), velocity and effort (0 for none).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Limit {
    pub lower: f64,
    pub upper: f64,
    pub velocity: f64,
    pub effort: f64,
}

/// A `<mimic>`: `q = multiplier * q_master + offset`.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Mimic {
    pub joint: String,
    pub multiplier: f64,
    pub offset: f64,
}

/// A `<joint>`.
#[derive(Clone, Debug)]
pub(super) struct JointDesc {
    pub name: String,
    pub kind: JointType,
    pub parent: String,
    pub child: String,
    pub origin: Pose,
    pub axis: [f64; 3],
    pub limit: Limit,
    pub mimic: Option<Mimic>,
}

/// What the simulator reads of a URDF document.
#[derive(Clone, Debug)]
pub(super) struct Description {
    pub name: String,
    pub links: Vec<LinkDesc>,
    pub joints: Vec<JointDesc>,
}

/// Reads `xml` within the limits of [`super::limits`], in time linear in its length.
pub(super) fn read(xml: &str) -> Result<Description, UrdfError> {
    if xml.len() > MAX_BYTES {
        return Err(UrdfError::TooLarge { what: "bytes", limit: MAX_BYTES });
    }
    let options = ParsingOptions { nodes_limit: MAX_NODES, ..ParsingOptions::default() };
    let doc = Document::parse_with_options(xml, options).map_err(|e| match e {
        roxmltree::Error::NodesLimitReached => UrdfError::TooLarge { what: "XML nodes", limit: MAX_NODES as usize },
        e => UrdfError::Syntax(e.to_string()),
    })?;
    check_depth(&doc)?;
    let robot = doc.root_element();
    if robot.tag_name().name() != "robot" {
        return Err(UrdfError::Syntax(format!("the root element is <{}>, not <robot>", robot.tag_name().name())));
    }
    let name = required(robot, "name", || "<robot>".into())?.to_owned();
    let (mut links, mut joints) = (Vec::new(), Vec::new());
    for node in robot.children().filter(Node::is_element) {
        match node.tag_name().name() {
            "link" if links.len() == MAX_LINKS => return Err(UrdfError::TooLarge { what: "links", limit: MAX_LINKS }),
            "joint" if joints.len() == MAX_LINKS => {
                return Err(UrdfError::TooLarge { what: "joints", limit: MAX_LINKS })
            }
            "link" => links.push(link(node)?),
            "joint" => joints.push(joint(node)?),
            _ => {}
        }
    }
    Ok(Description { name, links, joints })
}

/// Refuses nesting deeper than [`MAX_DEPTH`], walking with a bounded
/// explicit stack: a hostile depth costs one linear pass, never the stack.
fn check_depth(doc: &Document) -> Result<(), UrdfError> {
    let mut stack = vec![doc.root_element().children()];
    while let Some(top) = stack.last_mut() {
        match top.next() {
            Some(n) if n.is_element() => {
                if stack.len() >= MAX_DEPTH {
                    return Err(UrdfError::TooLarge { what: "levels of element nesting", limit: MAX_DEPTH });
                }
                stack.push(n.children());
            }
            Some(_) => {}
            None => {
                stack.pop();
            }
        }
    }
    Ok(())
}

fn link(node: Node) -> Result<LinkDesc, UrdfError> {
    let name = required(node, "name", || "a <link>".into())?.to_owned();
    let at = |what: &str| format!("link \"{name}\" {what}");
    let (mut mass, mut com) = (0.0, Pose::default());
    if let Some(inertial) = child(node, "inertial") {
        com = origin(inertial, || at("<inertial>"))?;
        if let Some(m) = child(inertial, "mass") {
            mass = number(required(m, "value", || at("<mass>"))?, Quantity::Mass, || at("<mass> value"))?;
        }
    }
    let geometries = |tag: &str| -> Result<Vec<Geometry>, UrdfError> {
        let element = format!("<{tag}>");
        elements(node, tag).map(|g| geometry(g, &|what| at(&format!("{element} {what}")))).collect()
    };
    let visuals = geometries("visual")?;
    let collisions = geometries("collision")?;
    Ok(LinkDesc { name, mass, com, visuals, collisions })
}

/// A `<visual>` or `<collision>`; `at` names its parts in errors.
fn geometry(node: Node, at: &dyn Fn(&str) -> String) -> Result<Geometry, UrdfError> {
    let pose = origin(node, || at("<origin>"))?;
    let Some(shape) = child(node, "geometry").and_then(|g| g.children().find(Node::is_element)) else {
        return Ok((pose, None));
    };
    let tag = format!("<{}>", shape.tag_name().name());
    let size =
        |attr: &str| number(required(shape, attr, || at(&tag))?, Quantity::Size, || at(&format!("{tag} {attr}")));
    let shape = match shape.tag_name().name() {
        "box" => {
            let text = required(shape, "size", || at("<box>"))?;
            Some(Shape::Box(Vector3::from(numbers::<3>(text, Quantity::Size, || at("<box> size"))?)))
        }
        "cylinder" => Some(Shape::Cylinder { radius: size("radius")?, length: size("length")? }),
        "capsule" => Some(Shape::Capsule { radius: size("radius")?, length: size("length")? }),
        "sphere" => Some(Shape::Sphere(size("radius")?)),
        // A mesh (its file is not read) or something unknown: no primitive.
        _ => None,
    };
    Ok((pose, shape))
}

fn joint(node: Node) -> Result<JointDesc, UrdfError> {
    let name = required(node, "name", || "a <joint>".into())?.to_owned();
    let me = format!("joint \"{name}\"");
    let at = |what: &str| format!("{me} {what}");
    let kind = match required(node, "type", || me.clone())? {
        "fixed" => JointType::Fixed,
        "revolute" => JointType::Revolute,
        "continuous" => JointType::Continuous,
        "prismatic" => JointType::Prismatic,
        other => return Err(UrdfError::UnsupportedJoint { joint: name, kind: shorten(other) }),
    };
    let link_of = |tag: &str| -> Result<String, UrdfError> {
        let what = format!("<{tag} link=\"...\">");
        let element = child(node, tag).ok_or_else(|| UrdfError::Missing { element: me.clone(), what })?;
        Ok(required(element, "link", || at(&format!("<{tag}>")))?.to_owned())
    };
    let (parent, child_link) = (link_of("parent")?, link_of("child")?);
    let origin = origin(node, || at("<origin>"))?;
    let axis = match child(node, "axis").and_then(|a| a.attribute("xyz")) {
        Some(text) => numbers::<3>(text, Quantity::Direction, || at("<axis> xyz"))?,
        None => [1.0, 0.0, 0.0],
    };
    let mut limit = Limit::default();
    if let Some(l) = child(node, "limit") {
        let number = |attr: &str, q: Quantity| optional(l, attr, 0.0, q, || at(&format!("<limit> {attr}")));
        let range = match kind {
            JointType::Prismatic => Some(Quantity::Position),
            JointType::Revolute => Some(Quantity::Angle),
            // A continuous joint has no range; a fixed joint no motion.
            JointType::Continuous | JointType::Fixed => None,
        };
        if let Some(q) = range {
            limit.lower = number("lower", q)?;
            limit.upper = number("upper", q)?;
        }
        limit.velocity = number("velocity", Quantity::Speed)?;
        limit.effort = number("effort", Quantity::Effort)?;
    }
    let mimic = match child(node, "mimic") {
        Some(m) => {
            let number = |attr: &str, default: f64| {
                optional(m, attr, default, Quantity::Mimic, || at(&format!("<mimic> {attr}")))
            };
            Some(Mimic {
                joint: required(m, "joint", || at("<mimic>"))?.to_owned(),
                multiplier: number("multiplier", 1.0)?,
                offset: number("offset", 0.0)?,
            })
        }
        None => None,
    };
    Ok(JointDesc { name, kind, parent, child: child_link, origin, axis, limit, mimic })
}

/// The `<origin>` child of `node`, identity if absent.
fn origin(node: Node, at: impl Fn() -> String) -> Result<Pose, UrdfError> {
    let Some(o) = child(node, "origin") else { return Ok(Pose::default()) };
    let read = |attr: &str, q: Quantity| -> Result<[f64; 3], UrdfError> {
        o.attribute(attr).map_or(Ok([0.0; 3]), |text| numbers::<3>(text, q, || format!("{} {attr}", at())))
    };
    Ok(Pose { xyz: read("xyz", Quantity::Position)?, rpy: read("rpy", Quantity::Angle)? })
}

/// The first child element named `tag`.
fn child<'a, 'input>(node: Node<'a, 'input>, tag: &str) -> Option<Node<'a, 'input>> {
    node.children().find(|n| n.is_element() && n.tag_name().name() == tag)
}

/// The child elements named `tag`.
fn elements<'a, 'input: 'a>(node: Node<'a, 'input>, tag: &'a str) -> impl Iterator<Item = Node<'a, 'input>> + 'a {
    node.children().filter(move |n| n.is_element() && n.tag_name().name() == tag)
}

/// The attribute `attr` of `node`, or an error naming `element`.
fn required<'a>(node: Node<'a, '_>, attr: &str, element: impl FnOnce() -> String) -> Result<&'a str, UrdfError> {
    node.attribute(attr).ok_or_else(|| UrdfError::Missing { element: element(), what: format!("{attr} attribute") })
}

/// The number in attribute `attr` of `node`, checked as `q`; `default` if absent.
fn optional(node: Node, attr: &str, default: f64, q: Quantity, at: impl Fn() -> String) -> Result<f64, UrdfError> {
    node.attribute(attr).map_or(Ok(default), |text| number(text, q, at))
}

/// One number, checked as `q`.
fn number(text: &str, q: Quantity, at: impl Fn() -> String) -> Result<f64, UrdfError> {
    Ok(numbers::<1>(text, q, at)?[0])
}

/// Exactly `N` whitespace-separated numbers, each checked as `q`.
fn numbers<const N: usize>(text: &str, q: Quantity, at: impl Fn() -> String) -> Result<[f64; N], UrdfError> {
    let bad = || UrdfError::Number {
        element: at(),
        value: shorten(text),
        expected: if N == 1 { "a number" } else { "3 numbers" },
    };
    let mut out = [0.0; N];
    let mut words = text.split_ascii_whitespace();
    for v in &mut out {
        let x: f64 = words.next().and_then(|w| w.parse().ok()).ok_or_else(bad)?;
        *v = q.check(x, &at)?;
    }
    match words.next() {
        Some(_) => Err(bad()),
        None => Ok(out),
    }
}

/// `text` cut to a length fit for a one-line error.
fn shorten(text: &str) -> String {
    const KEEP: usize = 40;
    match text.char_indices().nth(KEEP) {
        Some((end, _)) => format!("{}...", &text[..end]),
        None => text.to_owned(),
    }
}
