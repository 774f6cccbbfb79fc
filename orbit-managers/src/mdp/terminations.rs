//! Termination terms.
use super::*;

/// `time_out`: the episode has lasted `max_episode_length` steps.
struct TimeOut;

impl TerminationTerm for TimeOut {
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [bool]) {
        for (o, &l) in out.iter_mut().zip(env.episode_length) {
            *o = l >= env.max_episode_length;
        }
    }
}

inventory::submit! { TerminationTermDef { name: "time_out", build: |_| Ok(Box::new(TimeOut)) } }
