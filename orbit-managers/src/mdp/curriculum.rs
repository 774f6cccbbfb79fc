//! Curriculum terms.
use super::*;

/// Parameters of `modify_reward_weight`.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModifyRewardWeightParams {
    /// Reward term to change.
    pub term_name: String,
    /// Its new weight.
    pub weight: f32,
    /// Env steps (the common step counter) after which the weight applies.
    pub num_steps: u64,
}

/// `modify_reward_weight`: once the common step counter exceeds `num_steps`, sets the reward
/// term's weight (idempotent); logs the current weight.
struct ModifyRewardWeight(ModifyRewardWeightParams);

impl CurriculumTerm for ModifyRewardWeight {
    fn compute(
        &mut self,
        _env_ids: &[usize],
        common_step_counter: u64,
        rewards: &mut crate::managers::RewardManager,
    ) -> Result<Option<f32>, EnvError> {
        if common_step_counter > self.0.num_steps {
            rewards.set_weight(&self.0.term_name, self.0.weight)?;
        }
        Ok(rewards.weight(&self.0.term_name))
    }
}

inventory::submit! { CurriculumTermDef { name: "modify_reward_weight", build: |c| {
    Ok(Box::new(ModifyRewardWeight(c.params()?)))
} } }
