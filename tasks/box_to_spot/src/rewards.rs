//! The task's one new term: the distance of an object from a fixed point.

use glam::Vec3;
use orbit_managers::term::{RewardTerm, RewardTermDef, TermContext};
use orbit_managers::{EnvError, EnvView};
use serde::Deserialize;

/// Parameters of `object_point_distance`.
#[derive(Clone, Debug, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ObjectPointParams {
    /// The rigid object to measure.
    pub object: String,
    /// The spot, in the env frame (m).
    pub point: Vec3,
}

impl Default for ObjectPointParams {
    fn default() -> Self {
        Self {
            object: "box".into(),
            point: Vec3::new(0.5, 0.0, -0.01),
        }
    }
}

/// `‖p_object − point‖` per env.
struct ObjectPointDistance {
    object: usize,
    point: Vec3,
}

impl RewardTerm for ObjectPointDistance {
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        let pos = env.scene.backend.rigid_object(self.object).pos;
        for (o, p) in out.iter_mut().zip(pos) {
            *o = (*p - self.point).length();
        }
    }
}

fn build(ctx: &TermContext<'_>) -> Result<Box<dyn RewardTerm>, EnvError> {
    let p: ObjectPointParams = ctx.params()?;
    if !p.point.is_finite() {
        return Err(ctx.error(format!("params.point must be finite, got {}", p.point)));
    }
    let object = ctx
        .scene
        .rigid_object(&format!("{}.params.object", ctx.field), &p.object)?;
    Ok(Box::new(ObjectPointDistance {
        object,
        point: p.point,
    }))
}

inventory::submit! { RewardTermDef { name: "object_point_distance", build } }
