//! Event terms: resets of joint and root state, randomisation of materials and masses.
use super::*;

/// `reset_scene_to_default`: default joint state of every articulation, default root state of
/// every floating base and rigid object.
struct ResetSceneToDefault;

impl EventTerm for ResetSceneToDefault {
    fn apply(
        &mut self,
        scene: &mut Scene,
        env_ids: &[usize],
        _rng: &mut EnvRngs,
    ) -> Result<(), EnvError> {
        for a in 0..scene.desc.articulations.len() {
            let desc = &scene.desc.articulations[a];
            if !desc.fixed_base {
                let states = vec![desc.default_root_state(); env_ids.len()];
                scene
                    .backend
                    .write_articulation_root_state(a, env_ids, &states)?;
            }
            let pos = desc.default_joint_pos.repeat(env_ids.len());
            let vel = desc.default_joint_vel.repeat(env_ids.len());
            scene.backend.write_joint_state(a, env_ids, &pos, &vel)?;
        }
        for o in 0..scene.desc.rigid_objects.len() {
            let states = vec![scene.desc.rigid_objects[o].default_root_state; env_ids.len()];
            scene.backend.write_root_state(o, env_ids, &states)?;
        }
        Ok(())
    }
}

inventory::submit! { EventTermDef { name: "reset_scene_to_default", build: |_| Ok(Box::new(ResetSceneToDefault)) } }

/// Parameters of `reset_root_state_uniform`: offsets added to the default root state.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResetRootParams {
    /// Rigid-object or floating-base articulation name.
    pub asset: String,
    /// Position offset ranges `(x, y, z)` as `((lo, hi), (lo, hi), (lo, hi))`.
    #[serde(default)]
    pub pos_range: [(f32, f32); 3],
    /// Yaw offset range (rad).
    #[serde(default)]
    pub yaw_range: (f32, f32),
    /// Linear velocity offset ranges `(x, y, z)` added to the default velocity (m/s).
    #[serde(default)]
    pub lin_vel_range: [(f32, f32); 3],
}

/// `reset_root_state_uniform`: default root state plus uniform position, yaw and linear
/// velocity offsets, for a rigid object or a floating base.
struct ResetRootUniform {
    target: RootOf,
    p: ResetRootParams,
}

/// Whose root state a term writes.
#[derive(Clone, Copy)]
enum RootOf {
    Object(usize),
    Articulation(usize),
}

impl EventTerm for ResetRootUniform {
    fn apply(
        &mut self,
        scene: &mut Scene,
        env_ids: &[usize],
        rng: &mut EnvRngs,
    ) -> Result<(), EnvError> {
        let default = match self.target {
            RootOf::Object(o) => scene.desc.rigid_objects[o].default_root_state,
            RootOf::Articulation(a) => scene.desc.articulations[a].default_root_state(),
        };
        let states: Vec<_> = env_ids
            .iter()
            .map(|&e| {
                let r = rng.get(e);
                let mut s = default;
                let off = Vec3::new(
                    r.uniform_range(self.p.pos_range[0].0, self.p.pos_range[0].1),
                    r.uniform_range(self.p.pos_range[1].0, self.p.pos_range[1].1),
                    r.uniform_range(self.p.pos_range[2].0, self.p.pos_range[2].1),
                );
                let yaw = r.uniform_range(self.p.yaw_range.0, self.p.yaw_range.1);
                let [vx, vy, vz] = self.p.lin_vel_range;
                s.lin_vel += Vec3::new(
                    r.uniform_range(vx.0, vx.1),
                    r.uniform_range(vy.0, vy.1),
                    r.uniform_range(vz.0, vz.1),
                );
                s.pose.pos += off;
                s.pose.rot = (Quat::from_rotation_z(yaw) * s.pose.rot).normalize();
                s
            })
            .collect();
        match self.target {
            RootOf::Object(o) => scene.backend.write_root_state(o, env_ids, &states)?,
            RootOf::Articulation(a) => scene
                .backend
                .write_articulation_root_state(a, env_ids, &states)?,
        }
        Ok(())
    }
}

