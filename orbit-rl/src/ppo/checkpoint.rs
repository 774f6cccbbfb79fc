//! Checkpoints of the learner: the network and Adam's state as burnpack files.

use std::path::Path;

use burn::module::Module;

use super::Ppo;
use crate::RlError;
use crate::adam::Adam;
use crate::model::ActorCritic;

impl Ppo {
    /// Saves the network and the optimiser state as burnpack files `<base>.bpk` and
    /// `<base>.adam.bpk`.
    pub fn save(&self, base: &Path) -> Result<(), RlError> {
        self.save_files(
            &base.with_extension("bpk"),
            &base.with_extension("adam.bpk"),
        )
    }

    /// Saves the network to `model_path` and the optimiser state to `adam_path` (burnpack
    /// files, whatever the names).
    pub fn save_files(&self, model_path: &Path, adam_path: &Path) -> Result<(), RlError> {
        self.model
            .clone()
            .save_file(model_path)
            .map_err(|e| RlError::checkpoint(model_path, e))?;
        self.current_optimizer()?.save(&self.model, adam_path)
    }

    /// Loads the network (and, if `with_optimizer`, the optimiser state) saved by [`Ppo::save`].
    /// A checkpoint whose optimiser state is in burn's format (`<base>.optim.bpk`, written
    /// before Adam kept its learning rate on the device) resumes with fresh Adam moments and a
    /// warning. A load that fails changes nothing.
    pub fn load(&mut self, base: &Path, with_optimizer: bool) -> Result<(), RlError> {
        let model = load_model(self.model.clone(), base)?;
        if with_optimizer {
            let path = base.with_extension("adam.bpk");
            let legacy = base.with_extension("optim.bpk");
            let mut optimizer = self.optimizer.clone();
            if !path.exists() && legacy.exists() {
                tracing::warn!(
                    "{} holds burn's Adam state, which this version does not read: resuming \
                     with fresh Adam moments (the weights, normalisers and learning rate are \
                     restored)",
                    legacy.display()
                );
                optimizer = Adam::new(self.learning_rate, &self.device);
            } else {
                optimizer.load(&model, &path)?;
            }
            self.optimizer = optimizer;
        }
        self.model = model;
        self.rollout_model = None;
        self.fused_reload();
        Ok(())
    }
}

/// Loads network weights saved by [`Ppo::save`] into `model` (which fixes the architecture).
pub fn load_model(model: ActorCritic, base: &Path) -> Result<ActorCritic, RlError> {
    let path = base.with_extension("bpk");
    model
        .try_load_file(&path)
        .map_err(|e| RlError::checkpoint(path, e))
}

#[cfg(test)]
mod tests {
    use crate::RlError;
    use crate::ppo::fixtures::{ppo, rollout};
    use crate::ppo::values;

    /// A checkpoint restores Adam's state; one whose Adam file is missing is refused without
    /// touching the network, and one with only burn's older optimiser file resumes with fresh
    /// moments.
    #[test]
    fn checkpoints_restore_adam_or_refuse_cleanly() {
        let mut p = ppo(16, 4);
        rollout(&mut p);
        p.update().unwrap();
        let dir = std::env::temp_dir().join(format!("orbit-ppo-ckpt-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let base = dir.join("model_0");
        p.save(&base).unwrap();
        let steps = p.optimizer.steps();
        assert_eq!(steps, 4, "2 epochs × 2 minibatches");

        let mut q = ppo(16, 4);
        q.load(&base, true).unwrap();
        assert_eq!(q.optimizer.steps(), steps);
        assert_eq!(values(q.model.action_std()), values(p.model.action_std()));

        let adam = base.with_extension("adam.bpk");
        std::fs::rename(&adam, base.with_extension("elsewhere")).unwrap();
        let mut r = ppo(16, 4);
        let fresh = values(r.model.action_std());
        assert_ne!(fresh, values(p.model.action_std()), "the update moved σ");
        assert!(matches!(
            r.load(&base, true),
            Err(RlError::Checkpoint { .. })
        ));
        assert_eq!(
            values(r.model.action_std()),
            fresh,
            "the network is untouched"
        );

        std::fs::rename(
            base.with_extension("elsewhere"),
            base.with_extension("optim.bpk"),
        )
        .unwrap();
        r.load(&base, true).unwrap();
        assert_eq!(r.optimizer.steps(), 0);
        assert_eq!(values(r.model.action_std()), values(p.model.action_std()));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
