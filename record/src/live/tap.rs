//! The control loop's side of the live view: a tap that never waits.
//!
//! [`LiveTap::record`] keeps only what the views are made from (the robot server's scans and
//! odometry, the master's `driving`, wiring, state, supervisor and link events; see
//! `ViewSetup::input_of`), and skips the scans and the odometry while no client subscribes to
//! anything (nor are they serialised: [`Tap::wants`] says no), and hands over one truth
//! sample every 2 s only while nobody watches. What it keeps goes to the views' thread through
//! a queue of [`QUEUED`] items, which that thread empties every [`POLL`] (the control loop
//! never wakes it); when the queue is full the item is dropped and counted (the first drop is
//! logged), so a slow viewer never slows the run. The views' thread makes the views with the
//! recording's code (`Views`) and writes them to the server's channels ([`LiveSink`]).

use super::Shared;
use super::sink::LiveSink;
use crate::record::views::{Input, TRAJECTORY_PERIOD_NS, TruthSample, ViewSetup, ViewSink, Views};
use orsa_actors::Timestamp;
use orsa_actors::supervision::SupervisorEvent;
use orsa_actors::tap::Tap;
use parking_lot::Mutex;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::sync::mpsc;

/// Items waiting for the views' thread at most (a few seconds of a run's views in real time).
pub const QUEUED: usize = 1024;

/// What the views' thread is handed.
enum Item {
    /// A message on a topic the views are made from.
    Message { input: Input, topic: String, at: Timestamp, json: Vec<u8> },
    /// A ground-truth sample.
    Truth(TruthSample),
}

/// Hands what the views are made from to their thread.
pub struct LiveTap {
    setup: ViewSetup,
    shared: Arc<Shared>,
    /// `None` once finished.
    queue: Mutex<Option<mpsc::SyncSender<Item>>>,
    thread: Mutex<Option<std::thread::JoinHandle<u64>>>,
    handed: std::sync::atomic::AtomicU64,
    /// When the last truth sample was handed, ns (`u64::MAX`: none yet).
    last_truth_ns: std::sync::atomic::AtomicU64,
}

impl std::fmt::Debug for LiveTap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LiveTap").field("robot", &self.setup.robot).finish()
    }
}

impl LiveTap {
    /// Starts the views' thread, writing to channels of `context`.
    pub(crate) fn start(
        setup: ViewSetup,
        context: Arc<foxglove::Context>,
        shared: Arc<Shared>,
    ) -> std::io::Result<LiveTap> {
        let (tx, rx) = mpsc::sync_channel(QUEUED);
        let views = Views::new(setup.clone());
        let mut sink = LiveSink::new(context);
        if let Err(e) = views.declare(&mut sink) {
            tracing::warn!("{e}");
        }
        let thread_shared = Arc::clone(&shared);
        let thread = std::thread::Builder::new()
            .name("orsa-live-views".into())
            .spawn(move || serve(views, sink, &thread_shared, rx))?;
        Ok(LiveTap {
            setup,
            shared,
            queue: Mutex::new(Some(tx)),
            thread: Mutex::new(Some(thread)),
            handed: Default::default(),
            last_truth_ns: std::sync::atomic::AtomicU64::new(u64::MAX),
        })
    }

    fn hand(&self, item: Item) {
        let queue = self.queue.lock();
        let Some(queue) = queue.as_ref() else { return };
        match queue.try_send(item) {
            Ok(()) => {
                self.handed.fetch_add(1, Ordering::Relaxed);
            }
            Err(mpsc::TrySendError::Full(_)) => {
                self.shared.dropped.fetch_add(1, Ordering::Relaxed);
                if !self.shared.warned.swap(true, Ordering::Relaxed) {
                    tracing::warn!(
                        "live view: the views' queue is full ({QUEUED} items): dropping what the viewer is too slow for (counted)"
                    );
                }
            }
            // The views' thread ended (it logged why).
            Err(mpsc::TrySendError::Disconnected(_)) => {}
        }
    }

    /// Hands the views a ground-truth sample; while nobody watches, one every
    /// [`TRAJECTORY_PERIOD_NS`] only (what the path keeps).
    pub fn truth(&self, sample: TruthSample) {
        let ns = sample.at.as_nanos();
        if self.shared.subscriptions.load(Ordering::Acquire) == 0 {
            let last = self.last_truth_ns.load(Ordering::Relaxed);
            if last != u64::MAX && ns < last.saturating_add(TRAJECTORY_PERIOD_NS) {
                return;
            }
        }
        self.last_truth_ns.store(ns, Ordering::Relaxed);
        self.hand(Item::Truth(sample));
    }

