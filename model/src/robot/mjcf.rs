//! Writing a [`Robot`] as an MJCF model MuJoCo loads: the same bodies,
//! joints, axes and limits, so that MuJoCo's forward kinematics equals
//! [`super::kinematics::forward`], and the collision shapes the skin is
//! laid on.
//!
//! MuJoCo needs what a description of the skin's view leaves out: masses,
//! inertias and actuators. They are written from stated rules, the same
//! for every robot (the built-in one and any URDF):
//!
//! - **Masses**: a link's URDF mass spread over its collision shapes by
//!   volume; a link without a mass weighs as water (MuJoCo's default
//!   density, 1000 kg/m^3). MuJoCo computes the inertias from the shapes, so
//!   a URDF's own inertia tensor and centre-of-mass offset are not carried.
//! - **Actuators**: one position servo per DoF (Menagerie's choice), full
//!   torque at [`SATURATION_RAD`] (or [`SATURATION_M`]) of error, force
//!   limited to the URDF's effort; without an effort, to three times the
//!   gravity torque the joint bears at worst over its subtree's shapes.
//! - **Armature**: each joint gets the reflected rotor inertia that keeps
//!   its servo's period at least [`STEPS_PER_PERIOD`]-fold longer than a
//!   step, so that stiff servos on light links stay stable at 2 ms.
//! - **Contacts**: the robot's shapes touch a scene's objects (MuJoCo's
//!   default contact type and affinity, 1 and 1) but not each other, as in
//!   the built-in world; a description's collision shapes often overlap
//!   where links meet, and bones around meshes always do.
//! - The root is fixed to the world, as a trunk on a stand; mimic joints
//!   follow their master through an equality constraint; the integrator is
//!   `implicitfast` at 2 ms, as Menagerie's models use.

use std::f64::consts::PI;
use std::fmt::Write;

use nalgebra::{Isometry3, Point3, UnitQuaternion, Vector3};

use super::kinematics::{forward, BodyState, DofMotion};
use super::{DofKind, Drive, Robot, Shape, Surface};

/// Simulation step, s: Menagerie's models' 2 ms.
pub const TIMESTEP_S: f64 = 0.002;
/// Position error at which a turning servo gives its full torque, rad.
pub const SATURATION_RAD: f64 = 0.05;
/// Position error at which a sliding servo gives its full force, m.
pub const SATURATION_M: f64 = 0.005;
/// Smallest servo period, in steps: armature is added below it.
pub const STEPS_PER_PERIOD: f64 = 20.0;
/// Effort assumed over the gravity load when the description gives none.
pub const GRAVITY_MARGIN: f64 = 3.0;
/// Smallest effort written, N m or N, so that a massless subtree's servo still moves it.
const MIN_EFFORT: f64 = 0.1;
/// Water, kg/m^3: the mass of a link whose description gives none.
const DENSITY_KG_M3: f64 = 1000.0;
const GRAVITY_M_S2: f64 = 9.81;

/// One collision shape of a body, body frame.
struct Geom {
    /// The MJCF attributes of type, size and placement.
    attributes: String,
    /// Centre, body frame.
    centre: Point3<f64>,
    /// Mass, kg.
    mass_kg: f64,
    /// The `<mesh>` asset a mesh geom names, written inline.
    mesh: Option<String>,
}

/// The MJCF text of `robot`, its servos' targets and its joints at its home pose.
pub fn write(robot: &Robot) -> String {
    let mut s = String::new();
    write_to(robot, &mut s).expect("writing to a String cannot fail");
    s
}

