//! Recordings written here are read back with the `mcap` crate's own readers.

use super::*;
use serde_json::{Value, json};

#[derive(Serialize)]
struct Scan {
    distance_m: Vec<f64>,
    stamp: Timestamp,
}

#[derive(Serialize)]
struct Bumpers {
    hit: [bool; 4],
}

#[derive(Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
enum Wiring {
    Connect { port: String, to: String },
    Disconnect { port: String },
}

fn temp_path(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("orsa-record-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir.join(name)
}

fn ms(ms: u64) -> Timestamp {
    Timestamp(ms * 1_000_000)
}

/// Writes three topics of three types and metadata; returns the file's bytes and the summary.
fn write_sample(path: &Path) -> (Vec<u8>, RecordSummary) {
    let mut rec = Recorder::create(path).expect("create");
    let mut run = BTreeMap::new();
    run.insert("world".to_owned(), "Palazzina 1 corridor".to_owned());
    run.insert("seed".to_owned(), "42".to_owned());
    rec.write_metadata("run", run).expect("metadata");
    for i in 0..25u64 {
        let scan = Scan { distance_m: vec![0.5 + i as f64, 1.0, 2.25], stamp: ms(40 * i) };
        rec.write("nomad200/distanceir", "orsa.DistanceScan", ms(40 * i + 1), ms(40 * i), &scan)
            .expect("scan");
        if i % 10 == 0 {
            rec.write(
                "nomad200/bumpers",
                "orsa.Bumpers",
                ms(40 * i),
                ms(40 * i),
                &Bumpers { hit: [i == 10; 4] },
            )
            .expect("bumpers");
        }
    }
    let wirings = [
        Wiring::Connect { port: "wallfollow/vel".into(), to: "nomad200/navigationvelocity".into() },
        Wiring::Disconnect { port: "wallfollow/vel".into() },
    ];
    for (i, w) in wirings.iter().enumerate() {
        rec.write("executive/wiring", "orsa.WiringChange", ms(500 * i as u64), ms(500 * i as u64), w)
            .expect("wiring");
    }
    let summary = rec.finish().expect("finish");
    (std::fs::read(path).expect("read back"), summary)
}

#[test]
fn a_recording_reads_back_with_channels_schemas_and_messages() {
    let path = temp_path("sample.mcap");
    let (bytes, summary) = write_sample(&path);

    assert_eq!(summary.messages["nomad200/distanceir"], 25);
    assert_eq!(summary.messages["nomad200/bumpers"], 3);
    assert_eq!(summary.messages["executive/wiring"], 2);
    assert_eq!(summary.total_messages(), 30);
    assert_eq!(summary.metadata, 1);

    let index = mcap::read::Summary::read(&bytes).expect("summary").expect("has a summary");
    let stats = index.stats.as_ref().expect("statistics");
    assert_eq!(stats.message_count, 30);
    assert_eq!(stats.channel_count, 3);
    assert_eq!(stats.metadata_count, 1);
    assert!(!index.chunk_indexes.is_empty());
    assert!(index.chunk_indexes.iter().all(|c| c.compression == "zstd"), "chunks are zstd compressed");

    let mut topics: Vec<&str> = index.channels.values().map(|c| c.topic.as_str()).collect();
    topics.sort();
    assert_eq!(topics, ["executive/wiring", "nomad200/bumpers", "nomad200/distanceir"]);
    for channel in index.channels.values() {
        assert_eq!(channel.message_encoding, "json");
        let schema = channel.schema.as_ref().expect("every channel has a schema");
        assert_eq!(schema.encoding, "jsonschema");
        let doc: Value = serde_json::from_slice(&schema.data).expect("schema is JSON");
        assert_eq!(doc["title"], schema.name.as_str());
        assert_eq!(doc["type"], "object");
        match channel.topic.as_str() {
            "nomad200/distanceir" => {
                assert_eq!(schema.name, "orsa.DistanceScan");
                assert_eq!(
                    doc["properties"],
                    json!({
                        "distance_m": {"type": "array", "items": {"type": "number"}},
                        "stamp": {"type": "integer"}
                    })
                );
                assert_eq!(doc["required"], json!(["distance_m", "stamp"]));
            }
            "nomad200/bumpers" => {
                assert_eq!(doc["properties"]["hit"], json!({"type": "array", "items": {"type": "boolean"}}));
            }
            "executive/wiring" => {
                // Inferred from the first message only: a Connect.
                assert_eq!(doc["required"], json!(["kind", "port", "to"]));
                assert_eq!(doc["properties"]["kind"], json!({"type": "string"}));
            }
            other => panic!("unexpected topic {other}"),
        }
    }

    let metadata = mcap::read::metadata(&bytes, &index.metadata_indexes[0]).expect("metadata record");
    assert_eq!(metadata.name, "run");
    assert_eq!(metadata.metadata["seed"], "42");
    assert_eq!(metadata.metadata["world"], "Palazzina 1 corridor");
}

#[test]
fn messages_keep_payload_times_and_sequences() {
    let path = temp_path("messages.mcap");
    let (bytes, _) = write_sample(&path);
    let mut scans = 0u64;
    let mut wirings = Vec::new();
    for message in mcap::MessageStream::new(&bytes).expect("stream") {
        let message = message.expect("message");
        let payload: Value = serde_json::from_slice(&message.data).expect("payload is JSON");
        match message.channel.topic.as_str() {
            "nomad200/distanceir" => {
                let i = scans;
                assert_eq!(message.sequence as u64, i, "per-channel sequence numbers");
                assert_eq!(message.log_time, (40 * i + 1) * 1_000_000, "log time in nanoseconds");
                assert_eq!(message.publish_time, 40 * i * 1_000_000);
                assert_eq!(
                    payload,
                    json!({"distance_m": [0.5 + i as f64, 1.0, 2.25], "stamp": 40 * i * 1_000_000})
                );
                scans += 1;
            }
            "nomad200/bumpers" => {
                let hit = message.sequence == 1;
                assert_eq!(payload, json!({"hit": [hit, hit, hit, hit]}));
            }
            "executive/wiring" => wirings.push((message.sequence, payload)),
            other => panic!("unexpected topic {other}"),
        }
    }
    assert_eq!(scans, 25);
    assert_eq!(
        wirings,
        [
            (0, json!({"kind": "connect", "port": "wallfollow/vel", "to": "nomad200/navigationvelocity"})),
            (1, json!({"kind": "disconnect", "port": "wallfollow/vel"})),
        ]
    );
}

#[test]
fn dropping_an_unfinished_recorder_leaves_a_readable_file() {
    let path = temp_path("dropped.mcap");
    {
        let mut rec = Recorder::create(&path).expect("create");
        rec.write("a/b", "T", ms(1), ms(1), &json!({"x": 1})).expect("write");
    }
    let bytes = std::fs::read(&path).expect("read back");
    let index = mcap::read::Summary::read(&bytes).expect("summary").expect("has a summary");
    assert_eq!(index.stats.expect("statistics").message_count, 1);
}

#[test]
fn an_unwritable_path_is_an_error_naming_it() {
    let path = temp_path("no-such-dir").join("deeper").join("run.mcap");
    let error = Recorder::create(&path).expect_err("the directory does not exist");
    assert!(matches!(error, RecordError::Create { .. }));
    let text = error.to_string();
    assert!(text.contains(&path.display().to_string()), "{text}");
    assert!(text.contains("cannot create"), "{text}");
}

#[test]
fn a_message_that_is_not_json_is_an_error_naming_topic_and_file() {
    let path = temp_path("bad.mcap");
    let mut rec = Recorder::create(&path).expect("create");
    let mut bad = BTreeMap::new();
    bad.insert((1, 2), 3);
    let error = rec.write("x/y", "Bad", ms(0), ms(0), &bad).expect_err("tuple keys are not JSON");
    let text = error.to_string();
    assert!(text.contains("x/y") && text.contains(&path.display().to_string()), "{text}");
    // The recorder stays usable.
    rec.write("x/y", "Good", ms(1), ms(1), &json!({"ok": true})).expect("write");
    assert_eq!(rec.finish().expect("finish").messages["x/y"], 1);
}