    /// Hands the views a supervisor's event (on `/events`).
    pub fn supervisor_event(&self, e: &SupervisorEvent) {
        self.note(crate::record::events::SUPERVISION_EVENTS, e.at, e);
    }

    /// Hands the views a control event that is not a pattern message, on `topic`, if the
    /// views make something of it.
    pub fn note<T: serde::Serialize + ?Sized>(&self, topic: &str, at: Timestamp, value: &T) {
        let Some(input) = self.setup.input_of(topic) else { return };
        match serde_json::to_vec(value) {
            Ok(json) => self.hand(Item::Message { input, topic: topic.to_owned(), at, json }),
            Err(e) => tracing::warn!("live view: an event on {topic} does not serialise: {e}"),
        }
    }

    /// Stops the views' thread once it has made the views of what it was handed.
    pub(crate) fn finish(&self) -> super::LiveSummary {
        self.queue.lock().take();
        if let Some(thread) = self.thread.lock().take()
            && thread.join().is_err()
        {
            tracing::error!("live view: the views' thread panicked");
        }
        super::LiveSummary {
            handed: self.handed.load(Ordering::Relaxed),
            dropped: self.shared.dropped.load(Ordering::Relaxed),
            published: None,
        }
    }
}

impl LiveTap {
    /// What a message on `topic` is to the views, if they want it now: scans and odometry are
    /// made into nothing but messages, none needed while nobody looks (driving and events
    /// change what the robot is drawn as: always wanted).
    fn wanted(&self, topic: &str) -> Option<Input> {
        let input = self.setup.input_of(topic)?;
        let watched = self.shared.subscriptions.load(Ordering::Acquire) > 0;
        (watched || !matches!(input, Input::Infrared | Input::Sonar | Input::Base)).then_some(input)
    }
}

impl LiveTap {
    /// A component of this process changed a parameter (`json` is its
    /// [`ParamChange`](orsa_actors::param::ParamChange), on `component/params`): its new value
    /// goes to the clients subscribed to it, by its full name (`component.name`).
    fn param_changed(&self, topic: &str, json: &[u8]) {
        let Some(component) = topic.strip_suffix(PARAM_CHANGES) else { return };
        match serde_json::from_slice::<orsa_actors::param::ParamChange>(json) {
            Ok(change) => {
                let name = format!("{component}.{}", change.name);
                self.shared.publish_parameters(vec![super::params::to_parameter(name, &change.new)]);
            }
            Err(e) => tracing::warn!("live view: a parameter change on {topic} does not read: {e}"),
        }
    }
}

/// The end of the topic of a component's parameter changes (`wallfollow/params`).
const PARAM_CHANGES: &str = "/params";

impl Tap for LiveTap {
    fn record(&self, topic: &str, type_id: &str, stamp: Timestamp, json: &[u8]) {
        if type_id == <orsa_actors::param::ParamChange as orsa_actors::CommObject>::ID {
            return self.param_changed(topic, json);
        }
        let Some(input) = self.wanted(topic) else { return };
        self.hand(Item::Message { input, topic: topic.to_owned(), at: stamp, json: json.to_vec() });
    }

    fn wants(&self, topic: &str) -> bool {
        self.wanted(topic).is_some() || topic.ends_with(PARAM_CHANGES)
    }

    /// Messages from another process are not made into views (as in a recording).
    fn record_remote(&self, _topic: &str, _type_id: &str, _stamp: Timestamp, _json: &[u8]) {}
}

/// How often the views' thread takes what was queued. It is never woken by the control loop
/// (a wake-up at each message put the views' thread, the server's and its clients' on the
/// CPU at the moment the control loop delivers that message: sense to act's p50 tripled on a
/// loaded 2-core machine); a viewer sees the views at most this much later.
pub const POLL: std::time::Duration = std::time::Duration::from_millis(20);

/// The views' thread: every item, in order, until the queue closes; how many messages it sent.
fn serve(mut views: Views, mut sink: LiveSink, shared: &Shared, queue: mpsc::Receiver<Item>) -> u64 {
    let mut warned = false;
    let mut last = Timestamp::ZERO;
    loop {
        std::thread::sleep(POLL);
        let (open, done) = take(&mut views, &mut sink, shared, &queue, &mut last);
        if let Err(e) = done
            && !std::mem::replace(&mut warned, true)
        {
            tracing::warn!("{e} (further errors of the live view are not logged)");
        }
        if !open {
            return sink.sent;
        }
    }
}