fn write_to(robot: &Robot, s: &mut String) -> std::fmt::Result {
    let geoms = body_geoms(robot);
    let efforts: Vec<f64> = (0..robot.dofs().len()).map(|d| effort(robot, &geoms, d)).collect();
    writeln!(s, "<mujoco model=\"{}\">", escape(robot.name()))?;
    writeln!(
        s,
        "  <!-- Written by skin-model from the robot's description: masses, inertias, servo gains, \
         armatures and effort limits follow the rules stated in skin_model::robot::mjcf. -->"
    )?;
    // Massless intermediate frames (URDF links without geometry) need a floor
    // on mass to compile; their joints' armature carries the dynamics.
    writeln!(s, "  <compiler angle=\"radian\" autolimits=\"true\" boundmass=\"1e-6\" boundinertia=\"1e-12\"/>")?;
    writeln!(s, "  <option integrator=\"implicitfast\" timestep=\"{TIMESTEP_S}\"/>")?;
    let meshes: Vec<&String> = geoms.iter().flatten().filter_map(|g| g.mesh.as_ref()).collect();
    if !meshes.is_empty() {
        writeln!(s, "  <asset>")?;
        for mesh in meshes {
            writeln!(s, "    {mesh}")?;
        }
        writeln!(s, "  </asset>")?;
    }
    writeln!(s, "  <worldbody>")?;
    writeln!(s, "    <light pos=\"0 0 3\" dir=\"0 0 -1\" directional=\"true\"/>")?;
    let mut joint_order = Vec::new();
    write_body(robot, &geoms, &efforts, 0, 2, &mut joint_order, s)?;
    writeln!(s, "  </worldbody>")?;

    let mimics: Vec<_> = robot
        .joints()
        .iter()
        .filter_map(|j| match j.drive {
            Drive::Mimic { dof, multiplier, offset } => Some((j, dof, multiplier, offset)),
            Drive::Dof(_) => None,
        })
        .collect();
    if !mimics.is_empty() {
        writeln!(s, "  <equality>")?;
        for (j, dof, multiplier, offset) in mimics {
            let master = &robot.joints()[robot.dofs()[dof].joint].name;
            writeln!(
                s,
                "    <joint joint1=\"{}\" joint2=\"{}\" polycoef=\"{offset} {multiplier} 0 0 0\"/>",
                escape(&j.name),
                escape(master)
            )?;
        }
        writeln!(s, "  </equality>")?;
    }

    writeln!(s, "  <actuator>")?;
    for (dof, &effort) in robot.dofs().iter().zip(&efforts) {
        write!(
            s,
            "    <position name=\"{name}\" joint=\"{name}\" kp=\"{kp}\" dampratio=\"1\" forcerange=\"{lo} {effort}\"",
            name = escape(&dof.name),
            kp = stiffness(dof.kind, effort),
            lo = -effort,
        )?;
        if dof.lower.is_finite() && dof.upper.is_finite() {
            write!(s, " ctrlrange=\"{} {}\"", dof.lower, dof.upper)?;
        }
        writeln!(s, "/>")?;
    }
    writeln!(s, "  </actuator>")?;

    let angles = robot.joint_angles(robot.home());
    // Adding zero turns a mirrored -0 into 0.
    let qpos: Vec<String> = joint_order.iter().map(|&j| (angles[j] + 0.0).to_string()).collect();
    let ctrl: Vec<String> = robot.home().iter().map(|q| (q + 0.0).to_string()).collect();
    writeln!(s, "  <keyframe>")?;
    writeln!(s, "    <key name=\"home\" qpos=\"{}\" ctrl=\"{}\"/>", qpos.join(" "), ctrl.join(" "))?;
    writeln!(s, "  </keyframe>")?;
    writeln!(s, "</mujoco>")
}

/// Writes body `b` and its subtree at `depth`, noting joints in document order.
fn write_body(
    robot: &Robot,
    geoms: &[Vec<Geom>],
    efforts: &[f64],
    b: usize,
    depth: usize,
    joint_order: &mut Vec<usize>,
    s: &mut String,
) -> std::fmt::Result {
    let indent = "  ".repeat(depth);
    let body = &robot.bodies()[b];
    let placement = match body.parent_joint {
        Some(j) => pose_attributes(&robot.joints()[j].origin),
        None => String::new(),
    };
    // A root named "world" (a common URDF idiom) is MuJoCo's world body itself.
    let in_world = b == 0 && body.name == "world";
    if !in_world {
        writeln!(s, "{indent}<body name=\"{}\"{placement}>", escape(&body.name))?;
    }
    if let Some(ji) = body.parent_joint {
        let j = &robot.joints()[ji];
        let kind = match j.kind {
            DofKind::Revolute => "hinge",
            DofKind::Prismatic => "slide",
        };
        let a = j.axis;
        write!(s, "{indent}  <joint name=\"{}\" type=\"{kind}\" axis=\"{} {} {}\"", escape(&j.name), a.x, a.y, a.z)?;
        if let Drive::Dof(d) = j.drive {
            let dof = &robot.dofs()[d];
            if dof.lower.is_finite() && dof.upper.is_finite() {
                write!(s, " range=\"{} {}\"", dof.lower, dof.upper)?;
            }
            write!(s, " armature=\"{}\"", armature(stiffness(dof.kind, efforts[d])))?;
        }
        writeln!(s, "/>")?;
        joint_order.push(ji);
    }
    for g in &geoms[b] {
        writeln!(s, "{indent}  <geom {} mass=\"{}\" contype=\"2\" conaffinity=\"1\"/>", g.attributes, g.mass_kg)?;
    }
    // Children in DoF order, so that MuJoCo numbers the joints as the description does.
    let mut children: Vec<(usize, usize)> = robot
        .joints()
        .iter()
        .filter(|j| j.parent_body == b)
        .map(|j| match j.drive {
            Drive::Dof(d) | Drive::Mimic { dof: d, .. } => (d, j.child_body),
        })
        .collect();
    children.sort_unstable();
    for (_, child) in children {
        write_body(robot, geoms, efforts, child, depth + 1, joint_order, s)?;
    }
    if !in_world {
        writeln!(s, "{indent}</body>")?;
    }
    Ok(())
}