inventory::submit! { EventTermDef { name: "reset_root_state_uniform", build: |c| {
    let p: ResetRootParams = c.params()?;
    let field = format!("{}.params.asset", c.field);
    let layout = c.scene.backend.layout();
    let target = match layout.articulation(&p.asset) {
        Ok(a) if layout.articulations[a].fixed_base => {
            return Err(EnvError::InvalidTerm {
                field,
                message: format!(
                    "articulation `{}` has a fixed base, whose root does not move; name a rigid \
                     object or a floating base (`fixed_base: false`)",
                    p.asset
                ),
            });
        }
        Ok(a) => RootOf::Articulation(a),
        Err(_) => RootOf::Object(c.scene.rigid_object(&field, &p.asset)?),
    };
    Ok(Box::new(ResetRootUniform { target, p }))
} } }
/// Parameters of `reset_joints_by_offset` / `reset_joints_by_scale`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResetJointsParams {
    /// Articulation name.
    #[serde(default = "robot")]
    pub asset: String,
    /// Joint-name regexes.
    #[serde(default = "all_joints")]
    pub joint_names: Vec<String>,
    /// Range added to (offset) or multiplied with (scale) the default positions.
    pub position_range: (f32, f32),
    /// Range added to or multiplied with the default velocities.
    #[serde(default)]
    pub velocity_range: (f32, f32),
}

impl Default for ResetJointsParams {
    fn default() -> Self {
        Self {
            asset: robot(),
            joint_names: all_joints(),
            position_range: (0.0, 0.0),
            velocity_range: (0.0, 0.0),
        }
    }
}

/// `reset_joints_by_offset` / `_by_scale`: the selected joints' default state plus (or times)
/// uniform noise, positions clamped to the joint limits; unselected joints keep their state
/// (as in Isaac Lab, which writes the selected joints only), so two such events can reset two
/// joints with ranges of their own.
struct ResetJoints {
    sel: JointSel,
    p: ResetJointsParams,
    scale: bool,
    limits: Vec<[f32; 2]>,
}

impl EventTerm for ResetJoints {
    fn apply(
        &mut self,
        scene: &mut Scene,
        env_ids: &[usize],
        rng: &mut EnvRngs,
    ) -> Result<(), EnvError> {
        let desc = &scene.desc.articulations[self.sel.articulation];
        let n = self.sel.num_dofs;
        let state = scene.backend.articulation(self.sel.articulation);
        let rows = |x: &[f32]| -> Vec<f32> {
            (env_ids.iter())
                .flat_map(|&e| x[e * n..(e + 1) * n].iter().copied())
                .collect()
        };
        let (mut pos, mut vel) = (rows(state.joint_pos), rows(state.joint_vel));
        for (i, &e) in env_ids.iter().enumerate() {
            let r = rng.get(e);
            for &j in &self.sel.dofs {
                pos[i * n + j] = desc.default_joint_pos[j];
                vel[i * n + j] = desc.default_joint_vel[j];
                let (dp, dv) = (
                    r.uniform_range(self.p.position_range.0, self.p.position_range.1),
                    r.uniform_range(self.p.velocity_range.0, self.p.velocity_range.1),
                );
                let (q, v) = (&mut pos[i * n + j], &mut vel[i * n + j]);
                if self.scale {
                    *q *= dp;
                    *v *= dv;
                } else {
                    *q += dp;
                    *v += dv;
                }
                *q = q.clamp(self.limits[j][0], self.limits[j][1]);
            }
        }
        scene
            .backend
            .write_joint_state(self.sel.articulation, env_ids, &pos, &vel)?;
        Ok(())
    }
}

