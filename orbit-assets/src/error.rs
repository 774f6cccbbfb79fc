//! Errors of asset loading. Every message names the file (or the asset name) and the offending
//! element, and says what to change.

use orbit_core::scene::ModelError;

/// Why an asset could not be turned into a model.
#[derive(Debug, thiserror::Error)]
pub enum AssetError {
    /// A scene config file is malformed (file, line, column and field path in the message).
    #[error(transparent)]
    Config(#[from] orbit_core::config::ConfigError),
    /// A scene config is well-formed but does not resolve (unknown joints, bad values, ...).
    #[error("{file}: {source}")]
    Scene {
        /// The scene config file.
        file: String,
        /// What does not resolve, with the field path (boxed: it is large and rare).
        source: Box<orbit_core::scene::SceneError>,
    },
    /// The file could not be read.
    #[error("cannot read `{file}`: {source}")]
    Io {
        /// File path.
        file: String,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The text is not well-formed XML or not a URDF document (message from urdf-rs).
    #[error("{file}: not a valid URDF document: {message}")]
    Parse {
        /// File name.
        file: String,
        /// Parser message.
        message: String,
    },
    /// The robot has no `<link>`.
    #[error("{file}: the robot has no links; a URDF needs at least one `<link>`")]
    NoLinks {
        /// File name.
        file: String,
    },
    /// Two links or two joints share a name.
    #[error("{file}: two {kind}s are named `{name}`; {kind} names must be unique")]
    DuplicateName {
        /// File name.
        file: String,
        /// `"link"` or `"joint"`.
        kind: &'static str,
        /// The repeated name.
        name: String,
    },
    /// A joint names a parent or child link that is not defined.
    #[error(
        "{file}: joint `{joint}` names {role} link `{link}`, which is not defined; \
         add `<link name=\"{link}\">` or fix the name"
    )]
    MissingLink {
        /// File name.
        file: String,
        /// The joint.
        joint: String,
        /// `"parent"` or `"child"`.
        role: &'static str,
        /// The undefined link name.
        link: String,
    },
    /// A link is the child of more than one joint.
    #[error(
        "{file}: link `{link}` is the child of both joint `{first}` and joint `{second}`; \
         each link may have only one parent joint"
    )]
    TwoParents {
        /// File name.
        file: String,
        /// The link.
        link: String,
        /// First joint naming it as child.
        first: String,
        /// Second joint naming it as child.
        second: String,
    },
    /// More than one link is nobody's child.
    #[error(
        "{file}: links {} are not the child of any joint, but a URDF tree has exactly one \
         root link; connect the others with joints",
        quoted(.roots)
    )]
    SeveralRoots {
        /// File name.
        file: String,
        /// The root candidates.
        roots: Vec<String>,
    },
    /// The joints form a cycle (so some links are not reachable from a single root).
    #[error(
        "{file}: joints form a cycle through links {}; a URDF must be a tree",
        quoted(.links)
    )]
    Cycle {
        /// File name.
        file: String,
        /// Links on the cycle.
        links: Vec<String>,
    },
    /// A joint type orbit-rs cannot simulate.
    #[error(
        "{file}: joint `{joint}` has type `{kind}`, which is not supported; use revolute, \
         continuous, prismatic or fixed (articulations have a fixed base: for a floating \
         base, drop the joint and its dummy parent link)"
    )]
    UnsupportedJoint {
        /// File name.
        file: String,
        /// The joint.
        joint: String,
        /// The URDF joint type.
        kind: String,
    },
    /// A revolute or prismatic joint with a zero (or non-finite) axis.
    #[error(
        "{file}: joint `{joint}` has axis {axis:?}, which has no direction; give a non-zero \
         `<axis xyz=\"...\"/>`"
    )]
    ZeroAxis {
        /// File name.
        file: String,
        /// The joint.
        joint: String,
        /// The axis as written.
        axis: [f64; 3],
    },
    /// Joint limits with `lower > upper` (or NaN).
    #[error(
        "{file}: joint `{joint}` has lower limit {lower} > upper limit {upper}; \
         fix `<limit lower=... upper=...>`"
    )]
    InvalidLimits {
        /// File name.
        file: String,
        /// The joint.
        joint: String,
        /// Lower limit as written.
        lower: f64,
        /// Upper limit as written.
        upper: f64,
    },
    /// Mass or inertia that is not finite, or negative.
    #[error("{file}: link `{link}`: {problem}")]
    InvalidInertial {
        /// File name.
        file: String,
        /// The link.
        link: String,
        /// What is wrong.
        problem: String,
    },
    /// Any other value that is out of range (non-finite origin, non-positive shape size,
    /// missing `<limit>`, negative damping, malformed extension element, ...).
    #[error("{file}: {element}: {problem}")]
    InvalidValue {
        /// File name.
        file: String,
        /// The element, e.g. ``joint `j1` `` or ``link `base`, collision 0``.
        element: String,
        /// What is wrong and what is expected.
        problem: String,
    },
    /// An MJCF file that is not well-formed XML.
    #[error("{file}:{line}: not well-formed XML: {message}")]
    MjcfSyntax {
        /// File name.
        file: String,
        /// Line of the problem (1-based).
        line: usize,
        /// The XML parser's message.
        message: String,
    },
    /// An MJCF element or attribute that is malformed, out of range or not supported.
    #[error(
        "{file}:{line}: <{element}>{}: {message}",
        attribute.as_ref().map_or(String::new(), |a| format!(" attribute `{a}`"))
    )]
    Mjcf {
        /// File name.
        file: String,
        /// Line of the element (1-based).
        line: usize,
        /// The element's name.
        element: String,
        /// The attribute, if one is at fault.
        attribute: Option<String>,
        /// What is wrong and what is expected.
        message: String,
    },
    /// The imported model failed [`orbit_core::scene::ArticulationModel::validate`].
    #[error("{file}: {source}")]
    Model {
        /// File name.
        file: String,
        /// The model error.
        #[source]
        source: ModelError,
    },
    /// An asset path matched neither a file nor a bundled asset.
    #[error(
        "asset `{path}` not found: tried {}; bundled assets are {}",
        quoted(.tried),
        quoted(.bundled)
    )]
    NotFound {
        /// The path as given.
        path: String,
        /// File paths tried.
        tried: Vec<String>,
        /// Names of the bundled assets.
        bundled: Vec<String>,
    },
}

/// `` `a`, `b` `` for error messages.
fn quoted(names: &[String]) -> String {
    let list: Vec<String> = names.iter().map(|n| format!("`{n}`")).collect();
    list.join(", ")
}
