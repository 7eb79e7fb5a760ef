//! Comparing a replay with its recording: the first divergence (a replay must be bit for bit),
//! and, for a what-if, how much and where the replayed messages differ.

use super::file::Recorded;
use orsa_actors::Timestamp;
use orsa_interfaces::executive::WiringChange;
use serde::Serialize;
use std::collections::BTreeMap;
use std::sync::Arc;

/// Messages per topic, in order.
pub type Messages = BTreeMap<Arc<str>, Vec<Recorded>>;

/// How a replay's instants are held to the recording's.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Timing {
    /// A recording made on a paused clock: every message at its recorded instant, every byte
    /// the same.
    Exact,
    /// A recording made live: every message in its recorded order, logged at most this many
    /// ns from its recorded log time, with the same content but for its readings of the live
    /// clock (every field named `stamp`, `stamp_ns` or `at`), which no replay reproduces to
    /// the nanosecond and which are held to the same tolerance. The last `tolerance` of the
    /// recording is left out: what the live process made in it may lie past the recording's
    /// end.
    Within(u64),
}

impl Timing {
    fn tolerance(self) -> u64 {
        match self {
            Timing::Exact => 0,
            Timing::Within(t) => t,
        }
    }

    /// The end of what is compared, for a recording whose last message is at `end`.
    pub fn cut(self, end: u64) -> u64 {
        end.saturating_sub(self.tolerance())
    }

    /// Whether two messages are the same, sequence numbers aside if `ignore_seq`.
    fn same(self, x: &Recorded, y: &Recorded, ignore_seq: bool) -> bool {
        if x.data == y.data {
            return true;
        }
        if self == Timing::Exact && !ignore_seq {
            return false;
        }
        let parse = |r: &Recorded| serde_json::from_slice::<serde_json::Value>(&r.data).ok();
        match (parse(x), parse(y)) {
            (Some(mut p), Some(mut q)) => {
                if ignore_seq {
                    for v in [&mut p, &mut q] {
                        if let serde_json::Value::Object(o) = v {
                            o.remove("seq");
                        }
                    }
                }
                equal_within(&p, &q, false, self.tolerance())
            }
            _ => false,
        }
    }
}

/// Whether a field of this name holds a reading of the clock.
fn is_clock_reading(key: &str) -> bool {
    matches!(key, "stamp" | "stamp_ns" | "at")
}

/// Whether two JSON values are equal, clock readings (when `clock`) within `tolerance` ns.
fn equal_within(a: &serde_json::Value, b: &serde_json::Value, clock: bool, tolerance: u64) -> bool {
    use serde_json::Value;
    match (a, b) {
        (Value::Number(x), Value::Number(y)) if clock && tolerance > 0 => match (x.as_u64(), y.as_u64()) {
            (Some(x), Some(y)) => x.abs_diff(y) <= tolerance,
            _ => x == y,
        },
        (Value::Object(x), Value::Object(y)) => {
            x.len() == y.len()
                && x.iter().all(|(k, v)| {
                    y.get(k).is_some_and(|w| equal_within(v, w, is_clock_reading(k), tolerance))
                })
        }
        (Value::Array(x), Value::Array(y)) => {
            x.len() == y.len() && x.iter().zip(y).all(|(v, w)| equal_within(v, w, false, tolerance))
        }
        _ => a == b,
    }
}

/// Where a replay first parted from its recording.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Divergence {
    /// The log time of the first message that differs (or is missing on one side), s.
    pub at_s: f64,
    /// Its topic.
    pub topic: String,
    /// Its index among the topic's messages (from 0).
    pub index: usize,
    /// The recorded message (JSON), if the recording has one there.
    pub recorded: Option<String>,
    /// The replayed message (JSON), if the replay made one there.
    pub replayed: Option<String>,
}

/// The messages of `m` on `topic` logged before `end` (ns).
fn window<'a>(m: &'a Messages, topic: &str, end: u64) -> &'a [Recorded] {
    let all = m.get(topic).map(Vec::as_slice).unwrap_or_default();
    &all[..all.partition_point(|r| r.log_time < end)]
}

