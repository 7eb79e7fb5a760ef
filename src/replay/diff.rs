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

/// The first message, by log time, where `replayed` differs from `recorded` before `end` (ns):
/// a different log time or different bytes, or a message one side has and the other has not.
pub fn first_divergence(recorded: &Messages, replayed: &Messages, end: u64) -> Option<Divergence> {
    let mut first: Option<(u64, Divergence)> = None;
    for topic in topics(recorded, replayed) {
        let (a, b) = (window(recorded, topic, end), window(replayed, topic, end));
        let Some(i) = (0..a.len().max(b.len())).find(|&i| a.get(i) != b.get(i)) else { continue };
        let at = match (a.get(i), b.get(i)) {
            (Some(x), Some(y)) => x.log_time.min(y.log_time),
            (Some(x), None) | (None, Some(x)) => x.log_time,
            (None, None) => continue,
        };
        if first.as_ref().is_none_or(|(t, _)| at < *t) {
            let d = Divergence {
                at_s: Timestamp(at).as_secs_f64(),
                topic: topic.to_string(),
                index: i,
                recorded: a.get(i).map(text),
                replayed: b.get(i).map(text),
            };
            first = Some((at, d));
        }
    }
    first.map(|(_, d)| d)
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

/// Compares a what-if replay with its recording before `end` (ns); `driving` is the topic of
/// the master's `driving` pushes (the behaviour share comes from them).
pub fn what_if(recorded: &Messages, replayed: &Messages, end: u64, driving: &str) -> WhatIf {
    let mut out = WhatIf::default();
    for topic in topics(recorded, replayed) {
        out.compared_topics += 1;
        let (a, b) = (window(recorded, topic, end), window(replayed, topic, end));
        let mut d = TopicDiff { recorded: a.len(), replayed: b.len(), ..TopicDiff::default() };
        for (x, y) in paired(a, b) {
            if let (Some(x), Some(y)) = (x, y)
                && same_but_sequence(x, y)
            {
                continue;
            }
            d.differing += 1;
            if d.first_part_s.is_none() {
                let at = x.into_iter().chain(y).map(|r| r.log_time).min().unwrap_or(0);
                d.first_part_s = Some(Timestamp(at).as_secs_f64());
            }
            if let (Some(x), Some(y)) = (x, y) {
                numeric_differences(&x.data, &y.data, &mut d.largest);
            }
        }
        if d.differing > 0 {
            out.topics.insert(topic.to_string(), d);
        }
    }
    let (ra, rb) = (drives(window(recorded, driving, end), end), drives(window(replayed, driving, end), end));
    out.share_recorded = share(&ra, end);
    out.share_replayed = share(&rb, end);
    out.wiring_differs_s = differing(&ra, &rb, end);
    out
}

/// The messages of both sides paired by log time: those of one instant in order, and a
/// message the other side has no counterpart for at that instant alone. (Pairing by index
/// would let one extra message make every later one look different.)
fn paired<'a>(a: &'a [Recorded], b: &'a [Recorded]) -> Vec<(Option<&'a Recorded>, Option<&'a Recorded>)> {
    let (mut i, mut j, mut out) = (0, 0, Vec::with_capacity(a.len().max(b.len())));
    while i < a.len() || j < b.len() {
        match (a.get(i), b.get(j)) {
            (Some(x), Some(y)) if x.log_time == y.log_time => {
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

/// Whether two messages are the same but for their sequence number (which a what-if shifts
/// once one message more or less was sent).
fn same_but_sequence(x: &Recorded, y: &Recorded) -> bool {
    if x.data == y.data {
        return true;
    }
    let parse = |r: &Recorded| serde_json::from_slice::<serde_json::Value>(&r.data).ok();
    match (parse(x), parse(y)) {
        (Some(serde_json::Value::Object(mut p)), Some(serde_json::Value::Object(mut q))) => {
            p.remove("seq");
            q.remove("seq");
            p == q
        }
        _ => false,
    }
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

/// The share of `[0, end)` each behaviour drove.
fn share(drives: &[(u64, Option<String>)], end: u64) -> BTreeMap<String, f64> {
    let mut out = BTreeMap::new();
    if end == 0 {
        return out;
    }
    for (i, (from, who)) in drives.iter().enumerate() {
        let to = drives.get(i + 1).map(|(t, _)| *t).unwrap_or(end).min(end);
        let name = who.clone().unwrap_or_else(|| "(none)".into());
        *out.entry(name).or_insert(0.0) += to.saturating_sub(*from) as f64 / end as f64;
    }
    out
}

/// Who drives at `t` (ns).
fn driver_at(drives: &[(u64, Option<String>)], t: u64) -> Option<&str> {
    let i = drives.partition_point(|(from, _)| *from <= t);
    i.checked_sub(1).and_then(|i| drives[i].1.as_deref())
}

/// The stretches in which the two sides disagree on who drives.
fn differing(a: &[(u64, Option<String>)], b: &[(u64, Option<String>)], end: u64) -> Vec<(f64, f64)> {
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
                out.push((Timestamp(from).as_secs_f64(), Timestamp(t).as_secs_f64()));
                since = None;
            }
            _ => {}
        }
    }
    if let Some(from) = since {
        out.push((Timestamp(from).as_secs_f64(), Timestamp(end).as_secs_f64()));
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
        assert_eq!(first_divergence(&rec, &rec.clone(), 10), None);
        let rep = messages(&[("a", 1, "1"), ("a", 5, "3"), ("b", 2, "x"), ("b", 3, "z")]);
        let d = first_divergence(&rec, &rep, 10).expect("it differs");
        assert_eq!((d.topic.as_str(), d.index), ("b", 1));
        assert_eq!((d.recorded.as_deref(), d.replayed.as_deref()), (Some("y"), Some("z")));
        // A message the replay did not make is a divergence too, and so is one at the end.
        let short = messages(&[("a", 1, "1"), ("b", 2, "x"), ("b", 3, "y")]);
        let d = first_divergence(&rec, &short, 10).expect("it differs");
        assert_eq!((d.topic.as_str(), d.index, d.replayed), ("a", 1, None));
        // Nothing at or after the end counts.
        assert_eq!(first_divergence(&rec, &short, 5), None);
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
        let w = what_if(&rec, &rep, 10, "d");
        let v = &w.topics["v"];
        assert_eq!((v.recorded, v.differing, v.first_part_s), (2, 1, Some(2e-9)));
        assert!((v.largest["value.v_m_s"] - 0.05).abs() < 1e-12);
        assert!((v.largest["value.omega_rad_s"] - 0.3).abs() < 1e-12);
        assert!((w.share_recorded["wallfollow"] - 0.4).abs() < 1e-12);
        assert!((w.share_replayed["wallfollow"] - 0.6).abs() < 1e-12);
        assert_eq!(w.wiring_differs_s, vec![(Timestamp(4).as_secs_f64(), Timestamp(6).as_secs_f64())]);
        assert!(what_if(&rec, &rec.clone(), 10, "d").topics.is_empty());
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
        let w = what_if(&rec, &rep, 10, "d");
        assert_eq!((w.topics["v"].differing, w.topics["v"].first_part_s), (1, Some(2e-9)));
    }
}
