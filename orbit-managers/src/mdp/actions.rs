//! Action terms: joint position and joint effort.
use super::*;
use orbit_core::parallel::MIN_ENVS_PER_COPY_TASK;
use orbit_core::scene::PerJoint;
use rayon::prelude::*;

/// Parameters of joint actions: `processed = raw · scale + offset`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointActionParams {
    /// Articulation name.
    #[serde(default = "robot")]
    pub asset: String,
    /// Joint-name regexes.
    #[serde(default = "all_joints")]
    pub joint_names: Vec<String>,
    /// Scale: one for every joint, or by joint-name regex (Isaac Lab's `scale` dict; every
    /// selected joint must match one).
    #[serde(default = "one")]
    pub scale: PerJoint,
    /// Offset.
    #[serde(default)]
    pub offset: f32,
    /// Position actions: use the default joint positions as offset.
    #[serde(default)]
    pub use_default_offset: bool,
    /// Raw actions are clipped to this range first (Fancy Gym clips to `[-1, 1]`).
    #[serde(default)]
    pub clip: Option<(f32, f32)>,
    /// Add the backend's bias forces (gravity + Coriolis compensation) as effort: on top of the
    /// processed torque for effort actions (Fancy Gym's torque controller), as a feed-forward
    /// effort beside the targets for position actions.
    #[serde(default)]
    pub compensate_bias: bool,
    /// Effort actions: clip the final effort per joint (Fancy Gym's `q_torque_max`).
    #[serde(default)]
    pub effort_clip: Option<Vec<f32>>,
}

fn one() -> PerJoint {
    PerJoint::All(1.0)
}

impl Default for JointActionParams {
    fn default() -> Self {
        Self {
            asset: robot(),
            joint_names: all_joints(),
            scale: one(),
            offset: 0.0,
            use_default_offset: false,
            clip: None,
            compensate_bias: false,
            effort_clip: None,
        }
    }
}

/// `joint_position` and `joint_effort` actions.
struct JointAction {
    kind: JointActionKind,
    sel: JointSel,
    p: JointActionParams,
    /// Scale per action value.
    scales: Vec<f32>,
    offsets: Vec<f32>,
    /// Raw range of each action value within which it changes the target or effort.
    bounds: Vec<(f32, f32)>,
    processed: Vec<f32>,
    /// Full `num_envs × num_dofs` target/effort buffer.
    full: Vec<f32>,
    /// The backend adds the bias forces (set up on the first `apply`); otherwise an effort
    /// action adds them itself before clipping, every physics step.
    backend_compensation: bool,
    compensation_enabled: bool,
}

impl ActionTerm for JointAction {
    fn dim(&self) -> usize {
        self.sel.dofs.len()
    }

    fn process(&mut self, _scene: &Scene, raw: &[f32]) {
        let (d, p) = (self.dim().max(1), &self.p);
        let (scales, offsets) = (&self.scales, &self.offsets);
        self.processed
            .par_chunks_mut(d)
            .with_min_len(MIN_ENVS_PER_COPY_TASK)
            .zip(raw.par_chunks(d))
            .for_each(|(out, raw)| {
                for (((o, &a), &scale), &offset) in out.iter_mut().zip(raw).zip(scales).zip(offsets)
                {
                    let a = match p.clip {
                        Some((lo, hi)) => a.clamp(lo, hi),
                        None => a,
                    };
                    *o = a * scale + offset;
                }
            });
    }

