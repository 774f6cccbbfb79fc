//! Resolving an articulation config: its model loaded and checked, its joints' starting state
//! and drives matched by name, its base fixed or floating.

use glam::Vec3;

use super::cfg::{ActuatorCfg, ArticulationCfg, PerJoint};
use super::desc::{ArticulationDesc, JointDrive, ModelLoader, SceneError, match_joints};
use super::model::{ArticulationModel, Joint};
use crate::math::Pose;

/// Writes values given per regex into `out` (joint order); a joint matched twice is an error.
fn apply_by_name(
    field: &str,
    entity: &str,
    joints: &[String],
    values: &std::collections::BTreeMap<String, f32>,
    out: &mut [f32],
) -> Result<Vec<bool>, SceneError> {
    let mut seen = vec![false; joints.len()];
    for (pattern, &value) in values {
        for i in match_joints(
            &format!("{field}[\"{pattern}\"]"),
            entity,
            joints,
            std::slice::from_ref(pattern),
        )? {
            if std::mem::replace(&mut seen[i], true) {
                return Err(SceneError::Ambiguous {
                    field: field.to_string(),
                    joint: joints[i].clone(),
                    entity: entity.to_string(),
                });
            }
            out[i] = value;
        }
    }
    Ok(seen)
}

/// Applies a [`PerJoint`] value to the selected joints.
fn apply_per_joint(
    field: &str,
    entity: &str,
    joints: &[String],
    selected: &[usize],
    value: &PerJoint,
    set: &mut dyn FnMut(usize, f32),
) -> Result<(), SceneError> {
    match value {
        PerJoint::All(v) => selected.iter().for_each(|&i| set(i, *v)),
        PerJoint::ByName(map) => {
            let mut tmp = vec![f32::NAN; joints.len()];
            apply_by_name(field, entity, joints, map, &mut tmp)?;
            for &i in selected {
                if !tmp[i].is_nan() {
                    set(i, tmp[i]);
                }
            }
        }
    }
    Ok(())
}

pub(super) fn resolve_articulation(
    field: &str,
    cfg: &ArticulationCfg,
    load: &ModelLoader<'_>,
) -> Result<ArticulationDesc, SceneError> {
    let moving = cfg.init_state.lin_vel != Vec3::ZERO || cfg.init_state.ang_vel != Vec3::ZERO;
    if cfg.fixed_base && moving {
        return Err(SceneError::Invalid {
            field: format!("{field}.init_state"),
            message: "a fixed base cannot move: remove `lin_vel` and `ang_vel`, or set \
                      `fixed_base: false`"
                .into(),
        });
    }
    if !(cfg.init_state.lin_vel.is_finite() && cfg.init_state.ang_vel.is_finite()) {
        return Err(SceneError::Invalid {
            field: format!("{field}.init_state"),
            message: "root velocities must be finite".into(),
        });
    }
    let raw = load(&cfg.spawn).map_err(|message| SceneError::Asset {
        field: format!("{field}.spawn"),
        message,
    })?;
    raw.validate().map_err(|e| SceneError::Asset {
        field: format!("{field}.spawn"),
        message: e.to_string(),
    })?;
    let model = raw.merge_fixed_joints();
    if !cfg.fixed_base && model.links[0].inertial.mass <= 0.0 {
        return Err(SceneError::Invalid {
            field: format!("{field}.fixed_base"),
            message: format!(
                "the root link `{}` of `{}` has no mass, so it cannot float; give it a mass \
                 or set `fixed_base: true`",
                model.links[0].name, cfg.name
            ),
        });
    }
    // A joint moving nothing with mass (nor armature) would have no inertia to resist it.
    let mut subtree_mass: Vec<f32> = model.links.iter().map(|l| l.inertial.mass).collect();
    for (i, link) in model.links.iter().enumerate().rev() {
        if let Some(p) = link.parent {
            subtree_mass[p] += subtree_mass[i];
        }
    }
    for (i, link) in model.links.iter().enumerate().skip(1) {
        if let Some(j) = &link.joint
            && subtree_mass[i] <= 0.0
            && j.armature <= 0.0
        {
            return Err(SceneError::Invalid {
                field: format!("{field}.spawn"),
                message: format!(
                    "joint `{}` of `{}` moves no mass: give link `{}` or a link below it a \
                     mass, or the joint an armature",
                    j.name, cfg.name, link.name
                ),
            });
        }
    }
    let joints = model.joint_names();
    let n = joints.len();
    let entity = cfg.name.as_str();

    let mut default_joint_pos = vec![0.0; n];
    let mut default_joint_vel = vec![0.0; n];
    let given_pos = apply_by_name(
        &format!("{field}.init_state.joint_pos"),
        entity,
        &joints,
        &cfg.init_state.joint_pos,
        &mut default_joint_pos,
    )?;
    apply_by_name(
        &format!("{field}.init_state.joint_vel"),
        entity,
        &joints,
        &cfg.init_state.joint_vel,
        &mut default_joint_vel,
    )?;

    let dof_links = model.dof_links();
    let asset_joint = |i: usize| {
        model.links[dof_links[i]]
            .joint
            .as_ref()
            .expect("dof link has a joint")
    };
    // A start outside the joint's range is not a state the simulation can be in.
    for (i, &q) in default_joint_pos.iter().enumerate() {
        let range = asset_joint(i)
            .limits
            .unwrap_or([f32::NEG_INFINITY, f32::INFINITY]);
        if given_pos[i] && !(q.is_finite() && q >= range[0] - 1e-6 && q <= range[1] + 1e-6) {
            return Err(SceneError::Invalid {
                field: format!("{field}.init_state.joint_pos"),
                message: format!(
                    "joint `{}` of `{entity}` starts at {q}, outside its limits [{}, {}]; \
                     choose a position inside them",
                    joints[i], range[0], range[1]
                ),
            });
        }
    }
    let mut drives: Vec<JointDrive> = (0..n)
        .map(|i| JointDrive {
            // As Isaac Lab 1.0 does for implicit actuators: the asset's effort limit is enforced
            // unless the actuator overrides it; its velocity limit is not (only an explicit
            // `velocity_limit` in the actuator group is).
            effort_limit: asset_joint(i).effort_limit.unwrap_or(f32::INFINITY),
            ..JointDrive::default()
        })
        .collect();
    let mut model = model;
    let mut covered = vec![false; n];
    for (group, act) in &cfg.actuators {
        let f = format!("{field}.actuators.{group}");
        let selected = match_joints(
            &format!("{f}.joint_names_expr"),
            entity,
            &joints,
            &act.joint_names_expr,
        )?;
        selected.iter().for_each(|&i| covered[i] = true);
        resolve_actuator(
            &f,
            entity,
            &joints,
            &selected,
            act,
            &mut drives,
            &mut model,
            &dof_links,
        )?;
    }
    for (i, c) in covered.iter().enumerate() {
        if !c {
            tracing::warn!(
                "{field}: joint `{}` of `{entity}` is in no actuator group; it is unactuated",
                joints[i]
            );
        }
    }
    Ok(ArticulationDesc {
        name: cfg.name.clone(),
        model,
        root_pose: Pose::new(cfg.init_state.pos, cfg.init_state.rot),
        fixed_base: cfg.fixed_base,
        root_lin_vel: cfg.init_state.lin_vel,
        root_ang_vel: cfg.init_state.ang_vel,
        default_joint_pos,
        default_joint_vel,
        drives,
        self_collisions: cfg.self_collisions,
    })
}