/// One poll of the views' thread: what a subscription asked to be written again, then every
/// item queued, in order; whether the queue is still open. `last` is the newest time the views
/// were given: the latched views written again are stamped with it, on the system's time base.
/// Until the first item comes (a robot hands nothing but its health and events while nobody
/// watches) there is no such time, and they wait for it rather than go out stamped 1970.
fn take<S: ViewSink>(
    views: &mut Views,
    sink: &mut S,
    shared: &Shared,
    queue: &mpsc::Receiver<Item>,
    last: &mut Timestamp,
) -> (bool, Result<(), S::Error>) {
    let mut done = Ok(());
    if *last > Timestamp::ZERO && shared.rewrite.swap(false, Ordering::AcqRel) {
        done = views.rewrite_latched(sink, *last);
    }
    while done.is_ok() {
        let item = match queue.try_recv() {
            Ok(item) => item,
            Err(mpsc::TryRecvError::Empty) => break,
            Err(mpsc::TryRecvError::Disconnected) => return (false, done),
        };
        done = match &item {
            Item::Message { input, topic, at, json } => {
                *last = (*last).max(*at);
                views.message(sink, *input, topic, *at, json)
            }
            Item::Truth(sample) => {
                *last = (*last).max(sample.at);
                views.truth(sink, sample)
            }
        };
        if done.is_ok() && *last > Timestamp::ZERO && shared.rewrite.swap(false, Ordering::AcqRel) {
            done = views.rewrite_latched(sink, *last);
        }
    }
    (true, done)
}

/// A tap that hands every message to two taps (a recording's and a live view's).
pub struct Both(pub Arc<dyn Tap>, pub Arc<dyn Tap>);

impl Tap for Both {
    fn record(&self, topic: &str, type_id: &str, stamp: Timestamp, json: &[u8]) {
        for tap in [&self.0, &self.1] {
            if tap.wants(topic) {
                tap.record(topic, type_id, stamp, json);
            }
        }
    }

    fn record_remote(&self, topic: &str, type_id: &str, stamp: Timestamp, json: &[u8]) {
        for tap in [&self.0, &self.1] {
            if tap.wants(topic) {
                tap.record_remote(topic, type_id, stamp, json);
            }
        }
    }

    fn wants(&self, topic: &str) -> bool {
        self.0.wants(topic) || self.1.wants(topic)
    }
}