    fn apply(&mut self, scene: &mut Scene) -> Result<(), EnvError> {
        if self.backend_compensation && !self.compensation_enabled {
            self.sel.enable_bias_compensation(scene)?;
            self.compensation_enabled = true;
        }
        let (n, d) = (self.sel.num_dofs, self.dim());
        let view = scene.backend.articulation(self.sel.articulation);
        let own_bias = self.p.compensate_bias && !self.backend_compensation;
        let host_effort = self.kind == JointActionKind::Effort && !self.backend_compensation;
        let (dofs, effort_clip) = (&self.sel.dofs, &self.p.effort_clip);
        // (`max(1)`: an articulation without dofs, or a term without joints, has empty rows.)
        self.full
            .par_chunks_mut(n.max(1))
            .with_min_len(MIN_ENVS_PER_COPY_TASK)
            .zip(self.processed.par_chunks(d.max(1)))
            .zip(view.bias_forces.par_chunks(n.max(1)))
            .for_each(|((full, processed), bias)| {
                for (k, &j) in dofs.iter().enumerate() {
                    let mut v = processed[k];
                    if host_effort {
                        if own_bias {
                            v += bias[j];
                        }
                        if let Some(lim) = effort_clip {
                            v = v.clamp(-lim[k], lim[k]);
                        }
                    }
                    full[j] = v;
                }
            });
        let a = self.sel.articulation;
        match self.kind {
            JointActionKind::Position => scene.backend.set_joint_position_targets(a, &self.full)?,
            JointActionKind::Effort => scene.backend.set_joint_efforts(a, &self.full)?,
        }
        Ok(())
    }

    fn substep_invariant(&self) -> bool {
        // Only an effort action adding the bias forces itself reads state between steps.
        !self.p.compensate_bias || self.backend_compensation
    }

    fn processed(&self) -> &[f32] {
        &self.processed
    }

    fn bounds(&self) -> Vec<(f32, f32)> {
        self.bounds.clone()
    }

    fn joint_map(&self) -> Option<JointActionMap<'_>> {
        Some(JointActionMap {
            kind: self.kind,
            articulation: self.sel.articulation,
            dofs: &self.sel.dofs,
            scales: &self.scales,
            offsets: &self.offsets,
            clip: self.p.clip,
        })
    }
}

fn joint_action(
    ctx: &TermContext<'_>,
    kind: JointActionKind,
) -> Result<Box<dyn ActionTerm>, EnvError> {
    let p: JointActionParams = ctx.params()?;
    let sel = JointSel::resolve(
        ctx,
        &JointsParams {
            asset: p.asset.clone(),
            joint_names: p.joint_names.clone(),
        },
    )?;
    let d = sel.dofs.len();
    if let Some(lim) = &p.effort_clip
        && lim.len() != d
    {
        return Err(ctx.error(format!(
            "effort_clip has {} values for {d} joints",
            lim.len()
        )));
    }
    let scales = action_scales(ctx, &sel, &p.scale)?;
    let defaults = &ctx.scene.desc.articulations[sel.articulation].default_joint_pos;
    let offsets: Vec<f32> = sel
        .dofs
        .iter()
        .map(|&j| {
            if p.use_default_offset {
                defaults[j]
            } else {
                p.offset
            }
        })
        .collect();
    let n = ctx.scene.num_envs();
    // Joints outside the selection keep their default targets (position) or zero effort.
    let full = match kind {
        JointActionKind::Position => defaults.repeat(n),
        JointActionKind::Effort => vec![0.0; n * sel.num_dofs],
    };
    // The backend's compensation adds the bias before the drive's effort limit. An effort
    // clip at or above that limit changes nothing on top, so the backend can do it; a tighter
    // clip must see the bias, so this term adds it every physics step.
    let drives = &ctx.scene.desc.articulations[sel.articulation].drives;
    let backend_compensation = p.compensate_bias
        && (kind == JointActionKind::Position
            || p.effort_clip.as_ref().is_none_or(|lim| {
                sel.dofs
                    .iter()
                    .zip(lim)
                    .all(|(&j, &l)| l >= drives[j].effort_limit)
            }));
    let bounds = (0..d)
        .map(|k| {
            let clip = p.clip.unwrap_or((f32::NEG_INFINITY, f32::INFINITY));
            // An effort saturates at the term's clip, and at the drive's limit where nothing
            // else adds to it: the state's bias forces, or the drive's own PD efforts.
            let drive = &drives[sel.dofs[k]];
            let limit = match (kind, p.compensate_bias) {
                (JointActionKind::Effort, false) => {
                    let clip_k = p.effort_clip.as_ref().map_or(f32::INFINITY, |l| l[k]);
                    let passive = drive.stiffness == 0.0 && drive.damping == 0.0;
                    clip_k.min(if passive {
                        drive.effort_limit
                    } else {
                        f32::INFINITY
                    })
                }
                _ => f32::INFINITY,
            };
            raw_bounds(clip, limit, scales[k], offsets[k])
        })
        .collect();
    Ok(Box::new(JointAction {
        kind,
        bounds,
        backend_compensation,
        compensation_enabled: false,
        full,
        processed: vec![0.0; n * d],
        sel,
        p,
        scales,
        offsets,
    }))
}

