//! The liveliness keys of the zenoh transport (`Keys::parse_service_token`,
//! `Keys::parse_process_token`) on any text, with or without the right prefix in front: what
//! parses writes back as the same key. Any text as a key prefix is refused or makes keys that
//! parse back. Never a panic.

#![no_main]

use libfuzzer_sys::fuzz_target;
use orsa_net::Keys;

fuzz_target!(|data: &[u8]| {
    let Some((&how, rest)) = data.split_first() else { return };
    let Ok(text) = std::str::from_utf8(rest) else { return };
    let keys = Keys::new("orsa").expect("a valid prefix");
    // Most inputs start at the part after the prefix, so the fuzzer works on what follows it.
    let key = match how % 3 {
        0 => format!("orsa/v1/alive/svc/{text}"),
        1 => format!("orsa/v1/alive/proc/{text}"),
        _ => text.to_string(),
    };
    if let Some(a) = keys.parse_service_token(&key) {
        assert_eq!(keys.service_token(&a.host, &a.addr, &a.info), key);
    }
    if let Some(p) = keys.parse_process_token(&key) {
        assert_eq!(keys.process_token(&p.zid, &p.role), key);
    }
    if let Ok(other) = Keys::new(text) {
        let token = other.process_token("zid", "robot");
        let p = other.parse_process_token(&token).expect("a token of a valid prefix parses");
        assert_eq!((p.zid.as_str(), p.role.as_str()), ("zid", "robot"));
    }
});
