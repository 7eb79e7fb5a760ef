//! `Config::from_toml` on any text: a checked config that writes out and reads back the same, or
//! an error that starts with the origin it was given. Never a panic.

#![no_main]

use libfuzzer_sys::fuzz_target;
use orsa::config::{Config, ConfigError};

const ORIGIN: &str = "fuzz.toml";

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    match Config::from_toml(text, ORIGIN) {
        Ok(config) => {
            assert!(config.validate().is_ok());
            let written = toml::to_string(&config).expect("an accepted config serialises");
            let back = Config::from_toml(&written, "written").expect("a written config parses");
            assert_eq!(back, config);
        }
        Err(e) => {
            let message = e.to_string();
            assert!(message.starts_with(&format!("{ORIGIN}:")), "{message}");
            if let ConfigError::Parse { line, column, .. } = e {
                assert!(line >= 1 && line <= text.matches('\n').count() + 1 && column >= 1, "{message}");
            }
        }
    }
});
