//! The views' live destination: the server's channels, one per view topic, in the same
//! schemas as the recording's.

use crate::record::views::ViewSink;
use foxglove::{Context, PartialMetadata, RawChannel};
use orsa_actors::Timestamp;
use std::collections::HashMap;
use std::sync::Arc;

/// Why a view could not be served.
#[derive(Debug, thiserror::Error)]
pub enum SinkError {
    /// Its channel could not be made.
    #[error("live view: cannot make the channel of {topic}: {problem}")]
    Channel {
        /// The view's topic.
        topic: String,
        /// Why.
        problem: String,
    },
    /// The message could not be encoded.
    #[error("live view: cannot encode a message on {topic}: {problem}")]
    Encode {
        /// The view's topic.
        topic: String,
        /// Why.
        problem: String,
    },
}

/// Writes views to a live server's channels (those of `context`). A message on a channel no
/// client subscribes to is not even encoded.
pub struct LiveSink {
    context: Arc<Context>,
    channels: HashMap<String, Arc<RawChannel>>,
    buf: Vec<u8>,
    /// Messages sent to at least one client.
    pub(crate) sent: u64,
}

impl std::fmt::Debug for LiveSink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LiveSink").field("channels", &self.channels.len()).field("sent", &self.sent).finish()
    }
}

impl LiveSink {
    /// Channels made in `context`.
    pub fn new(context: Arc<Context>) -> LiveSink {
        LiveSink { context, channels: HashMap::new(), buf: Vec::with_capacity(4096), sent: 0 }
    }

    fn channel<T: foxglove::Encode>(&mut self, topic: &str) -> Result<&Arc<RawChannel>, SinkError> {
        if !self.channels.contains_key(topic) {
            let channel = self
                .context
                .channel_builder(topic)
                .schema(T::get_schema())
                .message_encoding(T::get_message_encoding())
                .build_raw()
                .map_err(|e| SinkError::Channel { topic: topic.to_owned(), problem: e.to_string() })?;
            self.channels.insert(topic.to_owned(), channel);
        }
        self.channels
            .get(topic)
            .ok_or_else(|| SinkError::Channel { topic: topic.to_owned(), problem: "it vanished".into() })
    }
}

impl ViewSink for LiveSink {
    type Error = SinkError;

    fn view<T: foxglove::Encode>(&mut self, topic: &str, at: Timestamp, msg: &T) -> Result<(), SinkError> {
        let channel = Arc::clone(self.channel::<T>(topic)?);
        if !channel.has_sinks() {
            return Ok(());
        }
        self.buf.clear();
        msg.encode(&mut self.buf)
            .map_err(|e| SinkError::Encode { topic: topic.to_owned(), problem: e.to_string() })?;
        channel.log_with_meta(&self.buf, PartialMetadata { log_time: Some(at.as_nanos()) });
        self.sent += 1;
        Ok(())
    }

    fn declare<T: foxglove::Encode>(&mut self, topic: &str) -> Result<(), SinkError> {
        self.channel::<T>(topic).map(|_| ())
    }
}
