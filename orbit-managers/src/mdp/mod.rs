//! Built-in terms (Isaac Lab's generic `mdp` functions), registered by name: one module per
//! kind of term, and the entity selections they share.

mod actions;
mod base_state;
mod commands;
mod curriculum;
mod events;
mod locomotion;
mod observations;
mod rewards;
mod terminations;

pub use actions::*;
pub use base_state::*;
pub use commands::*;
pub use curriculum::*;
pub use events::*;
pub use locomotion::*;
pub use observations::*;

use glam::{Quat, Vec3};
use serde::Deserialize;

use crate::base_env::{EnvRngs, EnvView};
use crate::error::EnvError;
use crate::scene::Scene;
use crate::term::*;

fn robot() -> String {
    "robot".into()
}
fn all_joints() -> Vec<String> {
    vec![".*".into()]
}

/// An articulation and a joint selection (Isaac Lab `SceneEntityCfg`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointsParams {
    /// Articulation name.
    #[serde(default = "robot")]
    pub asset: String,
    /// Joint-name regexes (full match).
    #[serde(default = "all_joints")]
    pub joint_names: Vec<String>,
}

impl Default for JointsParams {
    fn default() -> Self {
        Self {
            asset: robot(),
            joint_names: all_joints(),
        }
    }
}

/// Resolved articulation + dof indices.
pub struct JointSel {
    /// Articulation index.
    pub articulation: usize,
    /// Selected dofs.
    pub dofs: Vec<usize>,
    /// Dofs of the articulation.
    pub num_dofs: usize,
}

impl JointSel {
    /// Per env, `Σ_k f(k, x[selected dof k])` over a `num_envs × num_dofs` array `x` (joint
    /// positions or velocities): the shape of every joint-penalty term.
    pub fn sum_per_env(
        &self,
        x: &[f32],
        out: &mut [f32],
        f: impl Fn(usize, f32) -> f32 + Sync + Send,
    ) {
        let (n, dofs) = (self.num_dofs, &self.dofs);
        orbit_core::parallel::fill_rows(out, 1, |e, o| {
            o[0] = dofs
                .iter()
                .enumerate()
                .map(|(k, &j)| f(k, x[e * n + j]))
                .sum();
        });
    }

    /// Resolves a joint selection for a term.
    pub fn resolve(ctx: &TermContext<'_>, p: &JointsParams) -> Result<Self, EnvError> {
        let articulation = ctx.articulation(&p.asset)?;
        let dofs = ctx.scene.joints(
            &format!("{}.params.joint_names", ctx.field),
            articulation,
            &p.joint_names,
        )?;
        let num_dofs = ctx.scene.backend.layout().articulations[articulation].num_dofs();
        Ok(Self {
            articulation,
            dofs,
            num_dofs,
        })
    }
}

impl JointSel {
    /// Makes the backend add its bias forces to the selected joints' effort input at every
    /// physics step (gravity and Coriolis compensation beside targets or efforts).
    pub fn enable_bias_compensation(&self, scene: &mut Scene) -> Result<(), EnvError> {
        scene
            .backend
            .set_bias_compensation(self.articulation, &self.dofs, true)?;
        Ok(())
    }
}

/// Each dof of `articulation` with the value of the last regex of `values` (the term's
/// `params.<param>`) that matches its joint, `None` where none does.
pub fn values_by_joint(
    ctx: &TermContext<'_>,
    param: &str,
    articulation: usize,
    values: &std::collections::BTreeMap<String, f32>,
) -> Result<Vec<Option<f32>>, EnvError> {
    let field = format!("{}.params.{param}", ctx.field);
    let n = ctx.scene.desc.articulations[articulation].num_dofs();
    let mut per_dof = vec![None; n];
    for (pattern, &v) in values {
        for j in (ctx.scene).joints(&field, articulation, std::slice::from_ref(pattern))? {
            per_dof[j] = Some(v);
        }
    }
    Ok(per_dof)
}

/// Position limits `(lower, upper)` of the listed dofs (`±inf` for an unlimited joint).
pub fn joint_limits(
    model: &orbit_core::scene::ArticulationModel,
    dofs: &[usize],
) -> Vec<(f32, f32)> {
    let dof_links = model.dof_links();
    dofs.iter()
        .map(|&j| {
            match model.links[dof_links[j]]
                .joint
                .as_ref()
                .and_then(|j| j.limits)
            {
                Some([lo, hi]) => (lo, hi),
                None => (f32::NEG_INFINITY, f32::INFINITY),
            }
        })
        .collect()
}

/// Parameters naming a rigid object.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectParams {
    /// Rigid-object name.
    pub asset: String,
}

impl Default for ObjectParams {
    fn default() -> Self {
        Self {
            asset: "object".into(),
        }
    }
}
