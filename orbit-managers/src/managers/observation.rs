//! The observation manager.

use std::collections::BTreeMap;

use orbit_core::config::Node;
use orbit_core::parallel::MIN_ENVS_PER_TASK;
use orbit_core::rng::EnvRng;
use rayon::prelude::*;

use super::{
    ActionManager, CommandManager, Manager, ResetContext, before_concurrent_terms, context_after,
};
use crate::base_env::{EnvRngs, EnvView};
use crate::cfg::{EnvCfg, NoiseCfg};
use crate::error::EnvError;
use crate::scene::Scene;
use crate::term::{ObservationTerm, build_observation};

struct ObsTerm {
    name: String,
    term: Box<dyn ObservationTerm>,
    noise: Option<NoiseCfg>,
    clip: Option<(f32, f32)>,
    scale: Option<f32>,
    buf: Vec<f32>,
    /// History slots (0 = none): per env `history × dim` values, oldest first.
    history: usize,
    hist: Vec<f32>,
    /// Envs whose next value fills the whole history (after a reset).
    fresh: Vec<bool>,
}

impl ObsTerm {
    /// Values per env in the group output.
    fn out_dim(&self) -> usize {
        self.term.dim() * self.history.max(1)
    }
}

/// One observation group: its terms and the concatenated output.
pub struct ObservationGroup {
    /// Group name.
    pub name: String,
    terms: Vec<ObsTerm>,
    /// Values per env.
    pub dim: usize,
    /// Concatenated observations, `num_envs × dim`.
    pub values: Vec<f32>,
}

impl ObservationGroup {
    /// The term that writes value `index` of an env's row, and the value's index within it
    /// (`<term>[k]`).
    pub fn term_at(&self, index: usize) -> Option<String> {
        let mut start = 0;
        for t in &self.terms {
            let end = start + t.out_dim();
            if index < end {
                return Some(format!("{}[{}]", t.name, index - start));
            }
            start = end;
        }
        None
    }
}

/// Computes observation groups: per term `func`, then noise, clip, scale; concatenated.
pub struct ObservationManager {
    pub(crate) groups: Vec<ObservationGroup>,
}

impl ObservationManager {
    pub(crate) fn new(
        doc: &Node,
        scene: &Scene,
        cfg: &EnvCfg,
        actions: &ActionManager,
        commands: &CommandManager,
    ) -> Result<Self, EnvError> {
        let n = scene.num_envs();
        let mut groups = Vec::new();
        for (gname, g) in &cfg.observations.0 {
            let mut terms = Vec::new();
            for (tname, t) in &g.terms.0 {
                let ctx = context_after(
                    doc,
                    scene,
                    cfg,
                    format!("observations.{gname}.terms.{tname}"),
                    actions,
                    commands,
                );
                let term = build_observation(&t.func, &ctx)?;
                let d = term.dim();
                terms.push(ObsTerm {
                    name: tname.clone(),
                    term,
                    noise: if g.enable_corruption { t.noise } else { None },
                    clip: t.clip,
                    scale: t.scale,
                    buf: vec![0.0; n * d],
                    history: t.history_length,
                    hist: vec![0.0; n * d * t.history_length],
                    fresh: vec![true; n],
                });
            }
            let dim = terms.iter().map(|t| t.out_dim()).sum();
            groups.push(ObservationGroup {
                name: gname.clone(),
                terms,
                dim,
                values: vec![0.0; n * dim],
            });
        }
        Ok(Self { groups })
    }

    /// Every term's fresh values into its buffer, the terms running concurrently.
    fn compute_terms(&mut self, env: &EnvView<'_>) {
        before_concurrent_terms(env);
        self.groups.par_iter_mut().for_each(|g| {
            g.terms
                .par_iter_mut()
                .for_each(|t| t.term.compute(env, &mut t.buf));
        });
    }

    pub(crate) fn compute(&mut self, env: &EnvView<'_>, noise: &mut EnvRngs) {
        self.compute_terms(env);
        // Noise draws follow term order within each env's stream: the terms go in order.
        let streams = noise.streams_mut();
        for g in &mut self.groups {
            let (dim, terms) = (g.dim, &mut g.terms);
            let mut offset = 0;
            let mut first = 0;
            while first < terms.len() {
                if terms[first].history > 0 {
                    offset += terms[first].write_history(&mut g.values, dim, offset, streams);
                    first += 1;
                    continue;
                }
                // A run of terms without history: one pass over the envs writes them all.
                let end = terms[first..]
                    .iter()
                    .position(|t| t.history > 0)
                    .map_or(terms.len(), |k| first + k);
                let run = &terms[first..end];
                g.values
                    .par_chunks_mut(dim)
                    .zip(streams.par_iter_mut())
                    .enumerate()
                    .with_min_len(MIN_ENVS_PER_TASK)
                    .for_each(|(e, (out, rng))| {
                        let mut column = offset;
                        for t in run {
                            let d = t.term.dim();
                            let values = &mut out[column..column + d];
                            values.copy_from_slice(&t.buf[e * d..(e + 1) * d]);
                            corrupt(t.corruption(), rng, values);
                            column += d;
                        }
                    });
                offset += run.iter().map(ObsTerm::out_dim).sum::<usize>();
                first = end;
            }
        }
    }

