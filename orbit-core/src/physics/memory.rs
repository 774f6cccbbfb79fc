//! A check made before a backend allocates its envs: that the memory they will take fits in
//! what the machine has available, so an absurd `num_envs` fails at once with numbers instead
//! of swapping the machine to a halt.

use super::PhysicsError;

/// Fails when `num_envs` envs of `bytes_per_env` each (a lower estimate) need more memory than
/// the machine has available (`MemAvailable` of `/proc/meminfo`; no check where that cannot be
/// read).
pub fn check_host_memory(
    backend: &str,
    num_envs: usize,
    bytes_per_env: usize,
) -> Result<(), PhysicsError> {
    let Some(available) = available_bytes() else {
        return Ok(());
    };
    check_fits(backend, num_envs, bytes_per_env, available)
}

/// [`check_host_memory`] against a given number of available bytes.
pub fn check_fits(
    backend: &str,
    num_envs: usize,
    bytes_per_env: usize,
    available: u64,
) -> Result<(), PhysicsError> {
    let needed = num_envs as u128 * bytes_per_env as u128;
    if needed <= u128::from(available) {
        return Ok(());
    }
    let gib = |b: u128| b as f64 / f64::from(1u32 << 30);
    let fitting = available / bytes_per_env.max(1) as u64;
    Err(PhysicsError::InvalidInput(format!(
        "{num_envs} envs on the `{backend}` backend need at least {:.1} GiB of memory \
         (about {} KiB per env), and {:.1} GiB are available: lower num_envs (at most about \
         {fitting} fit)",
        gib(needed),
        bytes_per_env / 1024,
        gib(u128::from(available))
    )))
}

/// The memory available to new allocations, in bytes, if the system says.
fn available_bytes() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 10⁸ envs of 140 KiB do not fit in 24 GiB: the error gives the need, the per-env size and
    /// how many fit; 10⁵ envs do fit.
    #[test]
    fn envs_beyond_the_memory_are_refused_with_numbers() {
        let available = 24 << 30;
        let per_env = 140 * 1024;
        assert!(check_fits("rapier", 100_000, per_env, available).is_ok());
        let message = check_fits("rapier", 100_000_000, per_env, available)
            .unwrap_err()
            .to_string();
        for part in [
            "13351.4 GiB",
            "140 KiB per env",
            "24.0 GiB are available",
            "179755 fit",
        ] {
            assert!(message.contains(part), "`{part}` missing: {message}");
        }
    }
}
