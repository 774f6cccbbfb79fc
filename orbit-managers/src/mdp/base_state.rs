//! Terms on an articulation's root link, its base: height, velocities and gravity in the base
//! frame, and the termination of a base that fell too low (Isaac Lab's `base_pos_z`,
//! `base_lin_vel`, `base_ang_vel`, `projected_gravity`, `root_height_below_minimum`).
use super::*;
use orbit_core::parallel::fill_rows;

/// Parameters naming an articulation.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BaseParams {
    /// Articulation name.
    #[serde(default = "robot")]
    pub asset: String,
}

impl Default for BaseParams {
    fn default() -> Self {
        Self { asset: robot() }
    }
}

/// Which base quantity a [`BaseState`] term reads.
#[derive(Clone, Copy)]
enum BaseQuantity {
    /// Height of the root link's origin above the env origin (1).
    Height,
    /// Linear velocity of the root link's origin, base axes (3).
    LinVel,
    /// Angular velocity, base axes (3).
    AngVel,
    /// The unit gravity direction `(0, 0, −1)` in base axes (3): `(0, 0, −1)` when upright.
    Gravity,
}

/// `base_pos_z` / `base_lin_vel` / `base_ang_vel` / `projected_gravity`.
struct BaseState {
    articulation: usize,
    quantity: BaseQuantity,
}

impl ObservationTerm for BaseState {
    fn dim(&self) -> usize {
        match self.quantity {
            BaseQuantity::Height => 1,
            _ => 3,
        }
    }
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        let view = env.scene.backend.articulation(self.articulation);
        let (links, quantity) = (view.num_links, self.quantity);
        fill_rows(out, self.dim(), |e, row| {
            let root = e * links;
            let to_base = view.link_quat[root].inverse();
            let v = match quantity {
                BaseQuantity::Height => {
                    row[0] = view.link_pos[root].z;
                    return;
                }
                BaseQuantity::LinVel => to_base * view.link_lin_vel[root],
                BaseQuantity::AngVel => to_base * view.link_ang_vel[root],
                BaseQuantity::Gravity => to_base * Vec3::NEG_Z,
            };
            row.copy_from_slice(&v.to_array());
        });
    }
}

fn base_state(
    ctx: &TermContext<'_>,
    quantity: BaseQuantity,
) -> Result<Box<dyn ObservationTerm>, EnvError> {
    let p: BaseParams = ctx.params()?;
    let articulation = ctx.articulation(&p.asset)?;
    Ok(Box::new(BaseState {
        articulation,
        quantity,
    }))
}

inventory::submit! { ObservationTermDef { name: "base_pos_z", build: |c| base_state(c, BaseQuantity::Height) } }
inventory::submit! { ObservationTermDef { name: "base_lin_vel", build: |c| base_state(c, BaseQuantity::LinVel) } }
inventory::submit! { ObservationTermDef { name: "base_ang_vel", build: |c| base_state(c, BaseQuantity::AngVel) } }
inventory::submit! { ObservationTermDef { name: "projected_gravity", build: |c| base_state(c, BaseQuantity::Gravity) } }

/// Parameters of `root_height_below_minimum`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MinimumHeightParams {
    /// Articulation name.
    #[serde(default = "robot")]
    pub asset: String,
    /// Height of the root link's origin (m) below which the episode ends.
    pub minimum_height: f32,
}

impl Default for MinimumHeightParams {
    /// No height: the term's builder asks for one.
    fn default() -> Self {
        Self {
            asset: robot(),
            minimum_height: f32::NAN,
        }
    }
}

/// `root_height_below_minimum`: the base fell below `minimum_height` (a torso on the ground).
struct RootHeightBelowMinimum {
    articulation: usize,
    minimum: f32,
}

impl TerminationTerm for RootHeightBelowMinimum {
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [bool]) {
        let view = env.scene.backend.articulation(self.articulation);
        for (e, o) in out.iter_mut().enumerate() {
            *o = view.link_pos[e * view.num_links].z < self.minimum;
        }
    }
}

inventory::submit! { TerminationTermDef { name: "root_height_below_minimum", build: |c| {
    let p: MinimumHeightParams = c.params()?;
    if !p.minimum_height.is_finite() {
        return Err(c.error(format!("params.minimum_height must be a finite height in metres, got {}", p.minimum_height)));
    }
    let articulation = c.articulation(&p.asset)?;
    Ok(Box::new(RootHeightBelowMinimum { articulation, minimum: p.minimum_height }))
} } }