/// Rejects negative or NaN gains and limits.
fn check_non_negative(field: &str, value: &PerJoint) -> Result<(), SceneError> {
    let bad = match value {
        PerJoint::All(v) => (v.is_nan() || *v < 0.0).then_some(*v),
        PerJoint::ByName(m) => m.values().copied().find(|v| v.is_nan() || *v < 0.0),
    };
    match bad {
        Some(v) => Err(SceneError::Invalid {
            field: field.to_string(),
            message: format!("expected values >= 0, got {v}"),
        }),
        None => Ok(()),
    }
}

#[allow(clippy::too_many_arguments)]
fn resolve_actuator(
    f: &str,
    entity: &str,
    joints: &[String],
    selected: &[usize],
    act: &ActuatorCfg,
    drives: &mut [JointDrive],
    model: &mut ArticulationModel,
    dof_links: &[usize],
) -> Result<(), SceneError> {
    let apply = |name: &str, value: &PerJoint, set: &mut dyn FnMut(usize, f32)| {
        let field = format!("{f}.{name}");
        check_non_negative(&field, value)?;
        apply_per_joint(&field, entity, joints, selected, value, set)
    };
    apply("stiffness", &act.stiffness, &mut |i, v| {
        drives[i].stiffness = v
    })?;
    apply("damping", &act.damping, &mut |i, v| drives[i].damping = v)?;
    if let Some(value) = &act.effort_limit {
        apply("effort_limit", value, &mut |i, v| {
            drives[i].effort_limit = v
        })?;
    }
    if let Some(value) = &act.velocity_limit {
        apply("velocity_limit", value, &mut |i, v| {
            drives[i].velocity_limit = v
        })?;
    }
    let mut joint_param =
        |name: &str, value: &Option<PerJoint>, set: fn(&mut Joint, f32)| match value {
            Some(value) => apply(name, value, &mut |i, v| {
                if let Some(j) = model.links[dof_links[i]].joint.as_mut() {
                    set(j, v);
                }
            }),
            None => Ok(()),
        };
    joint_param("armature", &act.armature, |j, v| j.armature = v)?;
    joint_param("friction", &act.friction, |j, v| j.friction = v)?;
    Ok(())
}
