//! Kernel generation: the scene-specific half of the WGSL kernel, written from the compiled
//! scene, in one of three forms ([`KernelForm`]).
//!
//! Every env shares one topology, so in the straight-line form each loop over links, dofs, free
//! objects and shape pairs is unrolled here, with the scene's numbers as literals and every
//! array index a constant. The driver then keeps the articulation's quantities in registers
//! instead of the local memory that run-time indexed tables need, drops work on structural
//! zeros (a root link's inertia, mass-matrix entries off the kinematic chain, a torque-driven
//! joint's drive terms). Shader compilers take far longer than linearly on long straight-line
//! code, so large articulations get the looped form: the scene as tables, read by the loops of
//! `step/articulation_loops.wgsl`. In both, the narrow phase stays a loop over the scene's
//! geometry table (a uniform buffer, see [`CompiledScene::geometry_table`];
//! `step/pair_loop.wgsl`): unrolled per shape pair it would be tens of thousands of
//! instructions, more than an instruction cache holds. The thread-per-branch form, whose lanes
//! hold a few pairs each, writes them out (`branch_narrow_phase.rs`). The scene-independent half, the files of `step/` in the order of [`STEP_WGSL`], is
//! appended to what this module writes.
//!
//! This module is the driver (the order of the sections, the writer and the scene's topology
//! queries they share, WGSL literals); each section of the kernel has its own module.

mod articulation;
mod branch_contacts;
mod branch_narrow_phase;
mod branch_system;
mod branch_threads;
mod constants;
mod constraints;
mod emitters;

pub(crate) use constraints::row_storage_floats;
mod integrate;
mod looped;
mod objects;
mod row_windows;
mod state_io;

use glam::{Mat3, Quat, Vec3};
use orbit_core::physics::SimCfg;

pub use branch_threads::Branches;

use crate::compile::{ArticulationBlock, CompiledScene, FreeRoot};

/// Beyond this many dofs the articulation is written as loops over tables
/// ([`KernelForm::Looped`]).
const STRAIGHT_LINE_DOFS: usize = 16;

/// How the kernel spells out the articulation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KernelForm {
    /// Straight-line code with the scene's numbers as literals: the fastest kernel, for
    /// articulations of up to [`STRAIGHT_LINE_DOFS`] dofs.
    StraightLine,
    /// Loops over the scene's link and dof tables: a kernel of about the same length whatever
    /// the articulation, which NVIDIA's driver builds in half the time of the Humanoid's
    /// straight-line one (docs/experiments/looped-kernel.md).
    Looped,
    /// Four invocations per env, one per branch of a floating root whose branches are chains
    /// of the same joints ([`Branches`]), sharing the root through quad operations (subgroup
    /// operations on the device): straight-line code, each invocation's constants selected by
    /// its lane (docs/experiments/ant-four-threads-per-env.md).
    ThreadPerBranch,
}

impl KernelForm {
    /// The form for `scene`: a thread per branch where the scene has [`Branches`] and the device
    /// has `subgroups` operations, else straight-line code up to [`STRAIGHT_LINE_DOFS`] dofs.
    pub fn for_scene(scene: &CompiledScene, subgroups: bool) -> Self {
        if subgroups && Branches::of(scene).is_some() {
            Self::ThreadPerBranch
        } else if scene.dofs.len() > STRAIGHT_LINE_DOFS {
            Self::Looped
        } else {
            Self::StraightLine
        }
    }
}

impl KernelForm {
    /// Invocations per env.
    pub fn threads_per_env(self) -> usize {
        if self == Self::ThreadPerBranch { 4 } else { 1 }
    }

    /// Warm-start entries per env of `scene`'s kernel in this form: contacts and limit rows
    /// share `MAX_CONTACTS`; with a thread per branch, each lane has one per chain dof.
    pub fn warm_entries(self, scene: &CompiledScene) -> usize {
        match (self, Branches::of(scene)) {
            (Self::ThreadPerBranch, Some(b)) => 4 * Gen::warm_per_lane(&b),
            _ => crate::compile::MAX_CONTACTS,
        }
    }
}