/// Every body's collision shapes, body frame, with the masses of the rules above.
fn body_geoms(robot: &Robot) -> Vec<Vec<Geom>> {
    let mut out: Vec<Vec<Geom>> = robot.bodies().iter().map(|_| Vec::new()).collect();
    // Meshes written so far: each gets an asset of its own.
    let mut meshes = 0usize;
    for link in robot.links() {
        let shapes: Vec<(String, Point3<f64>, f64, Option<String>)> = match &link.surface {
            Surface::None => Vec::new(),
            Surface::Shapes(shapes) => shapes
                .iter()
                .map(|(pose, shape)| {
                    let pose = link.in_body * pose;
                    let mut centre = Point3::from(pose.translation.vector);
                    let mut asset = None;
                    let (kind, volume) = match *shape {
                        Shape::Box(e) => (
                            format!("type=\"box\" size=\"{} {} {}\"", e.x / 2.0, e.y / 2.0, e.z / 2.0),
                            e.x * e.y * e.z,
                        ),
                        Shape::Cylinder { radius, length } => (
                            format!("type=\"cylinder\" size=\"{radius} {}\"", length / 2.0),
                            PI * radius * radius * length,
                        ),
                        Shape::Capsule { radius, length } => (
                            format!("type=\"capsule\" size=\"{radius} {}\"", length / 2.0),
                            PI * radius * radius * (length + 4.0 / 3.0 * radius),
                        ),
                        Shape::Sphere(r) => (format!("type=\"sphere\" size=\"{r}\""), 4.0 / 3.0 * PI * r.powi(3)),
                        Shape::Mesh(ref mesh) => {
                            let (volume, at) = mesh.volume();
                            centre = pose * at;
                            let name = format!("mesh{meshes}");
                            meshes += 1;
                            asset = Some(mesh_asset(&name, mesh));
                            (format!("type=\"mesh\" mesh=\"{name}\""), volume)
                        }
                    };
                    (format!("{kind}{}", pose_attributes(&pose)), centre, volume, asset)
                })
                .collect(),
            Surface::Bones { points, radius } => points
                .iter()
                .map(|p| {
                    let (from, to) = (link.in_body * Point3::origin(), link.in_body * p);
                    let length = (to - from).norm();
                    let attributes = format!(
                        "type=\"capsule\" size=\"{radius}\" fromto=\"{} {} {} {} {} {}\"",
                        from.x, from.y, from.z, to.x, to.y, to.z
                    );
                    let volume = PI * radius * radius * length + 4.0 / 3.0 * PI * radius.powi(3);
                    (attributes, from + (to - from) / 2.0, volume, None)
                })
                .collect(),
        };
        let total: f64 = shapes.iter().map(|(_, _, v, _)| v).sum();
        for (attributes, centre, volume, mesh) in shapes {
            let mass_kg =
                if link.mass_kg > 0.0 && total > 0.0 { link.mass_kg * volume / total } else { DENSITY_KG_M3 * volume };
            out[link.body].push(Geom { attributes, centre, mass_kg, mesh });
        }
    }
    out
}

/// A `<mesh>` asset named `name` carrying `mesh`'s vertices and faces inline.
fn mesh_asset(name: &str, mesh: &super::Mesh) -> String {
    let vertices: Vec<String> = mesh.vertices().iter().map(|p| format!("{} {} {}", p.x, p.y, p.z)).collect();
    let faces: Vec<String> = mesh.faces().iter().map(|[a, b, c]| format!("{a} {b} {c}")).collect();
    format!("<mesh name=\"{name}\" vertex=\"{}\" face=\"{}\"/>", vertices.join(" "), faces.join(" "))
}

/// The effort limit of DoF `d`: the description's, else [`GRAVITY_MARGIN`]
/// times the worst gravity load of its subtree at the home pose (every
/// shape's weight at its distance from the axis, gravity across it).
fn effort(robot: &Robot, geoms: &[Vec<Geom>], d: usize) -> f64 {
    let dof = &robot.dofs()[d];
    if dof.max_effort.is_finite() {
        return dof.max_effort;
    }
    let n = robot.dofs().len();
    let mut states = Vec::new();
    let zero = vec![0.0; n];
    forward(
        robot,
        &BodyState::at_rest(Isometry3::identity()),
        DofMotion { q: robot.home(), qd: &zero, qdd: &zero },
        &mut states,
    );
    let joint = &robot.joints()[dof.joint];
    let at = states[joint.child_body].pose;
    let axis = at.rotation * joint.axis.into_inner();
    let moved = robot.moved_by(d);
    let load: f64 = (0..robot.bodies().len())
        .filter(|&b| moved[b])
        .flat_map(|b| geoms[b].iter().map(move |g| (b, g)))
        .map(|(b, g)| {
            let lever = match dof.kind {
                DofKind::Revolute => {
                    let r: Vector3<f64> = states[b].pose * g.centre - Point3::from(at.translation.vector);
                    (r - axis * r.dot(&axis)).norm()
                }
                DofKind::Prismatic => 1.0,
            };
            g.mass_kg * GRAVITY_M_S2 * lever
        })
        .sum();
    (GRAVITY_MARGIN * load).max(MIN_EFFORT)
}