/// Every topic on either side.
fn topics<'a>(a: &'a Messages, b: &'a Messages) -> std::collections::BTreeSet<&'a str> {
    a.keys().chain(b.keys()).map(|t| &**t).collect()
}

fn text(r: &Recorded) -> String {
    String::from_utf8_lossy(&r.data).into_owned()
}

/// The first message, by log time, where `replayed` differs from `recorded` before
/// `timing.cut(end)` (ns): a different log time or different bytes (as `timing` says), or a
/// message one side has and the other has not. With it, the largest offset between a
/// replayed message's log time and its recorded one (ns). Times in seconds are since `origin`
/// (the recording clock's first stamp, ns).
pub fn first_divergence(
    recorded: &Messages,
    replayed: &Messages,
    origin: u64,
    end: u64,
    timing: Timing,
) -> (Option<Divergence>, u64) {
    let (cut, tolerance) = (timing.cut(end), timing.tolerance());
    let mut first: Option<(u64, Divergence)> = None;
    let mut largest = 0u64;
    for topic in topics(recorded, replayed) {
        // The recorded messages before the cut are compared; each may be answered by a
        // replayed one up to the end, as a message recorded just before the cut may be
        // replayed just after it (live, the two sides' log times differ by up to the
        // tolerance). Cutting both sides at the same instant made the last such message
        // missing: a recording ended by Ctrl-C or a lost peer parted at its last instants.
        let (a, b) = (window(recorded, topic, cut), window(replayed, topic, end));
        let differs = |i: usize| match (a.get(i), b.get(i)) {
            (Some(x), Some(y)) => x.log_time.abs_diff(y.log_time) > tolerance || !timing.same(x, y, false),
            (Some(_), None) => true,
            // A replayed message the recording has not: unless its recorded counterpart may
            // lie past the cut (a live process logs a little after the replay does).
            (None, Some(y)) => timing == Timing::Exact || y.log_time.saturating_add(tolerance) < cut,
            (None, None) => false,
        };
        let found = (0..a.len().max(b.len())).find(|&i| differs(i));
        let paired = found.unwrap_or(a.len().min(b.len())).min(a.len().min(b.len()));
        for (x, y) in a[..paired].iter().zip(&b[..paired]) {
            largest = largest.max(x.log_time.abs_diff(y.log_time));
        }
        let Some(i) = found else { continue };
        let at = match (a.get(i), b.get(i)) {
            (Some(x), Some(y)) => x.log_time.min(y.log_time),
            (Some(x), None) | (None, Some(x)) => x.log_time,
            (None, None) => continue,
        };
        if first.as_ref().is_none_or(|(t, _)| at < *t) {
            let d = Divergence {
                at_s: Timestamp(at.saturating_sub(origin)).as_secs_f64(),
                topic: topic.to_string(),
                index: i,
                recorded: a.get(i).map(text),
                replayed: b.get(i).map(text),
            };
            first = Some((at, d));
        }
    }
    (first.map(|(_, d)| d), largest)
}

/// How one topic's messages differ in a what-if.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct TopicDiff {
    /// Recorded messages (before the end).
    pub recorded: usize,
    /// Replayed messages (before the end).
    pub replayed: usize,
    /// Messages that differ: paired by log time, those whose contents differ (sequence numbers
    /// aside), and each that has no counterpart at its instant on the other side.
    pub differing: usize,
    /// When they first part, s (none if they never do).
    pub first_part_s: Option<f64>,
    /// The largest difference of each numeric field that differs, by its path in the message
    /// (`value.cmd.v_m_s`).
    pub largest: BTreeMap<String, f64>,
}

/// What a what-if changed.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct WhatIf {
    /// Per topic that has a difference.
    pub topics: BTreeMap<String, TopicDiff>,
    /// Topics compared.
    pub compared_topics: usize,
    /// Share of time each behaviour drove, recorded.
    pub share_recorded: BTreeMap<String, f64>,
    /// Share of time each behaviour drove, replayed.
    pub share_replayed: BTreeMap<String, f64>,
    /// The stretches `(from_s, to_s)` in which another behaviour drives in the what-if.
    pub wiring_differs_s: Vec<(f64, f64)>,
}