/// The full WGSL source of the step kernel for `scene` in `form`, with `workgroup`
/// invocations per workgroup.
///
/// # Panics
///
/// If `form` is [`KernelForm::ThreadPerBranch`] and `scene` has no [`Branches`].
pub fn kernel_source(
    scene: &CompiledScene,
    sim: &SimCfg,
    workgroup: usize,
    form: KernelForm,
) -> String {
    let mut g = Gen {
        scene,
        out: String::new(),
        indent: 0,
    };
    g.constants(sim, workgroup);
    if form == KernelForm::ThreadPerBranch {
        let branches = Branches::of(scene).expect("a scene of the thread-per-branch form");
        g.branch_threads(&branches);
        return g.out + BRANCH_STEP_WGSL;
    }
    match form {
        KernelForm::StraightLine => {
            g.state_io();
            g.kinematics();
            g.rnea_bias();
            g.crba();
            g.cholesky();
            g.drives();
        }
        KernelForm::Looped => g.looped_articulation(),
        KernelForm::ThreadPerBranch => unreachable!("written above"),
    }
    g.objects();
    g.collide();
    if form == KernelForm::StraightLine {
        g.jacobians();
        g.limit_rows();
        g.integrate();
    }
    let mut src = g.out + STEP_WGSL;
    if form == KernelForm::Looped {
        src.push_str(LOOPS_WGSL);
    }
    src
}

/// The looped form's articulation passes, appended after [`STEP_WGSL`].
const LOOPS_WGSL: &str = include_str!("../step/articulation_loops.wgsl");

/// The scene-independent half of the kernel, one file per concept: the per-invocation state and
/// bindings, quaternion and matrix helpers, buffer addresses, the narrow phase, the constraint
/// rows and their solver, and the substep with the entry point.
const STEP_WGSL: &str = concat!(
    include_str!("../step/bindings.wgsl"),
    include_str!("../step/state.wgsl"),
    include_str!("../step/math.wgsl"),
    include_str!("../step/addresses.wgsl"),
    include_str!("../step/narrow_phase.wgsl"),
    include_str!("../step/pair_loop.wgsl"),
    include_str!("../step/rows.wgsl"),
    include_str!("../step/constraints.wgsl"),
    include_str!("../step/run_env.wgsl"),
    include_str!("../step/substep.wgsl"),
);

/// The scene-independent half of the thread-per-branch kernel: bindings, helpers, the rows'
/// model, and its entry point.
const BRANCH_STEP_WGSL: &str = concat!(
    include_str!("../step/bindings.wgsl"),
    include_str!("../step/math.wgsl"),
    include_str!("../step/addresses.wgsl"),
    include_str!("../step/narrow_phase.wgsl"),
    include_str!("../step/rows.wgsl"),
    include_str!("../step/run_env.wgsl"),
    include_str!("../step/branch_threads.wgsl"),
);

/// The WGSL writer: the scene, the text so far and the current indentation.
struct Gen<'a> {
    scene: &'a CompiledScene,
    out: String,
    indent: usize,
}

impl Gen<'_> {
    fn line(&mut self, text: impl AsRef<str>) {
        for _ in 0..self.indent {
            self.out.push_str("    ");
        }
        self.out.push_str(text.as_ref());
        self.out.push('\n');
    }

    fn open(&mut self, text: impl AsRef<str>) {
        self.line(format!("{} {{", text.as_ref()));
        self.indent += 1;
    }

    fn close(&mut self) {
        self.indent -= 1;
        self.line("}");
    }

    /// Closes a block and opens the next one of the same statement (`} else {`).
    fn reopen(&mut self, text: impl AsRef<str>) {
        self.indent -= 1;
        self.line(format!("}} {} {{", text.as_ref()));
        self.indent += 1;
    }

    fn nd(&self) -> usize {
        self.scene.dofs.len()
    }

    /// The articulation that dof `d` belongs to.
    fn block(&self, d: usize) -> &ArticulationBlock {
        self.scene
            .articulations
            .iter()
            .find(|b| (b.dof0..b.dof0 + b.dofs).contains(&d))
            .expect("every dof belongs to an articulation")
    }

    /// The articulation `(first dof, dofs)` that dof `d` belongs to: its block of the system
    /// matrix.
    fn dof_block(&self, d: usize) -> (usize, usize) {
        let b = self.block(d);
        (b.dof0, b.dofs)
    }

    /// The dofs that move link `l`: its joint's, a floating root's six, none for a fixed root.
    fn link_dofs(&self, l: usize) -> Vec<usize> {
        let link = &self.scene.links[l];
        match (link.dof, link.free_root) {
            (Some(d), _) => vec![d],
            (None, Some(root)) => (root.dof0..root.dof0 + 6).collect(),
            (None, None) => vec![],
        }
    }

    /// The dofs from link `l` up to its articulation's root, child first (descending).
    fn chain(&self, l: usize) -> Vec<usize> {
        let mut out = Vec::new();
        let mut at = Some(l);
        while let Some(k) = at {
            out.extend(self.link_dofs(k).into_iter().rev());
            at = self.scene.links[k].parent;
        }
        out
    }

    /// Dof `d`'s motion subspace at the env origin as WGSL expressions `(angular, linear)`: a
    /// joint's from `kinematics`; a floating root's a unit translation of its centre of mass
    /// or a unit rotation about it, along an env axis.
    fn motion(&self, d: usize) -> (String, String) {
        let l = self.dof_link(d);
        let Some(axis) = self.scene.dofs[d].root_axis else {
            return (format!("sw[{l}]"), format!("su[{l}]"));
        };
        let root = self.scene.links[l]
            .free_root
            .expect("a root dof's link is a floating root");
        root_motion(axis, &format!("fcom[{}]", root.index))
    }

    /// The link that dof `d` moves: its joint's child link, or the floating root whose six
    /// dofs it is one of.
    fn dof_link(&self, d: usize) -> usize {
        self.scene
            .links
            .iter()
            .position(|link| {
                link.dof == Some(d)
                    || link
                        .free_root
                        .is_some_and(|r| (r.dof0..r.dof0 + 6).contains(&d))
            })
            .expect("every dof has its link")
    }

    /// A floating root's six velocity dofs as the WGSL vectors (centre-of-mass velocity,
    /// angular velocity).
    fn root_velocity(root: FreeRoot) -> (String, String) {
        let r = root.dof0;
        let v = |k: usize| format!("vec3<f32>(qd[{k}], qd[{}], qd[{}])", k + 1, k + 2);
        (v(r), v(r + 3))
    }
}

