//! What the streaming commands share: an optional progress callback carried in their job or
//! options, so that each command is one function whether or not a bar is drawn.

use std::fmt;

/// An optional callback told how far a run has come (`T`: points or pulses done since the last
/// call, or a step of a longer run), from any thread. The default tells nobody.
///
/// ```
/// use lidarqa_io::Progress;
/// use std::sync::atomic::{AtomicU64, Ordering};
///
/// let done = AtomicU64::new(0);
/// let count = |n: u64| {
///     done.fetch_add(n, Ordering::Relaxed);
/// };
/// let progress = Progress::new(&count);
/// progress.report(3);
/// progress.report(4);
/// Progress::<u64>::default().report(100);
/// assert_eq!(done.load(Ordering::Relaxed), 7);
/// ```
pub struct Progress<'a, T = u64>(Option<&'a (dyn Fn(T) + Sync)>);

impl<'a, T> Progress<'a, T> {
    /// Tells nobody.
    pub const NONE: Self = Progress(None);

    /// Calls `callback` on each report.
    pub fn new(callback: &'a (dyn Fn(T) + Sync)) -> Self {
        Progress(Some(callback))
    }

    /// Hands `value` to the callback, if there is one.
    pub fn report(&self, value: T) {
        if let Some(f) = self.0 {
            f(value);
        }
    }
}

impl<T> Clone for Progress<'_, T> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<T> Copy for Progress<'_, T> {}

impl<T> Default for Progress<'_, T> {
    fn default() -> Self {
        Progress::NONE
    }
}

impl<T> fmt::Debug for Progress<'_, T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(if self.0.is_some() {
            "Progress(callback)"
        } else {
            "Progress(none)"
        })
    }
}
