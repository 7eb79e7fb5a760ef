//! Rewriting a recording with the `mcap` crate, for tests that need a recording altered: every
//! message and metadata record copied, each channel with its schema and metadata, after `edit`
//! (topic, index of the message in its topic, bytes) and `meta` (each metadata record) had
//! their say.

use std::collections::BTreeMap;
use std::path::Path;

/// Copies the MCAP file `from` to `to` with `edit` applied to every message (topic, index on
/// its topic, data) and `meta` to the `run` metadata.
pub(crate) fn rewrite(
    from: &Path,
    to: &Path,
    mut edit: impl FnMut(&str, usize, &mut Vec<u8>),
    meta: impl Fn(&mut BTreeMap<String, String>),
) {
    let bytes = std::fs::read(from).expect("read");
    let mut out = mcap::WriteOptions::new()
        .create(std::io::BufWriter::new(std::fs::File::create(to).expect("create")))
        .expect("writer");
    for record in mcap::read::ChunkFlattener::new(&bytes).expect("mcap") {
        if let mcap::records::Record::Metadata(mut m) = record.expect("record") {
            meta(&mut m.metadata);
            out.write_metadata(&m).expect("metadata");
        }
    }
    let mut channels = BTreeMap::new();
    let mut index: BTreeMap<String, usize> = BTreeMap::new();
    for m in mcap::MessageStream::new(&bytes).expect("mcap") {
        let m = m.expect("message");
        let topic = m.channel.topic.clone();
        let id = *channels.entry(m.channel.id).or_insert_with(|| {
            let s = m.channel.schema.as_ref().expect("schema");
            let schema = out.add_schema(&s.name, &s.encoding, &s.data).expect("schema");
            out.add_channel(schema, &topic, &m.channel.message_encoding, &m.channel.metadata)
                .expect("channel")
        });
        let i = index.entry(topic.clone()).or_default();
        let mut data = m.data.into_owned();
        edit(&topic, *i, &mut data);
        *i += 1;
        let header = mcap::records::MessageHeader {
            channel_id: id,
            sequence: m.sequence,
            log_time: m.log_time,
            publish_time: m.publish_time,
        };
        out.write_to_known_channel(&header, &data).expect("message");
    }
    out.finish().expect("finish");
}