/// Root dof `axis`'s motion subspace as WGSL `(angular, linear)`: a unit translation of the
/// root's centre of mass `fcom` along env axis `axis` (0–2), or a unit rotation about it about
/// env axis `axis − 3`.
fn root_motion(axis: usize, fcom: &str) -> (String, String) {
    let e = v3(Vec3::AXES[axis % 3]);
    if axis < 3 {
        ("vec3<f32>(0.0)".into(), e)
    } else {
        (e.clone(), format!("cross({fcom}, {e})"))
    }
}

/// A WGSL float literal (infinities become ±3.4e38, which compare the same in every test made).
fn f(x: f32) -> String {
    if x.is_infinite() {
        return if x > 0.0 {
            "3.4e38".into()
        } else {
            "(-3.4e38)".into()
        };
    }
    let s = format!("{x:?}");
    // `-0.0` and friends need parentheses after a binary minus; keep every negative literal
    // wrapped.
    if x.is_sign_negative() {
        format!("({s})")
    } else {
        s
    }
}

fn v3(v: Vec3) -> String {
    format!("vec3<f32>({}, {}, {})", f(v.x), f(v.y), f(v.z))
}

fn q4(q: Quat) -> String {
    format!("vec4<f32>({}, {}, {}, {})", f(q.x), f(q.y), f(q.z), f(q.w))
}

fn m3(m: Mat3) -> String {
    format!(
        "mat3x3<f32>({}, {}, {})",
        v3(m.x_axis),
        v3(m.y_axis),
        v3(m.z_axis)
    )
}

#[cfg(test)]
mod tests {
    use glam::Vec3;
    use orbit_conformance::{free_box, passive_articulation, pendulum, resolve, table};
    use orbit_core::physics::SimCfg;
    use orbit_core::scene::{RootStateCfg, SceneCfg};

    use super::{Branches, KernelForm, kernel_source, row_storage_floats};
    use crate::compile::CompiledScene;

    /// Parses and validates a scene's kernel in `form` with naga (what wgpu does before any
    /// driver sees it), so a generator mistake fails here, with or without a GPU.
    fn validate_form(scene: &CompiledScene, form: KernelForm) -> String {
        let src = kernel_source(scene, &SimCfg::default(), 64, form);
        let module = naga::front::wgsl::parse_str(&src)
            .unwrap_or_else(|e| panic!("{form:?}: {}", e.emit_to_string(&src)));
        // Quad operations where the form uses them (the device's subgroup feature).
        let capabilities = if form == KernelForm::ThreadPerBranch {
            naga::valid::Capabilities::SUBGROUP
        } else {
            naga::valid::Capabilities::default()
        };
        naga::valid::Validator::new(naga::valid::ValidationFlags::all(), capabilities)
            .subgroup_stages(naga::valid::ShaderStages::COMPUTE)
            .validate(&module)
            .unwrap_or_else(|e| panic!("{form:?}: {}", e.emit_to_string(&src)));
        src
    }