/// Compares a what-if replay with its recording from `origin` to `timing.cut(end)` (ns; times
/// in seconds are since `origin`); `driving` is the topic of the master's `driving` pushes (the
/// behaviour share comes from them).
pub fn what_if(
    recorded: &Messages,
    replayed: &Messages,
    origin: u64,
    end: u64,
    driving: &str,
    timing: Timing,
) -> WhatIf {
    let mut out = WhatIf::default();
    let full_end = end;
    let end = timing.cut(end);
    for topic in topics(recorded, replayed) {
        out.compared_topics += 1;
        // As in `first_divergence`, a recorded message before the cut may be answered after
        // it: the replayed messages past the cut count as far as they pair with recorded ones.
        let a = window(recorded, topic, end);
        let (before, all) = (window(replayed, topic, end), window(replayed, topic, full_end));
        let b = &all[..all.len().min(a.len().max(before.len()))];
        let mut d = TopicDiff { recorded: a.len(), replayed: b.len(), ..TopicDiff::default() };
        for (x, y) in paired(a, b, timing.tolerance()) {
            if let (Some(x), Some(y)) = (x, y)
                && timing.same(x, y, true)
            {
                continue;
            }
            d.differing += 1;
            if d.first_part_s.is_none() {
                let at = x.into_iter().chain(y).map(|r| r.log_time).min().unwrap_or(0);
                d.first_part_s = Some(Timestamp(at.saturating_sub(origin)).as_secs_f64());
            }
            if let (Some(x), Some(y)) = (x, y) {
                numeric_differences(&x.data, &y.data, &mut d.largest);
                if timing != Timing::Exact {
                    d.largest.retain(|path, _| !path.rsplit('.').next().is_some_and(is_clock_reading));
                }
            }
        }
        if d.differing > 0 {
            out.topics.insert(topic.to_string(), d);
        }
    }
    let (ra, rb) = (drives(window(recorded, driving, end), end), drives(window(replayed, driving, end), end));
    out.share_recorded = share(&ra, origin, end);
    out.share_replayed = share(&rb, origin, end);
    // On a live recording, the moments of a rewiring are as far apart as the tolerance allows.
    let shortest = timing.tolerance() as f64 / 1e9;
    out.wiring_differs_s = differing(&ra, &rb, origin, end);
    out.wiring_differs_s.retain(|(from, to)| to - from > shortest);
    out
}

/// The messages of both sides paired by log time (within `tolerance` ns): those of one
/// instant in order, and a message the other side has no counterpart for at that instant
/// alone. (Pairing by index would let one extra message make every later one look different.)
fn paired<'a>(
    a: &'a [Recorded],
    b: &'a [Recorded],
    tolerance: u64,
) -> Vec<(Option<&'a Recorded>, Option<&'a Recorded>)> {
    let (mut i, mut j, mut out) = (0, 0, Vec::with_capacity(a.len().max(b.len())));
    while i < a.len() || j < b.len() {
        match (a.get(i), b.get(j)) {
            (Some(x), Some(y)) if x.log_time.abs_diff(y.log_time) <= tolerance => {
                out.push((Some(x), Some(y)));
                (i, j) = (i + 1, j + 1);
            }
            (Some(x), Some(y)) if x.log_time < y.log_time => {
                out.push((Some(x), None));
                i += 1;
            }
            (Some(x), None) => {
                out.push((Some(x), None));
                i += 1;
            }
            (_, Some(y)) => {
                out.push((None, Some(y)));
                j += 1;
            }
            (None, None) => break,
        }
    }
    out
}

/// The largest difference of every numeric field of two JSON messages, merged into `largest`.
fn numeric_differences(a: &[u8], b: &[u8], largest: &mut BTreeMap<String, f64>) {
    let (Ok(a), Ok(b)) = (serde_json::from_slice(a), serde_json::from_slice(b)) else { return };
    walk(&a, &b, &mut String::new(), largest);
}

