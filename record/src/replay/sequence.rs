//! Where a live replay applies the controls fed from outside the replayed components (a
//! behaviour's port wired, its state set, the link watchdog's command): at the place the
//! recording has them among the robot's publications and the outputs of what they act on.
//!
//! A live process runs on several threads, so a control can land between a scan going out and
//! a behaviour's step on it: the link watchdog unwires `centerfollow` 0.1 ms after the scan,
//! and the behaviour's step finds its port unwired (`delivered` false). A replay runs on one
//! thread, and a feeder that wakes after the scan runs after the behaviour's step. So each
//! control is applied at the first moment that its recorded time has come (on the replay's
//! timer, which wakes on whole milliseconds), the publications recorded before it are out and
//! the outputs recorded before it of what it acts on (see [`Recording::controls_outputs`])
//! are made: right after a publication, before anything it sets going runs, where the
//! recording says it went before the step on that publication
//! ([`Recording::controls_early`]); else once what the publication set going has run. A
//! control that went before the step is placed by that order alone, without waiting for its
//! time: the recorder logs a change when it hears of it, which on a loaded machine can be
//! milliseconds after the publication the step was on.
//!
//! A paused-clock recording is replayed at its exact instants and does not need this (see
//! [`super::feed_controls`]).
//!
//! [`Recording::controls_outputs`]: super::file::Recording::controls_outputs

use super::file::{Control, Recording};
use super::standin::Playback;
use orsa_actors::{Registry, Timestamp};
use parking_lot::Mutex;
use std::future::Future;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use tokio::sync::Notify;

/// The controls of a live replay, applied in their recorded place.
pub(super) struct Sequencer {
    registry: Registry,
    controls: Vec<(u64, Control)>,
    after: Vec<usize>,
    outputs: Vec<Vec<(Arc<str>, usize)>>,
    /// Whether each goes before the step on the publication before it (applied right after
    /// that publication), or after it (see [`Recording::controls_early`]).
    early: Vec<bool>,
    applier: super::Applier,
    playback: Arc<Playback>,
    /// What the replayed components made so far, per topic.
    made: Arc<Mutex<super::diff::Messages>>,
    /// The next control to apply (held while applying: a control applied from inside another
    /// does not apply the next one twice).
    next: Mutex<usize>,
    /// Woken when an output is captured.
    pub(super) moved: Notify,
}

impl Sequencer {
    /// The sequencer of `rec`'s controls, against what `playback` published and what `made`
    /// holds; `ask` if it makes the requests to parameters (not the stand-in).
    pub(super) fn new(
        registry: Registry,
        rec: &Recording,
        ask: bool,
        playback: Arc<Playback>,
        made: Arc<Mutex<super::diff::Messages>>,
    ) -> Sequencer {
        Sequencer {
            registry: registry.clone(),
            controls: rec.controls.clone(),
            after: rec.controls_after.clone(),
            outputs: rec.controls_outputs.clone(),
            early: if rec.controls_early.len() == rec.controls.len() {
                rec.controls_early.clone()
            } else {
                vec![true; rec.controls.len()]
            },
            applier: super::Applier::new(&registry, &rec.meta.robot, ask),
            playback,
            made,
            next: Mutex::new(0),
            moved: Notify::new(),
        }
    }

    /// When control `j` was recorded, on the replay's timer.
    fn due(&self, j: usize) -> tokio::time::Instant {
        self.registry.clock().instant_of(Timestamp(self.controls[j].0))
    }

    /// Whether control `j`'s place has come. A control that went before the step on the
    /// publication before it (`early`) is placed by that order alone, not by its log time: the
    /// recorder logs a change when it hears of it, which under load can be more than the
    /// timer's millisecond after that publication, though the step came after the change.
    /// Waiting for its time there would let the step run first.
    fn ready(&self, j: usize) -> bool {
        if (!self.early[j] && tokio::time::Instant::now() < self.due(j))
            || self.playback.cursor.load(Ordering::SeqCst) < self.after[j]
        {
            return false;
        }
        let made = self.made.lock();
        self.outputs[j].iter().all(|(topic, n)| made.get(topic).map_or(0, Vec::len) >= *n)
    }

    /// Applies, in order, every control whose place has come. Called by the stand-in before
    /// and right after each publication (`settled` false: a control that goes after the steps
    /// on the publication waits for [`feed`]), and by [`feed`] whenever an output is captured
    /// or a control's time comes, once what is ready to run has run (`settled`).
    pub(super) fn apply_ready(&self, settled: bool) {
        let Some(mut next) = self.next.try_lock() else { return };
        while *next < self.controls.len() && (settled || self.early[*next]) && self.ready(*next) {
            let j = *next;
            let control = self.controls[j].1.clone();
            if let Some(pending) = self.applier.apply(control) {
                now_or_spawn(pending);
            }
            *next += 1;
            if let Some(order) = &self.playback.order {
                order.applied(j);
            }
        }
    }

    /// The next control to apply, if any.
    fn next(&self) -> Option<usize> {
        let next = *self.next.lock();
        (next < self.controls.len()).then_some(next)
    }
}

/// Applies the controls whose place comes with an output or with their time (those that come
/// with a publication are applied by the stand-in), until all are.
pub(super) async fn feed(seq: Arc<Sequencer>) {
    loop {
        if seq.next().is_some_and(|j| !seq.early[j] && seq.ready(j)) {
            // What the publications before it set going runs first (a step on the last one),
            // as it did before the control in the recording; an early control goes before.
            for _ in 0..super::SETTLE_YIELDS {
                tokio::task::yield_now().await;
            }
        }
        seq.apply_ready(true);
        let Some(j) = seq.next() else { return };
        let due = seq.due(j);
        tokio::select! {
            () = seq.moved.notified() => {}
            () = tokio::time::sleep_until(due), if tokio::time::Instant::now() < due => {}
        }
    }
}

/// Runs `fut` at once as far as it goes (a local wiring or state change does not wait), the
/// rest on a task of its own.
fn now_or_spawn(fut: impl Future<Output = ()> + Send + 'static) {
    let mut fut = Box::pin(fut);
    let mut cx = std::task::Context::from_waker(std::task::Waker::noop());
    if fut.as_mut().poll(&mut cx).is_pending() {
        tokio::spawn(fut);
    }
}