    /// Validates a scene's kernel in both forms; returns the one of the scene's own form.
    fn validate(cfg: &SceneCfg) -> String {
        let scene = CompiledScene::new(&resolve(cfg)).expect("scene compiles");
        let other = match KernelForm::for_scene(&scene, false) {
            KernelForm::StraightLine => KernelForm::Looped,
            _ => KernelForm::StraightLine,
        };
        validate_form(&scene, other);
        validate_form(&scene, KernelForm::for_scene(&scene, false))
    }

    #[test]
    fn box_pushing_kernel_is_valid_wgsl() {
        let src = validate(&orbit_conformance::box_pushing_scene_cfg());
        if let Ok(path) = std::env::var("ORBIT_DUMP_KERNEL") {
            std::fs::write(path, &src).expect("write the kernel");
        }
        // The articulation is straight-line code: no link table is indexed at run time.
        assert!(!src.contains("link_parent") && src.contains("lpos[7]"));
        // A serial chain: the dense Cholesky factorisation.
        assert!(src.contains("amat[0] = sqrt(max(amat[0], 1e-12));"));
        // Capsule fingers against the box, the box against the table: codes 6 and 10.
        assert!(src.contains("const PAIR_KINDS = 0x440u;"));
        // No floating root: the rows store every entry.
        assert!(src.contains("const NJ = 7u;") && src.contains("return vec3<f32>(0.0);"));
    }

    /// A floating base compiles to six root dofs ahead of its joints' and a kernel that
    /// integrates its root; the Ant on the ground plane too.
    #[test]
    fn floating_base_kernels_are_valid_wgsl() {
        let mut art = passive_articulation(orbit_conformance::floating_tree());
        art.fixed_base = false;
        let cfg = SceneCfg {
            env_spacing: 2.0,
            articulations: vec![art],
            rigid_objects: vec![],
            static_objects: vec![],
        };
        let scene = CompiledScene::new(&resolve(&cfg)).expect("scene compiles");
        let block = scene.articulations[0];
        assert_eq!(
            (block.dofs, block.joint_dofs(), block.joint_dof0()),
            (8, 2, 6)
        );
        let src = validate(&cfg);
        assert!(src.contains("fcom[0] = fcom[0] + DT * vec3<f32>(qd[0], qd[1], qd[2]);"));
        let ant = validate(&SceneCfg {
            env_spacing: 3.0,
            articulations: vec![orbit_conformance::standing_ant(0.6, &[])],
            rigid_objects: vec![],
            static_objects: vec![orbit_conformance::ground(1.0)],
        });
        // The Ant's legs branch: its straight-line kernel factorises along the tree (no square
        // roots), and never writes the entry of two joints on different legs (dofs 8 and 6).
        assert!(!ant.contains("sqrt(max(amat") && ant.contains("linv[13] = 1.0 / max(amat[195]"));
        assert!(!ant.contains("amat[118]"));
        // Its rows leave out the floating root's six entries of each Jacobian: 8 of 14 stored.
        assert!(ant.contains("const NJ = 8u;") && ant.contains("cross(w, c_p[c] - fcom[0])"));
        // A row on one leg reads that leg's window of two entries.
        assert!(ant.contains(
            "select(select(select(qd[6], qd[8], br == 1u), qd[10], br == 2u), qd[12], br == 3u)"
        ));
    }