fn walk(
    a: &serde_json::Value,
    b: &serde_json::Value,
    path: &mut String,
    largest: &mut BTreeMap<String, f64>,
) {
    use serde_json::Value;
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => {
            let (Some(x), Some(y)) = (x.as_f64(), y.as_f64()) else { return };
            let d = (x - y).abs();
            if d > 0.0 && path != "seq" {
                let e = largest.entry(path.clone()).or_insert(0.0);
                *e = e.max(d);
            }
        }
        (Value::Object(x), Value::Object(y)) => {
            for (k, v) in x {
                if let Some(w) = y.get(k) {
                    let len = path.len();
                    if !path.is_empty() {
                        path.push('.');
                    }
                    path.push_str(k);
                    walk(v, w, path, largest);
                    path.truncate(len);
                }
            }
        }
        (Value::Array(x), Value::Array(y)) => {
            for (v, w) in x.iter().zip(y) {
                let len = path.len();
                path.push_str("[]");
                walk(v, w, path, largest);
                path.truncate(len);
            }
        }
        _ => {}
    }
}

/// Which behaviour drives from when (ns), from the master's `driving` pushes.
fn drives(pushes: &[Recorded], end: u64) -> Vec<(u64, Option<String>)> {
    let mut out: Vec<(u64, Option<String>)> = Vec::new();
    for p in pushes.iter().filter(|p| p.log_time < end) {
        #[derive(serde::Deserialize)]
        struct Pushed {
            value: WiringChange,
        }
        if let Ok(Pushed { value }) = serde_json::from_slice::<Pushed>(&p.data) {
            out.push((p.log_time, value.driving));
        }
    }
    out
}

/// The share of `[origin, end)` each behaviour drove.
fn share(drives: &[(u64, Option<String>)], origin: u64, end: u64) -> BTreeMap<String, f64> {
    let mut out = BTreeMap::new();
    let span = end.saturating_sub(origin);
    if span == 0 {
        return out;
    }
    for (i, (from, who)) in drives.iter().enumerate() {
        let to = drives.get(i + 1).map(|(t, _)| *t).unwrap_or(end).min(end);
        let name = who.clone().unwrap_or_else(|| "(none)".into());
        *out.entry(name).or_insert(0.0) += to.saturating_sub(*from) as f64 / span as f64;
    }
    out
}

/// Who drives at `t` (ns).
fn driver_at(drives: &[(u64, Option<String>)], t: u64) -> Option<&str> {
    let i = drives.partition_point(|(from, _)| *from <= t);
    i.checked_sub(1).and_then(|i| drives[i].1.as_deref())
}

