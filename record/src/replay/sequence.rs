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
//! Controls on one component keep their recorded order; controls on different components do
//! not wait for each other (a state set on `wallfollow` after the steps on a scan does not hold
//! up `centerfollow`'s wiring, which live went before its own step on that scan).
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
    /// What it acts on, per control: controls on one thing keep their recorded order, those on
    /// different things do not wait for each other.
    keys: Vec<String>,
    /// Which controls are applied, and how many from the first are (held while applying: a
    /// control applied from inside another does not apply one twice).
    done: Mutex<Done>,
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
            keys: rec.controls.iter().map(|(_, c)| rec.acts_on(c)).collect(),
            done: Mutex::new(Done { applied: vec![false; rec.controls.len()], prefix: 0 }),
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

    /// Applies every control whose place has come, each after the controls recorded before it
    /// on the same thing. Called by the stand-in before and right after each publication, and
    /// whenever an output is captured (`settled` false: a control that goes after the steps on
    /// the publication waits for [`feed`]), and by [`feed`] whenever an output is captured or a
    /// control's time comes, once what is ready to run has run (`settled`).
    ///
    /// Controls on different things commute: a state set on `wallfollow` that waits for the
    /// steps on a scan does not hold up `centerfollow`'s wiring, which live went before its
    /// step on that scan.
    pub(super) fn apply_ready(&self, settled: bool) {
        let Some(mut done) = self.done.try_lock() else { return };
        let cursor = self.playback.cursor.load(Ordering::SeqCst);
        let mut held: Vec<&str> = Vec::new();
        let mut j = done.prefix;
        while j < self.controls.len() && self.after[j] <= cursor {
            if !done.applied[j] {
                let key = self.keys[j].as_str();
                if !held.contains(&key) && (settled || self.early[j]) && self.ready(j) {
                    if let Some(pending) = self.applier.apply(self.controls[j].1.clone()) {
                        now_or_spawn(pending);
                    }
                    done.applied[j] = true;
                } else {
                    held.push(key);
                }
            }
            j += 1;
        }
        let before = done.prefix;
        while done.prefix < self.controls.len() && done.applied[done.prefix] {
            done.prefix += 1;
        }
        if done.prefix > before
            && let Some(order) = &self.playback.order
        {
            order.applied(done.prefix - 1);
        }
    }

    /// The controls not yet applied whose publications are out, in order.
    fn pending(&self) -> Vec<usize> {
        let done = self.done.lock();
        let cursor = self.playback.cursor.load(Ordering::SeqCst);
        (done.prefix..self.controls.len())
            .take_while(|&j| self.after[j] <= cursor)
            .filter(|&j| !done.applied[j])
            .collect()
    }

    /// Whether every control is applied.
    fn finished(&self) -> bool {
        self.done.lock().prefix == self.controls.len()
    }
}

/// Which controls a [`Sequencer`] has applied.
struct Done {
    applied: Vec<bool>,
    /// How many from the first are applied (what the stand-in waits for before a publication).
    prefix: usize,
}

/// Applies the controls whose place comes with an output or with their time (those that come
/// with a publication are applied by the stand-in), until all are.
pub(super) async fn feed(seq: Arc<Sequencer>) {
    loop {
        let pending = seq.pending();
        if pending.iter().any(|&j| !seq.early[j] && seq.ready(j)) {
            // What the publications before it set going runs first (a step on the last one),
            // as it did before the control in the recording; an early control goes before.
            for _ in 0..super::SETTLE_YIELDS {
                tokio::task::yield_now().await;
            }
        }
        seq.apply_ready(true);
        if seq.finished() {
            return;
        }
        // The next time a control's time comes (those whose time has come wait for outputs or
        // publications: they come with `moved`).
        let now = tokio::time::Instant::now();
        let due = seq.pending().into_iter().map(|j| seq.due(j)).filter(|&d| d > now).min();
        tokio::select! {
            () = seq.moved.notified() => {}
            () = tokio::time::sleep_until(due.unwrap_or(now)), if due.is_some() => {}
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