/// The tap to install for a recording and a live view, either, both or neither.
pub fn both(a: Option<Arc<dyn Tap>>, b: Option<Arc<dyn Tap>>) -> Option<Arc<dyn Tap>> {
    match (a, b) {
        (Some(a), Some(b)) => Some(Arc::new(Both(a, b))),
        (a, b) => a.or(b),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::views::{DRIVING_TOPIC, MAP_TOPIC, ROBOT_TOPIC, TRAJECTORY_TOPIC, WORLD_TOPIC};

    /// Remembers the topics declared and written.
    #[derive(Default)]
    struct Topics {
        declared: Vec<String>,
        written: Vec<String>,
        /// The log time of each written.
        stamps: Vec<Timestamp>,
    }

    impl ViewSink for Topics {
        type Error = std::convert::Infallible;

        fn view<T: foxglove::Encode>(
            &mut self,
            topic: &str,
            at: Timestamp,
            _msg: &T,
        ) -> Result<(), Self::Error> {
            self.written.push(topic.to_owned());
            self.stamps.push(at);
            Ok(())
        }

        fn declare<T: foxglove::Encode>(&mut self, topic: &str) -> Result<(), Self::Error> {
            self.declared.push(topic.to_owned());
            Ok(())
        }
    }

    fn setup(world: bool, truth: bool) -> ViewSetup {
        let config = crate::config::Config::default();
        let world = world.then(|| orsa_hardware::world::World::palazzina().expect("the built-in world"));
        crate::recording::view_setup(&config, world, truth)
    }

    #[test]
    fn each_process_declares_the_channels_it_can_fill() {
        let mut run = Topics::default();
        Views::new(setup(true, true)).declare(&mut run).expect("declared");
        assert_eq!(run.declared.len(), 12, "{:?}", run.declared);
        let mut executive = Topics::default();
        Views::new(setup(false, false)).declare(&mut executive).expect("declared");
        assert_eq!(executive.declared, ["/robot", "/driving", "/events"]);
    }

    #[test]
    fn a_late_subscriber_gets_the_world_the_robot_who_drives_and_the_path_again() {
        let mut views = Views::new(setup(true, true));
        let mut sink = Topics::default();
        let at = Timestamp::from_secs_f64(1.0);
        let change = orsa_actors::Stamped {
            seq: 1,
            sent_at: at,
            value: orsa_interfaces::executive::WiringChange {
                stamp: at,
                driving: Some("wallfollow".into()),
                mode: None,
            },
        };
        let json = serde_json::to_vec(&change).expect("json");
        views.message(&mut sink, Input::Driving, "master/driving", at, &json).expect("written");
        let sample = TruthSample { at, x_m: 1.0, y_m: 2.0, heading_rad: 0.0, people: Vec::new() };
        views.truth(&mut sink, &sample).expect("written");
        sink.written.clear();
        views.rewrite_latched(&mut sink, at).expect("written again");
        assert_eq!(sink.written, [WORLD_TOPIC, MAP_TOPIC, ROBOT_TOPIC, DRIVING_TOPIC, TRAJECTORY_TOPIC]);
    }

    #[test]
    fn latched_views_asked_for_before_any_time_is_known_wait_for_it() {
        let mut views = Views::new(setup(true, false));
        let mut sink = Topics::default();
        let shared = Shared::default();
        let (tx, rx) = mpsc::sync_channel(4);
        let mut last = Timestamp::ZERO;
        // A client subscribes before the robot handed anything: nothing goes out at time zero.
        shared.rewrite.store(true, Ordering::Release);
        let (open, done) = take(&mut views, &mut sink, &shared, &rx, &mut last);
        assert!(open && done.is_ok());
        assert!(sink.written.is_empty(), "{:?}", sink.written);
        assert!(shared.rewrite.load(Ordering::Acquire), "still asked for");
        // The first item gives the time: the latched views go out stamped with it.
        let at = Timestamp::from_secs_f64(1_795_000_000.5);
        let change = orsa_actors::Stamped {
            seq: 1,
            sent_at: at,
            value: orsa_interfaces::executive::WiringChange { stamp: at, driving: None, mode: None },
        };
        let json = serde_json::to_vec(&change).expect("json");
        tx.send(Item::Message { input: Input::Driving, topic: "master/driving".into(), at, json })
            .expect("queued");
        let (open, done) = take(&mut views, &mut sink, &shared, &rx, &mut last);
        assert!(open && done.is_ok());
        assert!(
            sink.written.iter().any(|t| t == WORLD_TOPIC) && sink.written.iter().any(|t| t == ROBOT_TOPIC)
        );
        assert!(sink.stamps.iter().all(|&t| t == at), "{:?}", sink.stamps);
        assert!(!shared.rewrite.load(Ordering::Acquire));
        drop(tx);
        assert!(!take(&mut views, &mut sink, &shared, &rx, &mut last).0, "the queue closed");
    }

    #[test]
    fn the_tap_keeps_only_what_the_views_are_made_from_and_scans_only_while_watched() {
        let shared = Arc::new(Shared::default());
        let tap = LiveTap::start(setup(true, false), foxglove::Context::new(), Arc::clone(&shared))
            .expect("started");
        let at = Timestamp::ZERO;
        assert!(!tap.wants("nomad200/distanceir") && !tap.wants("nomad200/bumpers"));
        assert!(tap.wants("master/driving") && tap.wants("wallfollow/state"));
        tap.record("nomad200/distanceir", "t", at, b"{}");
        tap.record("nomad200/bumpers", "t", at, b"{}");
        tap.record_remote("master/driving", "t", at, b"{}");
        assert_eq!(tap.handed.load(Ordering::Relaxed), 0);
        // Unwatched, one truth sample in 2 s.
        for i in 0..30 {
            let at = Timestamp::from_secs_f64(f64::from(i) * 0.1);
            tap.truth(TruthSample { at, x_m: 0.0, y_m: 0.0, heading_rad: 0.0, people: Vec::new() });
        }
        assert_eq!(tap.handed.load(Ordering::Relaxed), 2);
        shared.subscriptions.store(1, Ordering::Release);
        assert!(tap.wants("nomad200/distanceir"));
        tap.record("nomad200/distanceir", "t", at, b"{}");
        tap.record("wallfollow/state", "t", at, b"{}");
        let summary = tap.finish();
        assert_eq!((summary.handed, summary.dropped), (4, 0));
    }
}
