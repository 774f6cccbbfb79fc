//! A check made before a backend allocates its envs: that the memory they will take fits in
//! what the machine has available, so an absurd `num_envs` fails at once with numbers instead
//! of swapping the machine to a halt.

use super::PhysicsError;

/// Fails when `num_envs` envs of `bytes_per_env` each (a lower estimate), together with the
/// envs that other builds in this process are allocating at the same time (data-parallel ranks
/// in threads), need more memory than the machine has available (`MemAvailable` of
/// `/proc/meminfo`; no check where that cannot be read). Hold the reservation it returns until
/// the envs are allocated: other builds count it until then.
pub fn check_host_memory(
    backend: &str,
    num_envs: usize,
    bytes_per_env: usize,
) -> Result<HostMemoryReservation, PhysicsError> {
    let needed = num_envs as u128 * bytes_per_env as u128;
    let reservation = HostMemoryReservation::new(needed);
    if let Some(available) = available_bytes() {
        check_fits(
            backend,
            num_envs,
            bytes_per_env,
            reservation.others,
            available,
        )?;
    }
    Ok(reservation)
}

/// Bytes that builds in this process have claimed and not yet allocated.
static RESERVED: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// Memory a backend is allocating, counted against every other build of this process until
/// dropped.
#[derive(Debug)]
pub struct HostMemoryReservation {
    bytes: u64,
    /// What other builds had claimed when this one was made.
    others: u64,
}

impl HostMemoryReservation {
    fn new(bytes: u128) -> Self {
        let bytes = u64::try_from(bytes).unwrap_or(u64::MAX / 2);
        let before = RESERVED.fetch_add(bytes, std::sync::atomic::Ordering::SeqCst);
        Self {
            bytes,
            others: before,
        }
    }
}

impl Drop for HostMemoryReservation {
    fn drop(&mut self) {
        RESERVED.fetch_sub(self.bytes, std::sync::atomic::Ordering::SeqCst);
    }
}

/// [`check_host_memory`] against a given number of available bytes, with `others` bytes
/// claimed by other builds of this process.
pub fn check_fits(
    backend: &str,
    num_envs: usize,
    bytes_per_env: usize,
    others: u64,
    available: u64,
) -> Result<(), PhysicsError> {
    let needed = num_envs as u128 * bytes_per_env as u128;
    if needed + u128::from(others) <= u128::from(available) {
        return Ok(());
    }
    let gib = |b: u128| b as f64 / f64::from(1u32 << 30);
    let fitting = available.saturating_sub(others) / bytes_per_env.max(1) as u64;
    let shared = if others > 0 {
        format!(
            ", and other envs of this process (data-parallel ranks) are taking {:.1} GiB of \
             them: lower the run's num_envs (about {fitting} more fit)",
            gib(u128::from(others))
        )
    } else {
        format!(": lower num_envs (at most about {fitting} fit)")
    };
    Err(PhysicsError::InvalidInput(format!(
        "{num_envs} envs on the `{backend}` backend need at least {:.1} GiB of memory \
         (about {} KiB per env), and {:.1} GiB are available{shared}",
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
        assert!(check_fits("rapier", 100_000, per_env, 0, available).is_ok());
        let message = check_fits("rapier", 100_000_000, per_env, 0, available)
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

    /// Envs that fit alone do not fit beside other builds of the process: 8 ranks of 150 000
    /// envs of 140 KiB (20 GiB each) in 24 GiB. The reservations count while held.
    #[test]
    fn builds_of_one_process_count_together() {
        let (available, per_env) = (24u64 << 30, 140 * 1024);
        assert!(check_fits("rapier", 150_000, per_env, 0, available).is_ok());
        let first = HostMemoryReservation::new(150_000 * per_env as u128);
        let second = HostMemoryReservation::new(150_000 * per_env as u128);
        assert!(second.others >= first.bytes);
        let message = check_fits("rapier", 150_000, per_env, second.others, available)
            .unwrap_err()
            .to_string();
        assert!(message.contains("other envs of this process"), "{message}");
        drop((first, second));
        let third = HostMemoryReservation::new(1);
        assert!(third.others < 150_000 * per_env as u64, "released on drop");
    }
}