fn reset_joints(ctx: &TermContext<'_>, scale: bool) -> Result<Box<dyn EventTerm>, EnvError> {
    let p: ResetJointsParams = ctx.params()?;
    for (name, (lo, hi)) in [
        ("position_range", p.position_range),
        ("velocity_range", p.velocity_range),
    ] {
        if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
            return Err(ctx.error(format!(
                "params.{name} must be a finite (lo, hi) with lo <= hi, got ({lo}, {hi})"
            )));
        }
    }
    let sel = JointSel::resolve(
        ctx,
        &JointsParams {
            asset: p.asset.clone(),
            joint_names: p.joint_names.clone(),
        },
    )?;
    let model = &ctx.scene.desc.articulations[sel.articulation].model;
    let limits = model
        .dof_links()
        .into_iter()
        .map(|l| {
            model.links[l]
                .joint
                .as_ref()
                .and_then(|j| j.limits)
                .unwrap_or([f32::MIN, f32::MAX])
        })
        .collect();
    Ok(Box::new(ResetJoints {
        sel,
        p,
        scale,
        limits,
    }))
}

inventory::submit! { EventTermDef { name: "reset_joints_by_offset", build: |c| reset_joints(c, false) } }
inventory::submit! { EventTermDef { name: "reset_joints_by_scale", build: |c| reset_joints(c, true) } }
/// Parameters of `randomize_rigid_body_material`.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialParams {
    /// Rigid-object name.
    pub asset: String,
    /// Friction coefficients are drawn uniformly from this range per env.
    pub friction_range: (f32, f32),
}

/// `randomize_rigid_body_material`: a uniform friction coefficient per env for every shape of a
/// rigid object (shape priorities are kept, so a prioritised shape's new friction still wins).
struct RandomizeMaterial {
    object: usize,
    range: (f32, f32),
}

impl EventTerm for RandomizeMaterial {
    fn apply(
        &mut self,
        scene: &mut Scene,
        env_ids: &[usize],
        rng: &mut EnvRngs,
    ) -> Result<(), EnvError> {
        let values: Vec<f32> = env_ids
            .iter()
            .map(|&e| rng.get(e).uniform_range(self.range.0, self.range.1))
            .collect();
        scene.backend.set_friction(
            orbit_core::physics::BodyRef::RigidObject(self.object),
            env_ids,
            &values,
        )?;
        Ok(())
    }
}

inventory::submit! { EventTermDef { name: "randomize_rigid_body_material", build: |c| {
    let p: MaterialParams = c.params()?;
    let (lo, hi) = p.friction_range;
    if !(lo.is_finite() && hi.is_finite() && 0.0 <= lo && lo <= hi) {
        return Err(c.error(format!("params.friction_range must satisfy 0 <= lo <= hi, got ({lo}, {hi})")));
    }
    let object = c.scene.rigid_object(&format!("{}.params.asset", c.field), &p.asset)?;
    Ok(Box::new(RandomizeMaterial { object, range: p.friction_range }))
} } }

/// How `randomize_rigid_body_mass` combines a drawn value with the default mass.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
pub enum MassOperation {
    /// `default + value`.
    Add,
    /// `default · value`.
    #[default]
    Scale,
    /// `value`.
    Abs,
}

/// How `randomize_rigid_body_mass` draws its value from `mass_distribution_params`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
pub enum Distribution {
    /// Uniform in `[lo, hi]`.
    #[default]
    Uniform,
    /// Log-uniform in `[lo, hi]` (both > 0).
    LogUniform,
}

/// Parameters of `randomize_rigid_body_mass`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MassParams {
    /// An articulation or rigid-object name.
    pub asset: String,
    /// Link-name regexes (full match) when `asset` is an articulation; ignored for a rigid
    /// object.
    #[serde(default = "all_joints")]
    pub body_names: Vec<String>,
    /// The range values are drawn from.
    pub mass_distribution_params: (f32, f32),
    /// How a value changes the default mass.
    #[serde(default)]
    pub operation: MassOperation,
    /// How values are drawn.
    #[serde(default)]
    pub distribution: Distribution,
}

impl Default for MassParams {
    fn default() -> Self {
        Self {
            asset: String::new(),
            body_names: all_joints(),
            mass_distribution_params: (1.0, 1.0),
            operation: MassOperation::Scale,
            distribution: Distribution::Uniform,
        }
    }
}