/// The stretches in which the two sides disagree on who drives.
fn differing(
    a: &[(u64, Option<String>)],
    b: &[(u64, Option<String>)],
    origin: u64,
    end: u64,
) -> Vec<(f64, f64)> {
    let secs = |t: u64| Timestamp(t.saturating_sub(origin)).as_secs_f64();
    let mut moments: Vec<u64> = a.iter().chain(b).map(|(t, _)| *t).filter(|t| *t < end).collect();
    moments.sort_unstable();
    moments.dedup();
    let mut out = Vec::new();
    let mut since: Option<u64> = None;
    for t in moments {
        let agree = driver_at(a, t) == driver_at(b, t);
        match (since, agree) {
            (None, false) => since = Some(t),
            (Some(from), true) => {
                out.push((secs(from), secs(t)));
                since = None;
            }
            _ => {}
        }
    }
    if let Some(from) = since {
        out.push((secs(from), secs(end)));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn msg(t: u64, json: &str) -> Recorded {
        Recorded { log_time: t, data: json.as_bytes().to_vec() }
    }

    fn messages(list: &[(&str, u64, &str)]) -> Messages {
        let mut m = Messages::new();
        for (topic, t, json) in list {
            m.entry(Arc::from(*topic)).or_default().push(msg(*t, json));
        }
        m
    }

    #[test]
    fn the_first_divergence_is_the_earliest_over_all_topics() {
        let rec = messages(&[("a", 1, "1"), ("a", 5, "2"), ("b", 2, "x"), ("b", 3, "y")]);
        assert_eq!(first_divergence(&rec, &rec.clone(), 0, 10, Timing::Exact), (None, 0));
        let rep = messages(&[("a", 1, "1"), ("a", 5, "3"), ("b", 2, "x"), ("b", 3, "z")]);
        let d = first_divergence(&rec, &rep, 0, 10, Timing::Exact).0.expect("it differs");
        assert_eq!((d.topic.as_str(), d.index), ("b", 1));
        assert_eq!((d.recorded.as_deref(), d.replayed.as_deref()), (Some("y"), Some("z")));
        // A message the replay did not make is a divergence too, and so is one at the end.
        let short = messages(&[("a", 1, "1"), ("b", 2, "x"), ("b", 3, "y")]);
        let d = first_divergence(&rec, &short, 0, 10, Timing::Exact).0.expect("it differs");
        assert_eq!((d.topic.as_str(), d.index, d.replayed), ("a", 1, None));
        // Nothing at or after the end counts.
        assert_eq!(first_divergence(&rec, &short, 0, 5, Timing::Exact), (None, 0));
    }

    #[test]
    fn a_what_if_counts_differences_and_the_largest_change_per_field() {
        let rec = messages(&[
            ("v", 1, r#"{"seq":1,"value":{"v_m_s":0.2,"omega_rad_s":0.0}}"#),
            ("v", 2, r#"{"seq":2,"value":{"v_m_s":0.2,"omega_rad_s":0.1}}"#),
            ("d", 0, r#"{"seq":1,"value":{"driving":"centerfollow","mode":"patrol","stamp":0}}"#),
            ("d", 6, r#"{"seq":2,"value":{"driving":"wallfollow","mode":"patrol","stamp":6}}"#),
        ]);
        let rep = messages(&[
            ("v", 1, r#"{"seq":1,"value":{"v_m_s":0.2,"omega_rad_s":0.0}}"#),
            ("v", 2, r#"{"seq":2,"value":{"v_m_s":0.15,"omega_rad_s":0.4}}"#),
            ("d", 0, r#"{"seq":1,"value":{"driving":"centerfollow","mode":"patrol","stamp":0}}"#),
            ("d", 4, r#"{"seq":2,"value":{"driving":"wallfollow","mode":"patrol","stamp":4}}"#),
        ]);
        let w = what_if(&rec, &rep, 0, 10, "d", Timing::Exact);
        let v = &w.topics["v"];
        assert_eq!((v.recorded, v.differing, v.first_part_s), (2, 1, Some(2e-9)));
        assert!((v.largest["value.v_m_s"] - 0.05).abs() < 1e-12);
        assert!((v.largest["value.omega_rad_s"] - 0.3).abs() < 1e-12);
        assert!((w.share_recorded["wallfollow"] - 0.4).abs() < 1e-12);
        assert!((w.share_replayed["wallfollow"] - 0.6).abs() < 1e-12);
        assert_eq!(w.wiring_differs_s, vec![(Timestamp(4).as_secs_f64(), Timestamp(6).as_secs_f64())]);
        assert!(what_if(&rec, &rec.clone(), 0, 10, "d", Timing::Exact).topics.is_empty());
        // One extra message shifts every later sequence number, and is the only difference.
        let rec = messages(&[
            ("v", 1, r#"{"seq":1,"x":1}"#),
            ("v", 3, r#"{"seq":2,"x":2}"#),
            ("v", 5, r#"{"seq":3,"x":3}"#),
        ]);
        let rep = messages(&[
            ("v", 1, r#"{"seq":1,"x":1}"#),
            ("v", 2, r#"{"seq":2,"x":9}"#),
            ("v", 3, r#"{"seq":3,"x":2}"#),
            ("v", 5, r#"{"seq":4,"x":3}"#),
        ]);
        let w = what_if(&rec, &rep, 0, 10, "d", Timing::Exact);
        assert_eq!((w.topics["v"].differing, w.topics["v"].first_part_s), (1, Some(2e-9)));
    }

    #[test]
    fn a_live_recording_is_matched_in_order_and_content_with_its_times_within_the_tolerance() {
        let rec = messages(&[
            ("v", 100, r#"{"seq":1,"stamp":100,"value":{"stamp":90,"v":1}}"#),
            ("v", 205, r#"{"seq":2,"stamp":205,"value":{"stamp":190,"v":2}}"#),
            ("e", 150, r#"{"activation":1,"event":{"seq":1,"stamp":150,"value":{"x":1}}}"#),
            ("v", 995, r#"{"seq":3,"stamp":995,"value":{"stamp":990,"v":3}}"#),
        ]);
        // The replay logs each a little earlier, as it acts at the instant of the input.
        let rep = messages(&[
            ("v", 90, r#"{"seq":1,"stamp":90,"value":{"stamp":90,"v":1}}"#),
            ("v", 190, r#"{"seq":2,"stamp":190,"value":{"stamp":190,"v":2}}"#),
            ("e", 140, r#"{"activation":1,"event":{"seq":1,"stamp":140,"value":{"x":1}}}"#),
            ("v", 990, r#"{"seq":3,"stamp":990,"value":{"stamp":990,"v":3}}"#),
        ]);
        assert!(first_divergence(&rec, &rep, 0, 1000, Timing::Exact).0.is_some(), "not bit for bit");
        assert_eq!(first_divergence(&rec, &rep, 0, 1000, Timing::Within(20)), (None, 15));
        // Too late is a divergence, and so is a value that differs; a clock reading more than
        // the tolerance away is one too.
        let d = first_divergence(&rec, &rep, 0, 1000, Timing::Within(10)).0.expect("15 ns off");
        assert_eq!((d.topic.as_str(), d.index), ("v", 1));
        let other = messages(&[
            ("v", 90, r#"{"seq":1,"stamp":90,"value":{"stamp":91,"v":5}}"#),
            ("v", 190, r#"{"seq":2,"stamp":190,"value":{"stamp":190,"v":2}}"#),
            ("e", 140, r#"{"activation":1,"event":{"seq":1,"stamp":140,"value":{"x":1}}}"#),
        ]);
        let d = first_divergence(&rec, &other, 0, 1000, Timing::Within(20)).0.expect("another value");
        assert_eq!((d.topic.as_str(), d.index), ("v", 0));
        let late_reading = messages(&[
            ("v", 90, r#"{"seq":1,"stamp":90,"value":{"stamp":90,"v":1}}"#),
            ("v", 190, r#"{"seq":2,"stamp":190,"value":{"stamp":290,"v":2}}"#),
            ("e", 140, r#"{"activation":1,"event":{"seq":1,"stamp":140,"value":{"x":1}}}"#),
        ]);
        let d = first_divergence(&rec, &late_reading, 0, 1000, Timing::Within(20)).0.expect("100 ns off");
        assert_eq!((d.topic.as_str(), d.index), ("v", 1));
        // The last `tolerance` is left out; a replayed message just before the cut whose
        // recorded counterpart lies past it is no divergence, one well before it is.
        let rec = messages(&[("v", 100, r#"{"seq":1}"#), ("v", 995, r#"{"seq":2}"#)]);
        let rep = messages(&[("v", 100, r#"{"seq":1}"#), ("v", 975, r#"{"seq":2}"#)]);
        assert_eq!(first_divergence(&rec, &rep, 0, 1000, Timing::Within(20)), (None, 0));
        let extra = messages(&[("v", 100, r#"{"seq":1}"#), ("v", 500, r#"{"seq":2}"#)]);
        let rec = messages(&[("v", 100, r#"{"seq":1}"#)]);
        assert!(first_divergence(&rec, &extra, 0, 1000, Timing::Within(20)).0.is_some());
        // A message recorded just before the cut (979 < 980) and replayed just after it (985)
        // is the same message: it is found, not missing.
        let rec = messages(&[("v", 100, r#"{"seq":1}"#), ("v", 979, r#"{"seq":2}"#)]);
        let rep = messages(&[("v", 100, r#"{"seq":1}"#), ("v", 985, r#"{"seq":2}"#)]);
        assert_eq!(first_divergence(&rec, &rep, 0, 1000, Timing::Within(20)), (None, 6));
        // One replayed nowhere before the end is missing.
        let rep = messages(&[("v", 100, r#"{"seq":1}"#)]);
        let d = first_divergence(&rec, &rep, 0, 1000, Timing::Within(20)).0.expect("missing");
        assert_eq!((d.index, d.replayed), (1, None));
    }
}
