//! A recorded run, read back with the `mcap` crate alone (as Foxglove or the mcap CLI would).
//! (Its views for Foxglove, in protobuf, are decoded by `tests/views.rs`.)

use orsa::config::Config;
use orsa::mission::{self, RunOptions};
use orsa_hardware::world::World;
use std::collections::BTreeMap;

#[tokio::test(start_paused = true)]
async fn a_recorded_run_holds_every_stream_and_every_control_event() {
    let dir = std::env::temp_dir().join(format!("orsa-rec-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join("run.mcap");
    let mut opts =
        RunOptions::new(World::palazzina().expect("world"), "palazzina", Config::default(), 5, 60.0);
    opts.record = Some(path.clone());
    let out = mission::run(opts).await.expect("run");
    let summary = out.recording.expect("a recording was made").expect("and written");

    let bytes = std::fs::read(&path).expect("read");
    let mut counts: BTreeMap<String, u64> = BTreeMap::new();
    let mut encodings = BTreeMap::new();
    for m in mcap::MessageStream::new(&bytes).expect("an MCAP file") {
        let m = m.expect("a readable message");
        *counts.entry(m.channel.topic.clone()).or_default() += 1;
        let schema = m.channel.schema.as_ref().expect("every channel has a schema");
        encodings
            .insert(m.channel.topic.clone(), (m.channel.message_encoding.clone(), schema.encoding.clone()));
        if m.channel.message_encoding == "json" {
            let v: serde_json::Value = serde_json::from_slice(&m.data).expect("JSON payload");
            assert!(v.is_object(), "{}: {v}", m.channel.topic);
        }
    }
    assert_eq!(counts, summary.messages, "the file holds what the recorder says it wrote");
    // 60 s of pushes at their periods, from the first tick on.
    assert_eq!(counts["nomad200/distanceir"], 1500);
    assert_eq!(counts["nomad200/distanceson"], 937);
    assert_eq!(counts["nomad200/basestate"], 600);
    assert_eq!(counts["nomad200/bumpers"], 2000);
    // Commands, goals and control events are there too.
    for topic in
        ["nomad200/navigationvelocity", "master/goal", "master/goal/answer", "master/goals", "master/driving"]
    {
        assert!(counts.get(topic).is_some_and(|n| *n > 0), "{topic} missing: {counts:?}");
    }
    for topic in ["wallfollow/state", "centerfollow/state", "centerfollow/wiring"] {
        assert!(counts.contains_key(topic), "control events on {topic} missing: {counts:?}");
    }
    // The views for Foxglove (topics from the root, as Foxglove names them) are protobuf, every
    // other channel JSON.
    for (topic, e) in &encodings {
        let want = if topic.starts_with('/') { ("protobuf", "protobuf") } else { ("json", "jsonschema") };
        assert_eq!((e.0.as_str(), e.1.as_str()), want, "{topic}");
    }
    assert_eq!(counts["/infrared"], counts["nomad200/distanceir"]);
    assert_eq!(counts["/sonar"], counts["nomad200/distanceson"]);
    assert_eq!(counts["/tf"], counts["nomad200/basestate"]);
    assert_eq!(counts["/driving"], counts["master/driving"]);
    std::fs::remove_dir_all(&dir).expect("clean up");
}