/// `randomize_rigid_body_mass` (Isaac Lab's term): per env and body, a new mass from the
/// body's default mass and a drawn value; the inertia tensor scales with the mass (the centre
/// of mass is kept). Each application starts from the default, so repeated resets do not drift.
struct RandomizeMass {
    /// The bodies and their default masses.
    bodies: Vec<(orbit_core::physics::BodyRef, f32)>,
    p: MassParams,
    masses: Vec<f32>,
}

impl RandomizeMass {
    fn draw(&self, r: &mut orbit_core::rng::EnvRng) -> f32 {
        let (lo, hi) = self.p.mass_distribution_params;
        match self.p.distribution {
            Distribution::Uniform => r.uniform_range(lo, hi),
            Distribution::LogUniform => r.uniform_range(lo.ln(), hi.ln()).exp(),
        }
    }

    fn mass(&self, default: f32, value: f32) -> f32 {
        match self.p.operation {
            MassOperation::Add => default + value,
            MassOperation::Scale => default * value,
            MassOperation::Abs => value,
        }
    }
}

impl EventTerm for RandomizeMass {
    fn apply(
        &mut self,
        scene: &mut Scene,
        env_ids: &[usize],
        rng: &mut EnvRngs,
    ) -> Result<(), EnvError> {
        // Draws env by env, body by body, so each env's stream alone decides its masses.
        let mut masses = std::mem::take(&mut self.masses);
        masses.clear();
        masses.resize(env_ids.len() * self.bodies.len(), 0.0);
        for (k, &e) in env_ids.iter().enumerate() {
            for (b, &(_, default)) in self.bodies.iter().enumerate() {
                let value = self.draw(rng.get(e));
                masses[b * env_ids.len() + k] = self.mass(default, value);
            }
        }
        let n = env_ids.len();
        let result = self
            .bodies
            .iter()
            .enumerate()
            .try_for_each(|(b, &(body, _))| {
                scene
                    .backend
                    .set_masses(body, env_ids, &masses[b * n..(b + 1) * n])
            });
        self.masses = masses;
        Ok(result?)
    }
}

inventory::submit! { EventTermDef { name: "randomize_rigid_body_mass", build: |c| {
    use orbit_core::physics::BodyRef;
    let p: MassParams = c.params()?;
    let (lo, hi) = p.mass_distribution_params;
    if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
        return Err(c.error(format!("params.mass_distribution_params must satisfy lo <= hi, got ({lo}, {hi})")));
    }
    if p.distribution == Distribution::LogUniform && lo <= 0.0 {
        return Err(c.error(format!("params.mass_distribution_params must be > 0 for LogUniform, got ({lo}, {hi})")));
    }
    let layout = c.scene.backend.layout();
    let bodies: Vec<(BodyRef, f32)> = if let Ok(object) = layout.rigid_object(&p.asset) {
        vec![(BodyRef::RigidObject(object), c.scene.desc.rigid_objects[object].body.inertial.mass)]
    } else {
        let field = format!("{}.params.asset", c.field);
        let articulation = c.scene.articulation(&field, &p.asset).map_err(|_| c.error(format!(
            "params.asset: `{}` is neither a rigid object ({:?}) nor an articulation ({:?})",
            p.asset, layout.rigid_objects, layout.articulations.iter().map(|a| &a.name).collect::<Vec<_>>()
        )))?;
        let links = c.scene.bodies(&format!("{}.params.body_names", c.field), articulation, &p.body_names)?;
        let model = &c.scene.desc.articulations[articulation].model;
        links.into_iter().map(|link| (BodyRef::Link { articulation, link }, model.links[link].inertial.mass)).collect()
    };
    // Every mass the range can produce must be positive (checked at the range's ends, where
    // each operation is monotonic).
    let term = RandomizeMass { bodies, p, masses: Vec::new() };
    for &(body, default) in &term.bodies {
        let smallest = term.mass(default, lo).min(term.mass(default, hi));
        if smallest <= 0.0 {
            return Err(c.error(format!(
                "params.mass_distribution_params ({lo}, {hi}) with {:?} can give body {body:?} (default mass {default} kg) a mass of {smallest} kg; masses must stay > 0",
                term.p.operation
            )));
        }
    }
    Ok(Box::new(term))
} } }
