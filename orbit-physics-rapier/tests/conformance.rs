//! The backend conformance suite on the rapier backend.

use orbit_physics_rapier::BACKEND_NAME;

#[test]
fn free_fall() {
    orbit_conformance::free_fall(BACKEND_NAME);
}

#[test]
fn pendulum_period() {
    orbit_conformance::pendulum_period(BACKEND_NAME);
}

#[test]
fn box_rests_on_table() {
    orbit_conformance::box_rests_on_table(BACKEND_NAME);
}

#[test]
fn sliding_box_decelerates_at_mu_g() {
    orbit_conformance::sliding_box_decelerates_at_mu_g(BACKEND_NAME);
}

#[test]
fn writes_touch_only_listed_envs() {
    orbit_conformance::writes_touch_only_listed_envs(BACKEND_NAME);
}
