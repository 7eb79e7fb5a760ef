//! orsa's log lines, in one place: the operator's lines of the processes (`robot: up as
//! nomad200`, said with [`say!`](crate::say)) and the warnings and errors logged through
//! `tracing`. They go to stderr, as ever, and to one more destination while one is set
//! ([`route`]): the robot's ROS 2 node sets `/rosout` there, so `ros2 run rqt_console
//! rqt_console` and `ros2 topic echo /rosout` show what the robot's terminal shows.
//!
//! Tracing events reach the destination through [`RouteLayer`], which the `orsa` binary
//! installs beside its stderr formatter. What the destination does while it handles a line
//! (zenoh logging about the put, say) goes to stderr only: a line never loops back into it.

use parking_lot::RwLock;
use std::cell::Cell;
use std::sync::Arc;
use tracing::Level;

/// One log line, for a destination.
#[derive(Debug, Clone, Copy)]
pub struct Line<'a> {
    /// Its level.
    pub level: Level,
    /// Who says it: the process (`robot`) for an operator's line, the module for a tracing event.
    pub logger: &'a str,
    /// The text.
    pub text: &'a str,
    /// The source file.
    pub file: &'a str,
    /// The source line.
    pub line: u32,
    /// The module.
    pub module: &'a str,
}

type Destination = Arc<dyn Fn(&Line<'_>) + Send + Sync>;

static DESTINATION: RwLock<Option<Destination>> = RwLock::new(None);

thread_local! {
    static SENDING: Cell<bool> = const { Cell::new(false) };
}

/// Sends every line to `to` (besides stderr) until the returned guard is dropped; the latest
/// route wins.
#[must_use = "the route ends when the guard is dropped"]
pub fn route(to: impl Fn(&Line<'_>) + Send + Sync + 'static) -> RouteGuard {
    let to: Destination = Arc::new(to);
    *DESTINATION.write() = Some(Arc::clone(&to));
    RouteGuard(to)
}

/// Ends its route when dropped (unless another route replaced it).
pub struct RouteGuard(Destination);

impl std::fmt::Debug for RouteGuard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("RouteGuard")
    }
}

impl Drop for RouteGuard {
    fn drop(&mut self) {
        let mut d = DESTINATION.write();
        if d.as_ref().is_some_and(|d| Arc::ptr_eq(d, &self.0)) {
            *d = None;
        }
    }
}

/// Whether a route is set (cheap: a tracing event costs nothing more without one).
fn routed() -> bool {
    DESTINATION.read().is_some()
}

/// Hands `line` to the route, if there is one and this thread is not already handing one.
pub fn forward(line: &Line<'_>) {
    if SENDING.with(Cell::get) {
        return;
    }
    let Some(to) = DESTINATION.read().clone() else { return };
    SENDING.with(|s| s.set(true));
    to(line);
    SENDING.with(|s| s.set(false));
}

/// An operator's line: `who: text` on stderr, and to the route at info level. Use [`say!`](crate::say).
pub fn operator(who: &str, text: std::fmt::Arguments<'_>, file: &str, line: u32, module: &str) {
    let text = text.to_string();
    eprintln!("{who}: {text}");
    forward(&Line { level: Level::INFO, logger: who, text: &text, file, line, module });
}

/// Says an operator's line: `say!("robot", "up as {name}")` prints `robot: up as nomad200` on
/// stderr and sends it to the route (`/rosout`) as an info line of logger `robot`.
#[macro_export]
macro_rules! say {
    ($who:expr, $($arg:tt)*) => {
        $crate::logline::operator($who, format_args!($($arg)*), file!(), line!(), module_path!())
    };
}

/// The tracing layer that sends the events it is given to the route (filter it: the `orsa`
/// binary gives it warnings and errors).
#[derive(Debug, Clone, Copy, Default)]
pub struct RouteLayer;

impl<S: tracing::Subscriber> tracing_subscriber::Layer<S> for RouteLayer {
    fn on_event(&self, event: &tracing::Event<'_>, _ctx: tracing_subscriber::layer::Context<'_, S>) {
        if !routed() {
            return;
        }
        let mut text = Text::default();
        event.record(&mut text);
        let meta = event.metadata();
        forward(&Line {
            level: *meta.level(),
            logger: meta.target(),
            text: &text.0,
            file: meta.file().unwrap_or_default(),
            line: meta.line().unwrap_or(0),
            module: meta.module_path().unwrap_or_default(),
        });
    }
}

/// An event's message, then its other fields as `name=value`.
#[derive(Default)]
struct Text(String);

impl tracing::field::Visit for Text {
    fn record_debug(&mut self, field: &tracing::field::Field, value: &dyn std::fmt::Debug) {
        use std::fmt::Write as _;
        if field.name() == "message" {
            let fields = std::mem::take(&mut self.0);
            let _ = write!(self.0, "{value:?}{}{fields}", if fields.is_empty() { "" } else { " " });
        } else {
            let sep = if self.0.is_empty() { "" } else { " " };
            let _ = write!(self.0, "{sep}{}={value:?}", field.name());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tracing_subscriber::layer::SubscriberExt as _;

    /// Operator lines and tracing events reach the route with their level and logger; what
    /// the route logs while it handles a line does not come back to it; a dropped route gets
    /// nothing more.
    #[test]
    fn lines_reach_the_route_once_and_stop_with_it() {
        let got = Arc::new(parking_lot::Mutex::new(Vec::new()));
        let sink = Arc::clone(&got);
        let subscriber = tracing_subscriber::registry().with(RouteLayer);
        tracing::subscriber::with_default(subscriber, || {
            let guard = route(move |l: &Line<'_>| {
                sink.lock().push((l.level, l.logger.to_string(), l.text.to_string()));
                tracing::warn!("the route logs while it sends");
            });
            crate::say!("robot", "up as {}", "nomad200");
            tracing::warn!(component = "wallfollow", "input stale");
            drop(guard);
            crate::say!("robot", "not routed");
        });
        let got = got.lock();
        assert_eq!(got.len(), 2, "{got:?}");
        assert_eq!(got[0], (Level::INFO, "robot".into(), "up as nomad200".into()));
        assert_eq!(got[1].0, Level::WARN);
        assert_eq!(got[1].2, "input stale component=\"wallfollow\"");
    }
}
