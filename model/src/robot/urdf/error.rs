//! What can be wrong with a URDF document, one line each.

/// Why a URDF document is not a robot the simulator can run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum UrdfError {
    /// The file could not be read.
    #[error("cannot read URDF file {path}: {source}")]
    Read {
        /// The file.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// Not well-formed XML, or not a `<robot>` document.
    #[error("not a valid URDF document: {0}")]
    Syntax(String),
    /// The document is bigger than the reader accepts (bytes, XML nodes,
    /// nesting depth, links, joints or DoFs).
    #[error("the URDF has more than {limit} {what}, the most the simulator accepts")]
    TooLarge {
        /// What was counted, e.g. "levels of element nesting".
        what: &'static str,
        /// The largest accepted count.
        limit: usize,
    },
    /// A required attribute or element is absent.
    #[error("{element} has no {what}")]
    Missing {
        /// The element, e.g. `joint "elbow"`.
        element: String,
        /// What it lacks, e.g. `<parent link="...">`.
        what: String,
    },
    /// An attribute that should hold numbers does not.
    #[error("{element}: \"{value}\" is not {expected}")]
    Number {
        /// The element and attribute, e.g. `joint "elbow" <origin> xyz`.
        element: String,
        /// The text found (shortened).
        value: String,
        /// What was expected, e.g. "3 numbers".
        expected: &'static str,
    },
    /// A NaN or infinite number where a finite one is needed.
    #[error("{element} contains a number that is not finite")]
    NotFinite {
        /// The element and attribute, e.g. `joint "elbow" <origin> xyz`.
        element: String,
    },
    /// A finite number outside what a robot can physically be.
    #[error("{element} = {value:?} is out of range: {range}")]
    OutOfRange {
        /// The element and attribute, e.g. `link "base" <box> size`.
        element: String,
        /// The value found.
        value: f64,
        /// The accepted range, with its unit.
        range: &'static str,
    },
    /// Two links or two joints share a name.
    #[error("{kind} \"{name}\" is defined twice")]
    Duplicate {
        /// "link" or "joint".
        kind: &'static str,
        /// The repeated name.
        name: String,
    },
    /// A joint names a link that does not exist.
    #[error("joint \"{joint}\" refers to link \"{link}\", which is not defined")]
    UnknownLink {
        /// The joint.
        joint: String,
        /// The missing link.
        link: String,
    },
    /// A link is the child of two joints: a closed kinematic loop.
    #[error(
        "link \"{link}\" is the child of both joint \"{first}\" and joint \"{second}\": closed loops are not supported"
    )]
    TwoParents {
        /// The link.
        link: String,
        /// One parent joint.
        first: String,
        /// The other parent joint.
        second: String,
    },
    /// Not exactly one link without a parent.
    #[error("a robot needs exactly one root link (a link that is no joint's child), found: {0:?}")]
    Roots(Vec<String>),
    /// A joint type the method cannot handle.
    #[error("joint \"{joint}\" is {kind}: only revolute, continuous, prismatic and fixed joints are supported")]
    UnsupportedJoint {
        /// The joint.
        joint: String,
        /// Its URDF type.
        kind: String,
    },
    /// A joint axis of zero length.
    #[error("joint \"{joint}\" has a zero-length <axis>")]
    ZeroAxis {
        /// The joint.
        joint: String,
    },
    /// A revolute or prismatic joint whose range is empty or reversed.
    #[error(
        "{kind} joint \"{joint}\" has limits lower = {lower}, upper = {upper}: give it a <limit> with lower < upper{hint}"
    )]
    BadLimits {
        /// "revolute" or "prismatic".
        kind: &'static str,
        /// The joint.
        joint: String,
        /// Lower limit, rad or m.
        lower: f64,
        /// Upper limit, rad or m.
        upper: f64,
        /// What else the user can do.
        hint: &'static str,
    },
    /// A mimic joint follows a joint that does not exist, or mimics go round in a circle.
    #[error("joint \"{joint}\" mimics \"{master}\", which is not a joint it can follow")]
    BadMimic {
        /// The mimic joint.
        joint: String,
        /// The master it names.
        master: String,
    },
    /// Nothing to explore.
    #[error("the robot has no revolute, continuous or prismatic joint")]
    NoDofs,
    /// A pose with another number of values than the robot has DoFs.
    #[error("a pose of {got} values for a robot with {expected} DoFs")]
    PoseLength {
        /// DoFs of the robot.
        expected: usize,
        /// Values given.
        got: usize,
    },
}