/// The raw range within which `clip(raw) · scale + offset`, clamped to `±limit`, changes:
/// the clip range, narrowed to where the effort stays within its limit.
fn raw_bounds(clip: (f32, f32), limit: f32, scale: f32, offset: f32) -> (f32, f32) {
    if !limit.is_finite() || scale == 0.0 {
        return clip;
    }
    let (a, b) = ((-limit - offset) / scale, (limit - offset) / scale);
    let (lo, hi) = (a.min(b), a.max(b));
    let (lo, hi) = (clip.0.max(lo), clip.1.min(hi));
    // A clip outside the unsaturated range (every action saturates): the clip's own range.
    if lo <= hi { (lo, hi) } else { clip }
}

#[cfg(test)]
mod bounds_tests {
    use super::raw_bounds;

    const FREE: (f32, f32) = (f32::NEG_INFINITY, f32::INFINITY);

    /// An effort of `raw · 100` limited to ±400 N changes only for raw in ±4; an offset shifts
    /// the range, a negative scale flips it, a clip narrows it, no limit leaves the clip.
    #[test]
    fn raw_bounds_are_where_the_effort_is_below_its_limit() {
        assert_eq!(raw_bounds(FREE, 400.0, 100.0, 0.0), (-4.0, 4.0));
        assert_eq!(raw_bounds(FREE, 400.0, 100.0, 100.0), (-5.0, 3.0));
        assert_eq!(raw_bounds(FREE, 400.0, -100.0, 0.0), (-4.0, 4.0));
        assert_eq!(raw_bounds((-1.0, 1.0), 400.0, 100.0, 0.0), (-1.0, 1.0));
        assert_eq!(
            raw_bounds((-1.0, 1.0), f32::INFINITY, 100.0, 0.0),
            (-1.0, 1.0)
        );
        assert_eq!(raw_bounds(FREE, f32::INFINITY, 2.0, 0.0), FREE);
    }
}

/// The scale of each selected joint.
fn action_scales(
    ctx: &TermContext<'_>,
    sel: &JointSel,
    scale: &PerJoint,
) -> Result<Vec<f32>, EnvError> {
    let by_name = match scale {
        PerJoint::All(v) => return Ok(vec![*v; sel.dofs.len()]),
        PerJoint::ByName(m) => m,
    };
    let per_dof = values_by_joint(ctx, "scale", sel.articulation, by_name)?;
    let names = &ctx.scene.desc.articulations[sel.articulation]
        .model
        .joint_names();
    sel.dofs
        .iter()
        .map(|&j| {
            per_dof[j].ok_or_else(|| {
                ctx.error(format!(
                    "params.scale has no entry matching joint `{}`; add one",
                    names[j]
                ))
            })
        })
        .collect()
}

inventory::submit! { ActionTermDef { name: "joint_position", build: |c| joint_action(c, JointActionKind::Position) } }
inventory::submit! { ActionTermDef { name: "joint_effort", build: |c| joint_action(c, JointActionKind::Effort) } }
