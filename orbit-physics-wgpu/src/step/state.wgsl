// One invocation simulates one env for `params.substeps` substeps, then publishes its state.
//
// The files of `step/` are the scene-independent half of the kernel, in the order `codegen/mod.rs`
// concatenates them (after `bindings.wgsl`). `codegen/` prepends the other half,
// generated from the compiled scene: the constants (NL, ND, ..., the LAY_* and GEO_* offsets)
// and straight-line functions in which every link, dof and object is spelled out with constant
// indices (load_state, publish, kinematics, rnea_bias, crba, cholesky, chol_solve, drives,
// objects_free_velocity, copy_body_poses, body_jt, limit_rows, integrate and the obj_*
// accessors). Constant indices let the driver keep the articulation in registers. The narrow
// phase loops over the scene's geometry table `geo` (shapes, body spheres, groups of pairs,
// pairs; see `GeometryTable` in compile.rs) and the contact rows, whose number varies, are
// indexed at run time.
//
// Per substep: forward kinematics → RNEA bias forces → CRBA mass matrix + armature → implicit
// drives and joint damping folded into A = M + h(D + d) + h²K → Cholesky → free velocities →
// free bodies (gravity, explicit gyroscopic term) → contacts (narrow phase per shape pair) and
// joint limits as MuJoCo's soft constraint rows → over-relaxed projected Gauss–Seidel with warm
// start → velocity limits → semi-implicit Euler (quaternions renormalised).
//
// Spatial vectors are (angular, linear) pairs in env-frame coordinates taken at the env origin;
// a link's spatial inertia there is (mass m, first moment h = m c, rotational inertia J).

const RMAX: u32 = MAX_C * 3u + ND1;

var<private> env: u32;
var<private> num_envs: u32;
// Whether the substep running is the first of this dispatch (a written env skips the warm
// start of that one only).
var<private> first_substep: bool;
// Articulation state and kinematics (indexed by constants only).
var<private> q: array<f32, ND1>;
var<private> qd: array<f32, ND1>;
var<private> lpos: array<vec3<f32>, NL1>;
var<private> lrot: array<vec4<f32>, NL1>;
var<private> sw: array<vec3<f32>, NL1>;
var<private> su: array<vec3<f32>, NL1>;
var<private> vw: array<vec3<f32>, NL1>;
var<private> vu: array<vec3<f32>, NL1>;
var<private> im: array<f32, NL1>;
var<private> ih: array<vec3<f32>, NL1>;
var<private> ij: array<mat3x3<f32>, NL1>;
var<private> bias: array<f32, ND1>;
// A = M + h(D + d) + h²K, overwritten by its factors (lower triangle), and, for the dense
// Cholesky factor, its inverse diagonal.
var<private> amat: array<f32, NDD>;
var<private> linv: array<f32, ND1>;
var<private> applied: array<f32, ND1>;
// This dispatch's drive inputs: effort, bias compensation on, position and velocity targets.
var<private> in_ef: array<f32, ND1>;
var<private> in_comp: array<bool, ND1>;
var<private> in_qt: array<f32, ND1>;
var<private> in_vt: array<f32, ND1>;
// Free bodies: origin pose, centre-of-mass velocity, angular velocity.
var<private> opos: array<vec3<f32>, NO1>;
var<private> orot: array<vec4<f32>, NO1>;
var<private> ovel: array<vec3<f32>, NO1>;
var<private> oang: array<vec3<f32>, NO1>;
var<private> ocom: array<vec3<f32>, NO1>;
var<private> oinvm: array<f32, NO1>;
var<private> oinvi: array<mat3x3<f32>, NO1>;
var<private> mscale: array<f32, NB1>;
// Body poses for the narrow phase, which indexes them at run time.
var<private> bpos: array<vec3<f32>, NB1>;
var<private> brot: array<vec4<f32>, NB1>;
// Contacts of the current substep.
var<private> nc: u32;
var<private> c_n: array<vec3<f32>, MAX_C>;
var<private> c_p: array<vec3<f32>, MAX_C>;
var<private> c_sep: array<f32, MAX_C>;
var<private> c_ba: array<i32, MAX_C>;
var<private> c_bb: array<i32, MAX_C>;
var<private> c_mu: array<f32, MAX_C>;
var<private> c_slot: array<u32, MAX_C>;
// Constraints: one block per contact (its normal row and two tangent rows along the basis
// `contact_basis(n)`) and the joint-limit rows. A contact's rows see the relative velocity of
// its two sides at the contact point: J_arm q̇ (arm part) plus, per free object, the velocity of
// the object's material point there, v + ω × p (p from the object's centre of mass). An impulse
// P moves an object by (P / m, I⁻¹ (p × P)) and q̇ by W x per row (W = A⁻¹ J_armᵀ). Only the
// levers and effective masses are stored, not per-row object Jacobians: the solver is bound by
// the traffic of this storage (it lives in local memory, and 65 536 envs' worth does not fit in
// L2), so it recomputes the tangents and the object terms instead. `k_info` holds whether a
// contact has an arm part (ROW_ARM), its two sides' free objects plus one (bits 8–15 and
// 16–23, 0 for none), the factor of the floating root's part plus one (bits 24–25; see
// `contact_root_vel`) and the branch of its rows' Jacobian window (bits 26–31,
// `row_branch`). A penetrating contact or limit is a soft row of the configured contact model
// (its rows' target velocities `k_tgt` and the normal row's regulariser `k_r`; see
// `normal_row`), a gap a rigid speculative row.
var<private> k_info: array<u32, MAX_C>;
var<private> k_pa: array<vec3<f32>, MAX_C>;
var<private> k_pb: array<vec3<f32>, MAX_C>;
var<private> k_meff: array<vec3<f32>, MAX_C>;
var<private> k_tgt: array<vec3<f32>, MAX_C>;
var<private> k_r: array<f32, MAX_C>;
var<private> k_lam: array<vec3<f32>, MAX_C>;
var<private> nlim: u32;
var<private> l_meff: array<f32, ND1>;
var<private> l_tgt: array<f32, ND1>;
var<private> l_r: array<f32, ND1>;
var<private> l_lam: array<f32, ND1>;
var<private> l_slot: array<u32, ND1>;
// The branch of a limit row's Jacobian window (`dof_branch`).
var<private> l_br: array<u32, ND1>;
// Arm rows: J_arm and W of contact c's direction d at row 3c + d, of limit l at row 3 MAX_C + l
// (J_arm's NJ stored entries, W's ND1), in `r_j` and `r_w` or in the `rows` buffer (generated
// with their accessors).

const ROW_ARM: u32 = 4u;
// Velocities at the start of the substep: MuJoCo's reference acceleration
// aref = −REF_B v − REF_K d(pos) pos uses them (`ContactCfg::stiffness`, `ContactCfg::damping`).
var<private> qd0: array<f32, ND1>;
var<private> ovel0: array<vec3<f32>, NO1>;
var<private> oang0: array<vec3<f32>, NO1>;

