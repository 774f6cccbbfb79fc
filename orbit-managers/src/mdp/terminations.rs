//! Termination terms: time-out, joints out of manual bounds.
use super::*;

/// `time_out`: the episode has lasted `max_episode_length` steps.
struct TimeOut;

impl TerminationTerm for TimeOut {
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [bool]) {
        for (o, &l) in out.iter_mut().zip(env.episode_length) {
            *o = l >= env.max_episode_length;
        }
    }
}

inventory::submit! { TerminationTermDef { name: "time_out", build: |_| Ok(Box::new(TimeOut)) } }

/// Parameters of `joint_pos_out_of_manual_limit`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointBoundsParams {
    /// Articulation name.
    #[serde(default = "robot")]
    pub asset: String,
    /// Joint-name regexes (full match).
    #[serde(default = "all_joints")]
    pub joint_names: Vec<String>,
    /// `(lower, upper)` position bounds (rad or m).
    pub bounds: (f32, f32),
}

impl Default for JointBoundsParams {
    /// No bounds: the term's builder asks for them.
    fn default() -> Self {
        Self {
            asset: robot(),
            joint_names: all_joints(),
            bounds: (f32::NAN, f32::NAN),
        }
    }
}

/// `joint_pos_out_of_manual_limit`: a selected joint is outside `bounds` (Isaac Lab's; a
/// cart-pole's cart leaving its track).
struct JointPosOutOfManualLimit {
    sel: JointSel,
    bounds: (f32, f32),
}

impl TerminationTerm for JointPosOutOfManualLimit {
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [bool]) {
        let q = env
            .scene
            .backend
            .articulation(self.sel.articulation)
            .joint_pos;
        let (n, (lo, hi)) = (self.sel.num_dofs, self.bounds);
        for (e, o) in out.iter_mut().enumerate() {
            *o = (self.sel.dofs.iter()).any(|&j| !(lo..=hi).contains(&q[e * n + j]));
        }
    }
}

inventory::submit! { TerminationTermDef { name: "joint_pos_out_of_manual_limit", build: |c| {
    let p: JointBoundsParams = c.params()?;
    let (lo, hi) = p.bounds;
    if !(lo.is_finite() && hi.is_finite() && lo < hi) {
        return Err(c.error(format!("params.bounds must be given as (lower, upper), finite with lower < upper, got ({lo}, {hi})")));
    }
    let sel = JointSel::resolve(c, &JointsParams { asset: p.asset, joint_names: p.joint_names })?;
    Ok(Box::new(JointPosOutOfManualLimit { sel, bounds: p.bounds }))
} } }