/// A servo's gain: its full effort at the saturation error.
fn stiffness(kind: DofKind, effort: f64) -> f64 {
    effort
        / match kind {
            DofKind::Revolute => SATURATION_RAD,
            DofKind::Prismatic => SATURATION_M,
        }
}

/// The armature that puts the period of a servo of gain `kp` acting on it
/// alone at [`STEPS_PER_PERIOD`] steps: `2 pi sqrt(I / kp) = n dt`.
fn armature(kp: f64) -> f64 {
    let omega = 2.0 * PI / (STEPS_PER_PERIOD * TIMESTEP_S);
    kp / (omega * omega)
}

/// ` pos="x y z" quat="w x y z"` of a pose (identity parts left out).
fn pose_attributes(pose: &Isometry3<f64>) -> String {
    let mut s = String::new();
    let t = pose.translation.vector;
    if t != Vector3::zeros() {
        s += &format!(" pos=\"{} {} {}\"", t.x, t.y, t.z);
    }
    if pose.rotation != UnitQuaternion::identity() {
        let q = pose.rotation.quaternion();
        s += &format!(" quat=\"{} {} {} {}\"", q.w, q.i, q.j, q.k);
    }
    s
}

/// `text` safe inside a double-quoted XML attribute.
fn escape(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 2 kg box 0.5 m out on a horizontal hinge, and a slide carrying it,
    /// with no effort given.
    const ARM: &str = r#"<robot name="arm">
        <link name="base"/>
        <link name="carriage"><inertial><mass value="1"/></inertial>
            <collision><geometry><sphere radius="0.05"/></geometry></collision></link>
        <link name="arm"><inertial><mass value="2"/></inertial>
            <collision><origin xyz="0.5 0 0"/><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
        <joint name="lift" type="prismatic"><parent link="base"/><child link="carriage"/>
            <axis xyz="0 0 1"/><limit lower="0" upper="1"/></joint>
        <joint name="swing" type="revolute"><parent link="carriage"/><child link="arm"/>
            <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="7"/></joint>
    </robot>"#;

    fn attribute<'a>(mjcf: &'a str, element: &str, attr: &str) -> &'a str {
        let at = mjcf.find(element).unwrap_or_else(|| panic!("no {element}"));
        let rest = &mjcf[at..];
        let start = rest.find(&format!(" {attr}=\"")).unwrap() + attr.len() + 3;
        &rest[start..start + rest[start..].find('"').unwrap()]
    }

    #[test]
    fn without_an_effort_the_servo_bears_three_times_its_gravity_load() {
        let mjcf = write(&Robot::from_urdf_str(ARM).unwrap());
        // The slide lifts 3 kg; the hinge's own 7 N m is kept.
        let lift = GRAVITY_MARGIN * 3.0 * GRAVITY_M_S2;
        let numbers = |attr| -> Vec<f64> {
            attribute(&mjcf, "<position name=\"lift\"", attr).split(' ').map(|x| x.parse().unwrap()).collect()
        };
        let range = numbers("forcerange");
        assert!((range[0] + lift).abs() < 1e-9 && (range[1] - lift).abs() < 1e-9, "{range:?}");
        assert!((numbers("kp")[0] - lift / SATURATION_M).abs() < 1e-6);
        assert_eq!(attribute(&mjcf, "<position name=\"swing\"", "forcerange"), "-7 7");
        // The masses go to the shapes.
        assert_eq!(attribute(&mjcf, "<geom type=\"box\"", "mass"), "2");
    }

    #[test]
    fn the_armature_sets_a_servo_period_of_twenty_steps() {
        let kp = 1600.0;
        let period = 2.0 * PI * (armature(kp) / kp).sqrt();
        assert!((period - STEPS_PER_PERIOD * TIMESTEP_S).abs() < 1e-12, "{period}");
    }

    #[test]
    fn names_are_escaped_and_a_world_root_is_the_world_body() {
        let urdf = ARM.replace("\"base\"", "\"world\"").replace("<robot name=\"arm\">", "<robot name=\"a&quot;rm\">");
        let mjcf = write(&Robot::from_urdf_str(&urdf).unwrap());
        assert!(!mjcf.contains("<body name=\"world\""));
        assert!(mjcf.contains("<mujoco model=\"a&quot;rm\">"), "{mjcf}");
    }
}
