//! The kernel's constants: the scene's sizes, the step's and the contact model's numbers, the
//! inverse weights of the bodies and dofs, and the layout table's indices.

use orbit_core::physics::{ContactModel, SimCfg};

use super::{Gen, f, v3};
use crate::compile::{CONTACT_MARGIN, MAX_CONTACTS, SOLVER_RELAXATION, default_solver_iterations};
use crate::layout;
use crate::weights::InverseWeights;

impl Gen<'_> {
    /// The kernel's constants (`const` declarations and the inverse-weight tables).
    pub(super) fn constants(&mut self, sim: &SimCfg, workgroup: usize) {
        let s = self.scene;
        let (nl, nd, no, ns) = (s.links.len(), s.dofs.len(), s.objects.len(), s.shapes.len());
        let c = |g: &mut Self, name: &str, v: String| g.line(format!("const {name} = {v};"));
        c(self, "NL", format!("{nl}u"));
        c(self, "ND", format!("{nd}u"));
        c(self, "NO", format!("{no}u"));
        c(self, "NS", format!("{ns}u"));
        c(self, "NB", format!("{}u", s.num_bodies()));
        // Array lengths must be at least 1.
        c(self, "NL1", format!("{}u", nl.max(1)));
        c(self, "ND1", format!("{}u", nd.max(1)));
        c(self, "NO1", format!("{}u", no.max(1)));
        c(self, "NB1", format!("{}u", s.num_bodies().max(1)));
        c(self, "NDD", format!("{}u", (nd * nd).max(1)));
        c(self, "MAX_C", format!("{MAX_CONTACTS}u"));
        c(self, "WORKGROUP", format!("{workgroup}u"));
        c(self, "DT", f(sim.dt));
        c(self, "GRAVITY", v3(sim.gravity));
        c(
            self,
            "ITERATIONS",
            format!(
                "{}u",
                sim.iterations_or(default_solver_iterations(&sim.contact.model))
            ),
        );
        c(self, "MARGIN", f(CONTACT_MARGIN));
        // With a floating root, the kernel works in a frame at the first root's centre of
        // mass (`load_state`): spatial quantities at the env origin would lose f32 digits to
        // cancellation once a robot has walked tens of metres from it.
        let shifted = self.shifted();
        c(self, "SHIFTED", shifted.to_string());
        c(self, "REPUBLISH", f(layout::REPUBLISH));
        let contact = &sim.contact;
        // MuJoCo's rows (`normal_row` in step/constraints.wgsl); the soft step's as its target and
        // regulariser scales.
        let (soft_step, relaxation, soft_target, soft_r) = match contact.model {
            ContactModel::MuJoCo => (false, SOLVER_RELAXATION, 0.0, 0.0),
            ContactModel::SoftStep {
                frequency,
                damping_ratio,
            } => {
                let a1 = 2.0 * damping_ratio + sim.dt * frequency;
                (true, 1.0, frequency / a1, 1.0 / (sim.dt * frequency * a1))
            }
        };
        c(self, "SOFT_STEP", soft_step.to_string());
        c(self, "RELAXATION", f(relaxation));
        c(self, "SOFT_TARGET_SCALE", f(soft_target));
        c(self, "SOFT_R_SCALE", f(soft_r));
        c(self, "REF_K", f(contact.stiffness(sim.dt)));
        c(self, "REF_B", f(contact.damping(sim.dt)));
        c(self, "IMP0", f(contact.solimp.0));
        c(self, "IMP1", f(contact.solimp.1));
        c(self, "IMP_WIDTH", f(contact.solimp.2));
        c(self, "IMP_MID", f(contact.solimp.3));
        c(self, "IMPRATIO", f(contact.impratio));
        let weights = InverseWeights::new(s);
        let list = |v: &[f32]| {
            if v.is_empty() {
                "0.0".to_string()
            } else {
                v.iter().map(|x| f(*x)).collect::<Vec<_>>().join(", ")
            }
        };
        self.line("// Inverse weights at the reference configuration (weights.rs).");
        self.line(format!(
            "var<private> body_invw: array<f32, NB1> = array<f32, NB1>({});",
            list(&weights.body)
        ));
        self.line(format!(
            "var<private> dof_invw: array<f32, ND1> = array<f32, ND1>({});",
            list(&weights.dof)
        ));
        self.out.push_str(&layout::lay_constants(s));
        self.line("");
    }
}
