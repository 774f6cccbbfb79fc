//! The scalars of a run under RSL-RL's TensorBoard tag names (`Loss/...`, `Perf/...`,
//! `Train/...`): `scalars.csv`, one row per value, and a TensorBoard event file.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::RlError;
use crate::runner::IterationLog;
use crate::tensorboard::EventWriter;

/// The file name of a run's scalar log.
pub const SCALARS_FILE: &str = "scalars.csv";

/// `scalars.csv` (`iteration,env_steps,wall_time,tag,value`) and `events.out.tfevents.*`
/// (step = iteration), both flushed after every iteration.
pub struct ScalarLog {
    path: PathBuf,
    out: BufWriter<File>,
    events: EventWriter,
}

impl ScalarLog {
    /// Creates (or truncates) `dir/scalars.csv`, writes its header, and starts an event file.
    pub fn create(dir: &Path) -> Result<Self, RlError> {
        let path = dir.join(SCALARS_FILE);
        let file = File::create(&path).map_err(RlError::io(&path))?;
        let mut log = Self {
            path,
            out: BufWriter::new(file),
            events: EventWriter::create(dir)?,
        };
        log.line(format_args!("iteration,env_steps,wall_time,tag,value"))?;
        Ok(log)
    }

    fn line(&mut self, args: std::fmt::Arguments<'_>) -> Result<(), RlError> {
        writeln!(self.out, "{args}").map_err(RlError::io(&self.path))
    }

    /// Appends one iteration's scalars.
    pub fn write(&mut self, log: &IterationLog) -> Result<(), RlError> {
        let scalars = scalars(log);
        for (tag, value) in &scalars {
            let (it, steps, t) = (log.iteration, log.env_steps, log.wall_time);
            self.line(format_args!("{it},{steps},{t:.3},{tag},{value}"))?;
        }
        self.out.flush().map_err(RlError::io(&self.path))?;
        self.events.add_scalars(
            log.iteration as u64,
            scalars.iter().map(|(tag, v)| (tag.as_str(), *v as f32)),
        )?;
        self.events.flush()
    }
}

/// One history from the segments of a run resumed across run directories, oldest first: a
/// resumed run starts a new directory at the iteration after its checkpoint, and redoes the
/// iterations the previous directory logged past that checkpoint, so a later segment's
/// iterations replace an earlier one's. Sorted by iteration.
pub fn merge_segments(segments: Vec<Vec<IterationLog>>) -> Vec<IterationLog> {
    let mut by_iteration = std::collections::BTreeMap::new();
    for log in segments.into_iter().flatten() {
        by_iteration.insert(log.iteration, log);
    }
    by_iteration.into_values().collect()
}

/// The history to plot for a run resumed from the checkpoint `checkpoint_base`
/// (`<run>/model_<it>`): the resumed-from run's `scalars.csv` merged with this run's `own`
/// iterations (see [`merge_segments`]). Without a readable earlier file it is `own` alone,
/// with a warning.
pub fn resumed_history(checkpoint_base: &Path, own: &[IterationLog]) -> Vec<IterationLog> {
    let earlier = checkpoint_base.with_file_name(SCALARS_FILE);
    let mut segments = Vec::with_capacity(2);
    match read_scalars(&earlier) {
        Ok(logs) => segments.push(logs),
        Err(e) => tracing::warn!("plotting the resumed run's own iterations only: {e}"),
    }
    segments.push(own.to_vec());
    merge_segments(segments)
}

/// Reads a `scalars.csv` back into one [`IterationLog`] per iteration (for re-plotting a run
/// that was stopped before it drew its curves). Tags it does not know go to `episode`. A last
/// line without its newline was cut by a kill mid-write: it is dropped with a warning.
pub fn read_scalars(path: &Path) -> Result<Vec<IterationLog>, RlError> {
    let mut text = std::fs::read_to_string(path).map_err(RlError::io(path))?;
    if !text.is_empty() && !text.ends_with('\n') {
        let cut = text.rfind('\n').map_or(0, |i| i + 1);
        tracing::warn!(
            "{}: dropping the cut last line `{}` (the run was stopped while writing it)",
            path.display(),
            &text[cut..]
        );
        text.truncate(cut);
    }
    let bad = |line: usize, what: &str| RlError::Io {
        path: path.to_path_buf(),
        source: std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("line {line}: {what}; expected `iteration,env_steps,wall_time,tag,value`"),
        ),
    };
    let mut logs: Vec<IterationLog> = Vec::new();
    for (i, row) in text.lines().enumerate().skip(1) {
        let f: Vec<&str> = row.splitn(5, ',').collect();
        let [it, steps, t, tag, value] = f[..] else {
            return Err(bad(i + 1, "not five fields"));
        };
        let (Ok(it), Ok(steps), Ok(t), Ok(value)) = (
            it.parse::<usize>(),
            steps.parse::<u64>(),
            t.parse::<f64>(),
            value.parse::<f64>(),
        ) else {
            return Err(bad(i + 1, "a field is not a number"));
        };
        if logs.last().is_none_or(|l| l.iteration != it) {
            logs.push(IterationLog {
                iteration: it,
                env_steps: steps,
                wall_time: t,
                mean_return: None,
                mean_episode_length: None,
                success_rate: None,
                losses: Default::default(),
                learning_rate: 0.0,
                mean_noise_std: 0.0,
                fps: 0.0,
                collection_time: 0.0,
                env_time: 0.0,
                physics_time: 0.0,
                env_phase_times: Default::default(),
                policy_time: 0.0,
                learning_time: 0.0,
                episode: Default::default(),
            });
        }
        let log = logs.last_mut().expect("pushed above");
        let v32 = value as f32;
        match tag {
            "Loss/value_function" => log.losses.value = v32,
            "Loss/surrogate" => log.losses.surrogate = v32,
            "Loss/entropy" => log.losses.entropy = v32,
            "Loss/learning_rate" => log.learning_rate = value,
            "Policy/mean_noise_std" => log.mean_noise_std = v32,
            "Perf/total_fps" => log.fps = value,
            "Perf/collection_time" => log.collection_time = value,
            "Perf/env_time" => log.env_time = value,
            "Perf/physics_time" => log.physics_time = value,
            "Perf/policy_time" => log.policy_time = value,
            "Perf/learning_time" => log.learning_time = value,
            "Train/mean_reward" => log.mean_return = Some(v32),
            "Train/mean_episode_length" => log.mean_episode_length = Some(v32),
            "Train/success_rate" => log.success_rate = Some(v32),
            other => match env_phase(other) {
                Some(phase) => {
                    log.env_phase_times.insert(phase.to_string(), value);
                }
                None => {
                    let key = other.strip_prefix("Episode/").unwrap_or(other);
                    log.episode.insert(key.to_string(), v32);
                }
            },
        }
    }
    Ok(logs)
}

/// The env phase a `Perf/env_<phase>_time` tag names (not `Perf/env_time`, the whole step).
fn env_phase(tag: &str) -> Option<&str> {
    let phase = tag.strip_prefix("Perf/env_")?.strip_suffix("_time")?;
    (!phase.is_empty()).then_some(phase)
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
        ("Perf/env_time".into(), log.env_time),
        ("Perf/physics_time".into(), log.physics_time),
        ("Perf/policy_time".into(), log.policy_time),
        ("Perf/learning_time".into(), log.learning_time),
    ];
    v.extend(
        log.env_phase_times
            .iter()
            .map(|(phase, &t)| (format!("Perf/env_{phase}_time"), t)),
    );
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
