//! The host's copy of the published state, read back from the GPU only when someone looks at
//! it after a step: a step submits its kernel and returns, so steps that nobody reads in
//! between cost no transfer and no wait.

use std::cell::UnsafeCell;
use std::sync::OnceLock;

use glam::Vec4;

/// A buffer that is either current or refreshed (once) by the first reader after
/// [`invalidate`](Self::invalidate).
pub struct HostMirror {
    /// Set once the data is current.
    current: OnceLock<()>,
    data: UnsafeCell<Vec<Vec4>>,
}

// SAFETY: `data` is written only by the closure that `current.get_or_init` runs, which runs
// at most once between two `invalidate` calls and completes before any reader receives a
// reference (`get_or_init` returns only then, with a happens-before edge to every reader);
// `invalidate` and `get_mut` take `&mut self`, so no shared reference outlives a write.
unsafe impl Sync for HostMirror {}

impl HostMirror {
    /// `len` zeroed entries, current.
    pub fn new(len: usize) -> Self {
        let current = OnceLock::new();
        current.set(()).expect("a new OnceLock is empty");
        Self {
            current,
            data: UnsafeCell::new(vec![Vec4::ZERO; len]),
        }
    }

    /// The data, first refreshed by `refresh` if it is not current.
    pub fn get(&self, refresh: impl FnOnce(&mut [Vec4])) -> &[Vec4] {
        self.current.get_or_init(|| {
            // SAFETY: see the `Sync` impl: this is the only writer, and no reader exists yet.
            refresh(unsafe { &mut *self.data.get() })
        });
        // SAFETY: the data is current and only written again after `invalidate(&mut self)`.
        unsafe { &*self.data.get() }
    }

    /// Mutable access for host-side writes; the caller has made the data current first.
    pub fn get_mut(&mut self) -> &mut [Vec4] {
        self.data.get_mut()
    }

    /// Whether the data is current (no refresh pending).
    pub fn is_current(&self) -> bool {
        self.current.get().is_some()
    }

    /// The GPU state changed: the next reader refreshes.
    pub fn invalidate(&mut self) {
        self.current = OnceLock::new();
    }
}
