//! Scene descriptions: asset models, the declarative scene config, and the resolved scene.

mod cfg;
mod desc;
mod model;

pub use cfg::*;
pub use desc::*;
pub use model::*;
