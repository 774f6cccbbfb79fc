//! Movement primitives for episodic (black-box) RL, following MP_PyTorch 0.1.3 as Fancy Gym's
//! box pushing uses it (`shared/spec/box_pushing.md` §7.2): a linear phase, a zero-padded
//! normalised RBF basis and ProMP trajectories, generated for all envs at once.

mod basis;
mod error;
mod phase;
mod promp;

pub use basis::ZeroPaddedRbf;
pub use error::MpError;
pub use phase::LinearPhase;
pub use promp::{ProMp, ProMpCfg};
