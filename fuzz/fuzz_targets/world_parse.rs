//! `World::from_str` on any text: a checked world that writes out and reads back the same, or an
//! error that starts with the origin it was given. Never a panic.

#![no_main]

use libfuzzer_sys::fuzz_target;
use orsa_hardware::world::{World, WorldError};

const ORIGIN: &str = "fuzz.toml";

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    match World::from_str(text, ORIGIN) {
        Ok(world) => {
            assert!(world.check(ORIGIN).is_ok());
            let written = toml::to_string(&world).expect("an accepted world serialises");
            let back = World::from_str(&written, "written").expect("a written world parses");
            assert_eq!(back, world);
        }
        Err(e) => {
            let message = e.to_string();
            assert!(message.starts_with(ORIGIN), "{message}");
            if let WorldError::Syntax { at: Some(at), .. } | WorldError::Invalid { at: Some(at), .. } = e {
                assert!(at.line >= 1 && at.line <= text.matches('\n').count() + 1 && at.column >= 1, "{message}");
            }
        }
    }
});