    /// The Ant without ground is four legs of two hinges on a floating root: with subgroup
    /// operations its kernel has a thread per leg, each leg's constants selected by lane.
    #[test]
    fn ant_without_ground_has_a_thread_per_leg() {
        let cfg = SceneCfg {
            env_spacing: 3.0,
            articulations: vec![orbit_conformance::standing_ant(0.6, &[])],
            rigid_objects: vec![],
            static_objects: vec![],
        };
        let scene = CompiledScene::new(&resolve(&cfg)).expect("scene compiles");
        let branches = Branches::of(&scene).expect("the Ant's legs are branches");
        assert_eq!((branches.chains.len(), branches.chain_len()), (4, 2));
        assert_eq!(
            KernelForm::for_scene(&scene, true),
            KernelForm::ThreadPerBranch
        );
        assert_eq!(
            KernelForm::for_scene(&scene, false),
            KernelForm::StraightLine
        );
        let src = validate_form(&scene, KernelForm::ThreadPerBranch);
        // The legs' dofs 6, 8, 10 and 12 by lane, and the root's force summed over the quad.
        assert!(src.contains(
            "select(select(select(6u, 8u, lane == 1u), 10u, lane == 2u), 12u, lane == 3u)"
        ));
        assert!(src.contains("let tw = fwr + quad_sum3(fw0);"));
        // On the ground each lane tests its leg's two capsules against it, and one of the
        // torso's (the capsule at its leg's hip; lane 0 also the torso's sphere): 6 or 7
        // contact slots a lane, where the torso's five shapes on one lane would make 13.
        let ground = SceneCfg {
            static_objects: vec![orbit_conformance::ground(1.0)],
            ..cfg
        };
        let scene = CompiledScene::new(&resolve(&ground)).expect("scene compiles");
        let branches = Branches::of(&scene).expect("no pair joins two legs");
        let pairs = [
            vec![0, 1, 5, 6],
            vec![2, 7, 8],
            vec![3, 9, 10],
            vec![4, 11, 12],
        ];
        assert_eq!(branches.lane_pairs, pairs);
        assert_eq!(branches.contact_slots, 7);
        // Its contacts' visits sit in one loop over the legs' turns.
        let src = validate_form(&scene, KernelForm::ThreadPerBranch);
        assert!(src.contains("for (var t = 0u; t < NBR; t++)"));
        // Of the narrow phase's cases only sphere–plane (3) and capsule–plane (7) are live.
        assert!(src.contains("const PAIR_KINDS = 0x88u;"));
        // Its pairs are written out, not looped over: lane 0's sphere–plane pair alone, then
        // on every lane a hip, thigh and shin capsule against the plane.
        assert!(!src.contains("fn collide_pair") && src.contains("if lane == 0u {"));
        assert_eq!(src.matches("collide_shapes(3u, pa, pb").count(), 1);
        assert_eq!(src.matches("collide_shapes(7u, pa, pb").count(), 3);
    }

    /// The Humanoid (27 dofs, self-collisions) compiles to a valid kernel.
    #[test]
    fn humanoid_kernel_is_valid_wgsl() {
        let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../orbit-assets/assets/scenes/humanoid.ron");
        let scene = orbit_assets::load_scene(&file, &[]).expect("the humanoid scene resolves");
        let compiled = CompiledScene::new(&scene).expect("scene compiles");
        assert_eq!(compiled.articulations[0].dofs, 27);
        assert_eq!(KernelForm::for_scene(&compiled, true), KernelForm::Looped);
        // Per env: 3 · 12 contact rows and 27 limit rows, of 21 stored Jacobian entries (the
        // floating root's six left out) and 27 of W.
        assert_eq!(
            row_storage_floats(&compiled, 1),
            Some((3 * 12 + 27) * (21 + 27))
        );
        let looped = validate_form(&compiled, KernelForm::Looped);
        // Its factorisation along the tree of dofs is short enough to unroll.
        let g = super::Gen {
            scene: &compiled,
            out: String::new(),
            indent: 0,
        };
        assert_eq!(g.tree_factor_terms(), 1170);
        assert!(looped.contains("linv[26] = 1.0 / max(amat[728], 1e-12);"));
        assert!(!looped.contains("var i = dof_parent[k];"));
        // Its widest branch (abdomen and legs) spans 15 of the 21 stored entries, and its legs
        // touch its arms: no Jacobian windows.
        assert!(!looped.contains("fn body_branch"));
        let straight = validate_form(&compiled, KernelForm::StraightLine);
        // The looped form is the shorter kernel.
        let (looped, straight) = (looped.lines().count(), straight.lines().count());
        assert!(
            looped < straight * 3 / 4,
            "{looped} lines against {straight}"
        );
    }

    #[test]
    fn kernels_of_small_scenes_are_valid_wgsl() {
        let init = RootStateCfg {
            pos: Vec3::new(0.0, 0.0, 0.1),
            ..RootStateCfg::default()
        };
        // An articulation alone (no objects, no contacts), then free bodies alone (no dofs).
        validate(&SceneCfg {
            env_spacing: 2.0,
            articulations: vec![passive_articulation(pendulum(1.0, 0.5, 0.05, 1.0))],
            rigid_objects: vec![],
            static_objects: vec![],
        });
        validate(&SceneCfg {
            env_spacing: 2.0,
            articulations: vec![],
            rigid_objects: vec![free_box("box", Vec3::splat(0.05), 1.0, 0.5, init)],
            static_objects: vec![table(0.0, 0.5)],
        });
    }
}