    /// Writes each group's observations of the listed envs as they stand now, before a reset,
    /// into their rows of `out[group]` (`num_envs × dim` each): terms, clip and scale,
    /// histories shifted by the current value, but no noise. Histories and noise streams are
    /// left alone, so the next [`Self::compute`] is unchanged.
    pub(crate) fn compute_final(
        &mut self,
        env: &EnvView<'_>,
        env_ids: &[usize],
        out: &mut [Vec<f32>],
    ) {
        self.compute_terms(env);
        for (g, out) in self.groups.iter().zip(out) {
            for &e in env_ids {
                let row = &mut out[e * g.dim..(e + 1) * g.dim];
                let mut column = 0;
                for t in &g.terms {
                    column += t.write_final(e, &mut row[column..]);
                }
            }
        }
    }
}

impl ObsTerm {
    /// Noise, clip and scale, as [`corrupt`] takes them.
    fn corruption(&self) -> Corruption {
        (self.noise, self.clip, self.scale)
    }

    /// Writes env `e`'s value as [`ObservationManager::compute_final`] takes it (clip and
    /// scale, no noise; a history shifted by it, or filled with it after a reset) at the
    /// start of `row`; returns the columns written.
    fn write_final(&self, e: usize, row: &mut [f32]) -> usize {
        let (d, width) = (self.term.dim(), self.out_dim());
        let value = &self.buf[e * d..(e + 1) * d];
        let slots = if self.history == 0 || self.fresh[e] {
            self.history.max(1)
        } else {
            row[..width - d].copy_from_slice(&self.hist[e * width + d..(e + 1) * width]);
            1
        };
        let first = width - slots * d;
        for slot in row[first..width].chunks_exact_mut(d.max(1)).take(slots) {
            for (v, &x) in slot.iter_mut().zip(value) {
                *v = clip_and_scale(x, self.clip, self.scale);
            }
        }
        width
    }

    /// Corrupts this term's fresh values, shifts them into its history and writes the history
    /// (oldest first) into the group's columns from `offset`; returns the columns written.
    fn write_history(
        &mut self,
        values: &mut [f32],
        dim: usize,
        offset: usize,
        streams: &mut [EnvRng],
    ) -> usize {
        let (d, width, corruption) = (self.term.dim(), self.out_dim(), self.corruption());
        if d == 0 {
            return 0;
        }
        self.buf
            .par_chunks_mut(d)
            .zip(values.par_chunks_mut(dim))
            .zip(streams.par_iter_mut())
            .zip(self.hist.par_chunks_mut(width))
            .zip(self.fresh.par_iter_mut())
            .with_min_len(MIN_ENVS_PER_TASK)
            .for_each(|((((row, out), rng), hist), fresh)| {
                corrupt(corruption, rng, row);
                if std::mem::replace(fresh, false) {
                    hist.chunks_exact_mut(d)
                        .for_each(|slot| slot.copy_from_slice(row));
                } else {
                    hist.copy_within(d.., 0);
                    let last = hist.len() - d;
                    hist[last..].copy_from_slice(row);
                }
                out[offset..offset + width].copy_from_slice(hist);
            });
        width
    }
}

/// A term's noise, clip and scale.
type Corruption = (Option<NoiseCfg>, Option<(f32, f32)>, Option<f32>);

/// Adds a term's noise to one env's row, then clips and scales it (Isaac Lab's order).
fn corrupt((noise, clip, scale): Corruption, rng: &mut EnvRng, row: &mut [f32]) {
    if noise.is_none() && clip.is_none() && scale.is_none() {
        return;
    }
    for v in row {
        *v += match noise {
            Some(NoiseCfg::Uniform { n_min, n_max }) => rng.uniform_range(n_min, n_max),
            Some(NoiseCfg::Gaussian { mean, std }) => mean + std * rng.normal(),
            None => 0.0,
        };
        *v = clip_and_scale(*v, clip, scale);
    }
}

/// A term's clip, then its scale.
fn clip_and_scale(v: f32, clip: Option<(f32, f32)>, scale: Option<f32>) -> f32 {
    let v = clip.map_or(v, |(lo, hi)| v.clamp(lo, hi));
    scale.map_or(v, |s| v * s)
}

impl Manager for ObservationManager {
    /// Every group's terms as `<group>/<term>`, groups in config order.
    fn active_terms(&self) -> Vec<String> {
        self.groups
            .iter()
            .flat_map(|g| {
                g.terms
                    .iter()
                    .map(move |t| format!("{}/{}", g.name, t.name))
            })
            .collect()
    }

    /// Marks the listed envs' histories to be refilled by their next value; logs nothing.
    fn reset(&mut self, env_ids: &[usize], _: &mut ResetContext<'_>) -> BTreeMap<String, f32> {
        for g in &mut self.groups {
            for t in &mut g.terms {
                for &e in env_ids {
                    t.fresh[e] = true;
                }
            }
        }
        BTreeMap::new()
    }
}
