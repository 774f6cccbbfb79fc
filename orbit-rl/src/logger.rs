//! The scalars file of a run: one CSV row per value, TensorBoard's tag names (spec §6.5).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::RlError;
use crate::runner::IterationLog;

/// `scalars.csv`: `iteration,env_steps,wall_time,tag,value`, flushed after every iteration.
pub struct ScalarLog {
    path: PathBuf,
    out: BufWriter<File>,
}

impl ScalarLog {
    /// Creates (or truncates) the file and writes the header.
    pub fn create(path: &Path) -> Result<Self, RlError> {
        let file = File::create(path).map_err(RlError::io(path))?;
        let mut log = Self {
            path: path.to_path_buf(),
            out: BufWriter::new(file),
        };
        log.line(format_args!("iteration,env_steps,wall_time,tag,value"))?;
        Ok(log)
    }

    fn line(&mut self, args: std::fmt::Arguments<'_>) -> Result<(), RlError> {
        writeln!(self.out, "{args}").map_err(RlError::io(&self.path))
    }

    /// Appends one iteration's scalars.
    pub fn write(&mut self, log: &IterationLog) -> Result<(), RlError> {
        for (tag, value) in scalars(log) {
            let (it, steps, t) = (log.iteration, log.env_steps, log.wall_time);
            self.line(format_args!("{it},{steps},{t:.3},{tag},{value}"))?;
        }
        self.out.flush().map_err(RlError::io(&self.path))
    }
}

/// An iteration's scalars under RSL-RL's TensorBoard tags. Episode-log keys containing `/`
/// keep their name, others become `Episode/<key>`.
pub fn scalars(log: &IterationLog) -> Vec<(String, f64)> {
    let mut v: Vec<(String, f64)> = vec![
        ("Loss/value_function".into(), f64::from(log.losses.value)),
        ("Loss/surrogate".into(), f64::from(log.losses.surrogate)),
        ("Loss/entropy".into(), f64::from(log.losses.entropy)),
        ("Loss/learning_rate".into(), log.learning_rate),
        (
            "Policy/mean_noise_std".into(),
            f64::from(log.mean_noise_std),
        ),
        ("Perf/total_fps".into(), log.fps),
        ("Perf/collection_time".into(), log.collection_time),
        ("Perf/learning_time".into(), log.learning_time),
    ];
    let optional = [
        ("Train/mean_reward", log.mean_return),
        ("Train/mean_episode_length", log.mean_episode_length),
        ("Train/success_rate", log.success_rate),
    ];
    v.extend(
        optional
            .iter()
            .filter_map(|(t, x)| x.map(|x| (t.to_string(), f64::from(x)))),
    );
    for (key, &value) in &log.episode {
        let tag = if key.contains('/') {
            key.clone()
        } else {
            format!("Episode/{key}")
        };
        v.push((tag, f64::from(value)));
    }
    v
}
