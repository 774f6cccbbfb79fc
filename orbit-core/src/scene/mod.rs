//! Scene descriptions: asset models, the declarative scene config, and the resolved scene.

mod articulation;
mod cfg;
mod desc;
mod model;
mod viewer;

pub use cfg::*;
pub use desc::*;
pub use model::*;
pub use viewer::*;
