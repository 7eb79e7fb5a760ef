//! Parsers and network decoders never panic.
//!
//! (About 870 lines, over the usual 600: one property, checked for every parser and decoder of
//! outside input, each a short generator and a short check; split by parser they would repeat
//! the harness.)
//!
//! - The config (`Config::from_toml`), world (`World::from_str`) and fault-plan
//!   (`FaultPlan::parse`) parsers are fed arbitrary text, TOML-shaped token soup, and the shipped
//!   documents (`config/orsa.toml`, `hardware/worlds/palazzina.toml`,
//!   `config/faults.example.toml`) with characters, lines and values changed. Each answers a
//!   checked value or an error whose message starts with the origin it was given (and whose line
//!   lies in the text); what the config and world parsers accept survives a round trip.
//! - The zenoh transport's decoders: liveliness keys (`Keys::parse_service_token`,
//!   `Keys::parse_process_token`) on arbitrary and mutated keys, and the control messages
//!   (`SubscribeRequest`, `ActivateRequest`, a `NetStats` reply) and the robot's communication
//!   objects on arbitrary and mutated bytes.
//!
//! Cases run with a fixed seed (so a run is repeatable); set `PROPTEST_RNG_SEED` and
//! `PROPTEST_CASES` to explore further.

use ciborium::value::Value;
use orsa::config::{Config, ConfigError, DEFAULT_CONFIG};
use orsa::faults::{FaultPlan, KINDS, PlanTargets};
use orsa::hardware::world::{PALAZZINA_TOML, World, WorldError};
use orsa::interfaces::nomad200::{DistanceReading, DistanceScan, NavigationVelocity, Ring};
use orsa_actors::addr::{PatternKind, ServiceAddr, ServiceInfo};
use orsa_actors::event::EventMode;
use orsa_actors::wire::{Reply, decode, decode_stamped, encode, encode_stamped};
use orsa_actors::{CommObject, Stamped, Timestamp};
use orsa_net::{ActivateRequest, Keys, NetStats, SubscribeRequest};
use proptest::collection::vec;
use proptest::prelude::*;
use proptest::sample::{Index, select};
use proptest::test_runner::{Config as ProptestConfig, RngSeed, TestCaseError, TestRunner};
use serde::Serialize;
use serde::de::DeserializeOwned;

/// The shipped fault plan.
const FAULTS_EXAMPLE: &str = include_str!("../config/faults.example.toml");

/// The origin every parser is given; every error must start with it.
const ORIGIN: &str = "fuzzed/input.toml";

/// A runner for `cases` cases (unless `PROPTEST_CASES` says otherwise), with a fixed seed
/// unless `PROPTEST_RNG_SEED` gives one, writing no regression files.
fn runner(cases: u32) -> TestRunner {
    let base = ProptestConfig::default();
    TestRunner::new(ProptestConfig {
        cases: if std::env::var_os("PROPTEST_CASES").is_some() { base.cases } else { cases },
        failure_persistence: None,
        rng_seed: match base.rng_seed {
            RngSeed::Random => RngSeed::Fixed(0x6f72_7361_7061_7273),
            seed => seed,
        },
        ..base
    })
}

/// Runs `test` on every input of `strategy`; a failing (or panicking) case fails the test with
/// the smallest input proptest found.
fn check<S: Strategy>(cases: u32, strategy: S, test: impl Fn(S::Value) -> Result<(), TestCaseError>)
where
    S::Value: std::fmt::Debug,
{
    if let Err(e) = runner(cases).run(&strategy, test) {
        panic!("{e}");
    }
}

// ---------------------------------------------------------------------------------------------
// Text inputs

/// Numbers that break ranges, conversions and float formatting.
const NUMBERS: &[&str] = &[
    "0",
    "-0.0",
    "-1",
    "1",
    "2",
    "15",
    "16",
    "17",
    "255",
    "256",
    "65536",
    "4294967295",
    "4294967296",
    "9223372036854775807",
    "-9223372036854775808",
    "18446744073709551615",
    "18446744073709551616",
    "1e300",
    "-1e300",
    "1.7976931348623157e308",
    "1e-300",
    "5e-324",
    "1e-9",
    "0.0000001",
    "1e19",
    "3600.5",
    "86400.5",
    "nan",
    "-nan",
    "inf",
    "+inf",
    "-inf",
    "1_000",
    "0x7fffffff",
    "0o777",
    "0b101",
    "1e999",
];

/// Values of other types a key may be given.
const VALUES: &[&str] = &[
    "\"\"",
    "\"x\"",
    "\"nomad200\"",
    "\"nomad200/navigationvelocity\"",
    "\"line_fit\"",
    "\"infrared\"",
    "\"panic\"",
    "\"delay\"",
    "\"sensor_noise\"",
    "\"link_cut\"",
    "\"motors\"",
    "\"patrol\"",
    "\"stop\"",
    "\"\\u00e9\\ud7ff\"",
    "'literal'",
    "'''\nmulti\n'''",
    "true",
    "false",
    "[]",
    "[1, 2]",
    "[[1.0, 2.0], [3.0, 4.0]]",
    "[1.0, 2.0, 3.0]",
    "[\"a\", 1]",
    "{}",
    "{ a = 1 }",
    "{ drive = \"wallfollow\" }",
    "1979-05-27T07:32:00Z",
    "1979-05-27",
    "07:32:00",
];

/// TOML's tokens, for text that is almost TOML.
const TOKENS: &[&str] = &[
    "\n",
    " ",
    "=",
    ".",
    ",",
    "[",
    "]",
    "[[",
    "]]",
    "{",
    "}",
    "\"",
    "'",
    "'''",
    "\"\"\"",
    "#",
    "\\",
    "-",
    "+",
    "\r\n",
    "\t",
    "a",
    "robot",
    "sim",
    "x",
    "y",
    "name",
    "walls",
    "points",
    "fault",
    "at",
    "kind",
    "target",
    "every",
    "until",
    "duration",
    "delay_s",
    "sigma_m",
    "executive",
    "modes",
    "rules",
    "planner",
    "mission",
    "1",
    "0.5",
    "-1",
    "nan",
    "inf",
    "1e999",
    "é",
    "\u{0}",
    "\u{feff}",
    "🤖",
];

/// One change to a document.
#[derive(Debug, Clone)]
enum Edit {
    /// Delete up to `n` characters.
    Delete(Index, u8),
    /// Insert a token.
    Insert(Index, &'static str),
    /// Insert an arbitrary character.
    InsertChar(Index, char),
    /// Replace a number literal with another.
    Number(Index, &'static str),
    /// Replace what follows the `=` of a line with a value of any type.
    Value(Index, &'static str),
    /// Duplicate a line.
    DuplicateLine(Index),
    /// Delete a line.
    DeleteLine(Index),
    /// Swap two lines.
    SwapLines(Index, Index),
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        2 => (any::<Index>(), 1u8..12).prop_map(|(i, n)| Edit::Delete(i, n)),
        2 => (any::<Index>(), select(TOKENS)).prop_map(|(i, t)| Edit::Insert(i, t)),
        1 => (any::<Index>(), any::<char>()).prop_map(|(i, c)| Edit::InsertChar(i, c)),
        5 => (any::<Index>(), select(NUMBERS)).prop_map(|(i, n)| Edit::Number(i, n)),
        3 => (any::<Index>(), select(VALUES)).prop_map(|(i, v)| Edit::Value(i, v)),
        1 => any::<Index>().prop_map(Edit::DuplicateLine),
        2 => any::<Index>().prop_map(Edit::DeleteLine),
        1 => (any::<Index>(), any::<Index>()).prop_map(|(a, b)| Edit::SwapLines(a, b)),
    ]
}

/// The byte ranges of the number literals of `text` (outside comments, roughly).
fn numbers(text: &str) -> Vec<std::ops::Range<usize>> {
    let mut out = Vec::new();
    let bytes = text.as_bytes();
    let mut i = 0;
    while i < bytes.len() {
        let starts = bytes[i].is_ascii_digit()
            && (i == 0 || matches!(bytes[i - 1], b' ' | b'=' | b'[' | b',' | b'-' | b'+' | b'\n'));
        if starts {
            let start = if i > 0 && matches!(bytes[i - 1], b'-' | b'+') { i - 1 } else { i };
            let mut end = i;
            while end < bytes.len()
                && (bytes[end].is_ascii_alphanumeric() || matches!(bytes[end], b'.' | b'_' | b'+' | b'-'))
            {
                end += 1;
            }
            out.push(start..end);
            i = end;
        } else {
            i += 1;
        }
    }
    out
}

/// The byte offset of the `i`-th character boundary (the end included).
fn boundary(text: &str, i: &Index) -> usize {
    let n = text.chars().count() + 1;
    text.char_indices().map(|(b, _)| b).chain(std::iter::once(text.len())).nth(i.index(n)).unwrap_or(0)
}

fn apply(text: &str, edits: &[Edit]) -> String {
    let mut text = text.to_string();
    for e in edits {
        match e {
            Edit::Delete(i, n) => {
                let start = boundary(&text, i);
                let end =
                    text[start..].char_indices().nth(usize::from(*n)).map_or(text.len(), |(b, _)| start + b);
                text.replace_range(start..end, "");
            }
            Edit::Insert(i, t) => text.insert_str(boundary(&text, i), t),
            Edit::InsertChar(i, c) => text.insert(boundary(&text, i), *c),
            Edit::Number(i, n) => {
                let found = numbers(&text);
                if !found.is_empty() {
                    let r = found[i.index(found.len())].clone();
                    text.replace_range(r, n);
                }
            }
            Edit::Value(i, v) => {
                let mut lines: Vec<String> = text.lines().map(String::from).collect();
                let with_value: Vec<usize> = (0..lines.len()).filter(|&n| lines[n].contains('=')).collect();
                if !with_value.is_empty() {
                    let n = with_value[i.index(with_value.len())];
                    let key = lines[n].split('=').next().unwrap_or_default().to_string();
                    lines[n] = format!("{key}= {v}");
                    text = lines.join("\n");
                }
            }
            Edit::DuplicateLine(i) | Edit::DeleteLine(i) => {
                let mut lines: Vec<&str> = text.lines().collect();
                if !lines.is_empty() {
                    let n = i.index(lines.len());
                    if matches!(e, Edit::DuplicateLine(_)) {
                        lines.insert(n, lines[n]);
                    } else {
                        lines.remove(n);
                    }
                    text = lines.join("\n");
                }
            }
            Edit::SwapLines(a, b) => {
                let mut lines: Vec<&str> = text.lines().collect();
                if !lines.is_empty() {
                    let (a, b) = (a.index(lines.len()), b.index(lines.len()));
                    lines.swap(a, b);
                    text = lines.join("\n");
                }
            }
        }
    }
    text
}

/// What a parser is fed: arbitrary text, TOML token soup, or `doc` mutated (or as it is).
fn texts(doc: &'static str) -> impl Strategy<Value = String> {
    prop_oneof![
        1 => "\\PC{0,200}",
        1 => any::<String>(),
        2 => vec(select(TOKENS), 0..48).prop_map(|t| t.concat()),
        8 => vec(edit(), 1..5).prop_map(move |e| apply(doc, &e)),
        1 => Just(doc.to_string()),
    ]
}

/// `doc` with one change each: every number literal replaced by every edge number, and the
/// value of every `key = value` line replaced by every edge number and every value of another
/// type. Systematic where the random edits are sparse.
fn every_value_replaced(doc: &str) -> Vec<String> {
    let mut out = Vec::new();
    for r in numbers(doc) {
        for n in NUMBERS {
            out.push(format!("{}{n}{}", &doc[..r.start], &doc[r.end..]));
        }
    }
    let lines: Vec<&str> = doc.lines().collect();
    for (i, line) in lines.iter().enumerate() {
        let Some((key, _)) = line.split_once('=') else { continue };
        if line.trim_start().starts_with('#') {
            continue;
        }
        for v in NUMBERS.iter().chain(VALUES) {
            let mut changed = lines.clone();
            let replaced = format!("{key}= {v}");
            changed[i] = &replaced;
            out.push(changed.join("\n"));
        }
    }
    out
}

/// Runs `check` on every text, failing with the first text it fails on.
fn on_every(texts: Vec<String>, check: impl Fn(&str) -> Result<(), TestCaseError>) {
    assert!(texts.len() > 100, "only {} texts", texts.len());
    for text in &texts {
        if let Err(e) = check(text) {
            panic!("{e}\nfor the text:\n{text}");
        }
    }
}

/// Lines a position may name in `text`: 1 to one past the last.
fn max_line(text: &str) -> usize {
    text.matches('\n').count() + 1
}

// ---------------------------------------------------------------------------------------------
// Config

fn config_parses_or_names_the_origin(text: &str) -> Result<(), TestCaseError> {
    match Config::from_toml(text, ORIGIN) {
        Ok(config) => {
            prop_assert!(config.validate().is_ok());
            // What was accepted writes out and reads back the same.
            let written = toml::to_string(&config)
                .map_err(|e| TestCaseError::fail(format!("an accepted config does not serialise: {e}")))?;
            let back = Config::from_toml(&written, "written").map_err(|e| {
                TestCaseError::fail(format!("a written config does not parse: {e}\n{written}"))
            })?;
            prop_assert_eq!(back, config);
        }
        Err(e) => {
            let message = e.to_string();
            prop_assert!(message.starts_with(&format!("{ORIGIN}:")), "{}", message);
            match e {
                ConfigError::Parse { line, column, .. } => {
                    prop_assert!((1..=max_line(text)).contains(&line) && column >= 1, "{}", message);
                    prop_assert!(message.starts_with(&format!("{ORIGIN}:{line}:{column}: ")), "{}", message);
                }
                ConfigError::Invalid { .. } => {
                    prop_assert!(message.starts_with(&format!("{ORIGIN}: ")), "{}", message);
                }
                ConfigError::Read { .. } | ConfigError::Set { .. } => {
                    prop_assert!(false, "parsing text cannot fail to read or to set: {}", message)
                }
            }
        }
    }
    Ok(())
}

#[test]
fn config_parser_answers_a_config_or_an_error_naming_the_origin() {
    check(1024, texts(DEFAULT_CONFIG), |text| config_parses_or_names_the_origin(&text));
}

#[test]
fn config_parser_takes_every_edge_value_of_every_key() {
    on_every(every_value_replaced(DEFAULT_CONFIG), config_parses_or_names_the_origin);
}

// ---------------------------------------------------------------------------------------------
// World

fn world_parses_or_names_the_origin(text: &str) -> Result<(), TestCaseError> {
    match World::from_str(text, ORIGIN) {
        Ok(world) => {
            prop_assert!(world.check(ORIGIN).is_ok());
            let written = toml::to_string(&world)
                .map_err(|e| TestCaseError::fail(format!("an accepted world does not serialise: {e}")))?;
            let back = World::from_str(&written, "written").map_err(|e| {
                TestCaseError::fail(format!("a written world does not parse: {e}\n{written}"))
            })?;
            prop_assert_eq!(back, world);
        }
        Err(e) => {
            let message = e.to_string();
            prop_assert!(message.starts_with(ORIGIN), "{}", message);
            let at = match &e {
                WorldError::Syntax { at, .. } | WorldError::Invalid { at, .. } => *at,
                WorldError::Read { .. } => {
                    return Err(TestCaseError::fail(format!("parsing text cannot fail to read: {message}")));
                }
            };
            match at {
                Some(at) => {
                    prop_assert!((1..=max_line(text)).contains(&at.line) && at.column >= 1, "{}", message);
                    prop_assert!(message.starts_with(&format!("{ORIGIN}:{at}: ")), "{}", message);
                }
                None => prop_assert!(message.starts_with(&format!("{ORIGIN}: ")), "{}", message),
            }
        }
    }
    Ok(())
}

#[test]
fn world_parser_answers_a_world_or_an_error_naming_the_origin() {
    check(1024, texts(PALAZZINA_TOML), |text| world_parses_or_names_the_origin(&text));
}

#[test]
fn world_parser_takes_every_edge_value_of_every_key() {
    on_every(every_value_replaced(PALAZZINA_TOML), world_parses_or_names_the_origin);
}

// ---------------------------------------------------------------------------------------------
// Fault plans

fn plan_parses_or_names_the_origin(text: &str, targets: &PlanTargets) -> Result<(), TestCaseError> {
    match FaultPlan::parse(text, ORIGIN, targets) {
        Ok(plan) => {
            for f in &plan.faults {
                prop_assert!(KINDS.contains(&f.kind.as_str()), "{:?}", f);
                prop_assert!(f.at_s.is_finite() && f.at_s >= 0.0, "{:?}", f);
                for v in [f.duration_s, f.every_s].into_iter().flatten() {
                    prop_assert!(v.is_finite() && v > 0.0, "{:?}", f);
                }
                if let Some(u) = f.until_s {
                    prop_assert!(u.is_finite() && u >= f.at_s, "{:?}", f);
                }
            }
        }
        Err(e) => {
            let message = e.to_string();
            prop_assert_eq!(&e.origin, ORIGIN);
            prop_assert!(message.starts_with(&format!("{ORIGIN}: ")), "{}", message);
            // Every line the message names lies in the text.
            for part in message.split("line ").skip(1) {
                let digits: String = part.chars().take_while(char::is_ascii_digit).collect();
                if let Ok(line) = digits.parse::<usize>() {
                    prop_assert!((1..=max_line(text)).contains(&line), "{}", message);
                }
            }
        }
    }
    Ok(())
}

#[test]
fn fault_plan_parser_answers_a_plan_or_an_error_naming_the_origin() {
    let targets = PlanTargets::for_stack(&Config::default());
    check(1024, texts(FAULTS_EXAMPLE), |text| plan_parses_or_names_the_origin(&text, &targets));
}

#[test]
fn fault_plan_parser_takes_every_edge_value_of_every_key() {
    let targets = PlanTargets::for_stack(&Config::default());
    on_every(every_value_replaced(FAULTS_EXAMPLE), |text| plan_parses_or_names_the_origin(text, &targets));
}

/// A fault of each family, with the target it takes.
const PLAN_KINDS: &[(&str, &str)] = &[
    ("panic", "wallfollow"),
    ("drop", "nomad200/navigationvelocity"),
    ("delay", "nomad200/distanceir"),
    ("sensor_noise", "infrared"),
    ("motor_stall", "motors"),
];

/// The numeric keys of a fault.
const PLAN_KEYS: &[&str] = &["at", "duration", "every", "until", "delay_s", "sigma_m"];

#[test]
fn fault_plan_values_at_the_edges_of_f64_are_errors_or_plans() {
    // Every kind with every numeric key at every extreme value: the edges a mutation may miss.
    let targets = PlanTargets::for_stack(&Config::default());
    check(1024, (select(PLAN_KINDS), select(PLAN_KEYS), select(NUMBERS)), |((kind, target), key, n)| {
        let mut lines = vec![
            "[[fault]]".to_string(),
            format!("kind = \"{kind}\""),
            format!("target = \"{target}\""),
            "at = 1.0".to_string(),
        ];
        if !matches!(kind, "panic") {
            lines.push("duration = 1.0".to_string());
        }
        lines.push("delay_s = 0.1".to_string());
        lines.push("sigma_m = 0.02".to_string());
        lines.retain(|l| !l.starts_with(&format!("{key} =")));
        lines.push(format!("{key} = {n}"));
        plan_parses_or_names_the_origin(&lines.join("\n"), &targets)
    });
}

// ---------------------------------------------------------------------------------------------
// Liveliness keys

fn name() -> impl Strategy<Value = String> {
    "[a-zA-Z0-9_-]{1,8}"
}

fn pattern() -> impl Strategy<Value = PatternKind> {
    select(vec![
        PatternKind::Send,
        PatternKind::Query,
        PatternKind::PushNewest,
        PatternKind::PushTimed,
        PatternKind::Event,
        PatternKind::State,
        PatternKind::Wiring,
    ])
}

fn type_id() -> impl Strategy<Value = String> {
    prop_oneof![
        Just(NavigationVelocity::ID.to_string()),
        Just(DistanceScan::ID.to_string()),
        "[a-z.]{1,8}/[0-9]",
    ]
}

/// Characters that matter to key expressions.
const KEY_TOKENS: &[&str] = &["/", "//", ",", "@", "*", "**", "$*", "?", "#", " ", "é", "orsa/v1/alive/svc/"];

/// A key, character-level: delete, insert a key token or any character.
#[derive(Debug, Clone)]
enum KeyEdit {
    Delete(Index, u8),
    Insert(Index, &'static str),
    InsertChar(Index, char),
}

fn key_edit() -> impl Strategy<Value = KeyEdit> {
    prop_oneof![
        (any::<Index>(), 1u8..6).prop_map(|(i, n)| KeyEdit::Delete(i, n)),
        (any::<Index>(), select(KEY_TOKENS)).prop_map(|(i, t)| KeyEdit::Insert(i, t)),
        (any::<Index>(), any::<char>()).prop_map(|(i, c)| KeyEdit::InsertChar(i, c)),
    ]
}

fn apply_key(key: &str, edits: &[KeyEdit]) -> String {
    let edits: Vec<Edit> = edits
        .iter()
        .map(|e| match e {
            KeyEdit::Delete(i, n) => Edit::Delete(*i, *n),
            KeyEdit::Insert(i, t) => Edit::Insert(*i, t),
            KeyEdit::InsertChar(i, c) => Edit::InsertChar(*i, *c),
        })
        .collect();
    apply(key, &edits)
}

/// The parts of a service token: host, component, service, pattern, types.
fn parts() -> impl Strategy<Value = (String, String, String, PatternKind, Vec<String>)> {
    (name(), name(), name(), pattern(), vec(type_id(), 1..3))
}

fn keys_from(prefix: &str) -> Keys {
    Keys::new(prefix).expect("a valid prefix")
}

/// Service tokens: arbitrary and mutated keys parse to an announcement that writes back as the
/// same key, or to nothing; a token made from valid parts parses back to them.
#[test]
fn service_tokens_parse_back_to_themselves_or_not_at_all() {
    let prefix = prop_oneof![Just("orsa".to_string()), Just("lab/robot-1".to_string())];
    let key = (prefix, parts(), vec(key_edit(), 0..4)).prop_map(|(prefix, (h, c, s, p, t), edits)| {
        let keys = keys_from(&prefix);
        let types: Vec<&str> = t.iter().map(String::as_str).collect();
        let token = keys.service_token(&h, &ServiceAddr::new(c, s), &ServiceInfo::new(p, &types));
        (prefix, apply_key(&token, &edits))
    });
    let arbitrary = (Just("orsa".to_string()), "\\PC{0,80}");
    check(2048, (prop_oneof![4 => key, 1 => arbitrary], parts()), |((prefix, key), (h, c, s, p, t))| {
        let keys = keys_from(&prefix);
        if let Some(a) = keys.parse_service_token(&key) {
            prop_assert_eq!(keys.service_token(&a.host, &a.addr, &a.info), key);
        }
        // Valid parts always round-trip.
        let types: Vec<&str> = t.iter().map(String::as_str).collect();
        let (addr, info) = (ServiceAddr::new(c, s), ServiceInfo::new(p, &types));
        let token = keys.service_token(&h, &addr, &info);
        let back =
            keys.parse_service_token(&token).ok_or_else(|| TestCaseError::fail("a token did not parse"))?;
        prop_assert_eq!((back.host, back.addr, back.info), (h, addr, info));
        Ok(())
    });
}

/// Process tokens likewise, and prefixes of any text are refused or make working keys.
#[test]
fn process_tokens_parse_back_to_themselves_or_not_at_all() {
    let token = (name(), name(), vec(key_edit(), 0..4))
        .prop_map(|(zid, role, edits)| apply_key(&keys_from("orsa").process_token(&zid, &role), &edits));
    let prefix = prop_oneof![Just("orsa".to_string()), "\\PC{0,12}", "[a-z/*]{0,8}"];
    check(2048, (prop_oneof![3 => token, 1 => "\\PC{0,60}"], prefix), |(key, prefix)| {
        let keys = keys_from("orsa");
        if let Some(p) = keys.parse_process_token(&key) {
            prop_assert_eq!(keys.process_token(&p.zid, &p.role), key.clone());
        }
        if let Ok(other) = Keys::new(&prefix) {
            let token = other.process_token("zid", "robot");
            let p = other.parse_process_token(&token).ok_or_else(|| TestCaseError::fail("did not parse"))?;
            prop_assert_eq!((p.zid.as_str(), p.role.as_str()), ("zid", "robot"));
            let _ = other.parse_service_token(&key);
        }
        Ok(())
    });
}

// ---------------------------------------------------------------------------------------------
// Control messages and the robot's communication objects, from bytes

/// One change to an encoding.
#[derive(Debug, Clone)]
enum ByteEdit {
    Flip(Index, u8),
    Set(Index, u8),
    Insert(Index, u8),
    Delete(Index),
    Truncate(Index),
}

fn byte_edit() -> impl Strategy<Value = ByteEdit> {
    prop_oneof![
        3 => (any::<Index>(), 0u8..8).prop_map(|(i, b)| ByteEdit::Flip(i, b)),
        3 => (any::<Index>(), any::<u8>()).prop_map(|(i, b)| ByteEdit::Set(i, b)),
        2 => (any::<Index>(), any::<u8>()).prop_map(|(i, b)| ByteEdit::Insert(i, b)),
        2 => any::<Index>().prop_map(ByteEdit::Delete),
        1 => any::<Index>().prop_map(ByteEdit::Truncate),
    ]
}

fn apply_bytes(mut bytes: Vec<u8>, edits: &[ByteEdit]) -> Vec<u8> {
    for e in edits {
        let len = bytes.len();
        match e {
            ByteEdit::Insert(i, b) => bytes.insert(i.index(len + 1), *b),
            _ if len == 0 => {}
            ByteEdit::Flip(i, bit) => bytes[i.index(len)] ^= 1 << bit,
            ByteEdit::Set(i, b) => bytes[i.index(len)] = *b,
            ByteEdit::Delete(i) => {
                bytes.remove(i.index(len));
            }
            ByteEdit::Truncate(i) => bytes.truncate(i.index(len)),
        }
    }
    bytes
}

const CBOR_KEYS: &[&str] = &[
    "op",
    "subscribe",
    "unsubscribe",
    "activate",
    "deactivate",
    "every",
    "client",
    "id",
    "mode",
    "single",
    "continuous",
    "params",
    "ok",
    "err",
    "code",
    "message",
    "detail",
    "published",
    "received",
    "decode_errors",
    "seq",
    "stamp_ns",
    "value",
    "stamp",
    "v_m_s",
    "omega_rad_s",
    "ring",
    "readings",
    "sensor_id",
    "valid",
    "distance_m",
    "sonar",
    "infrared",
];

fn cbor_key() -> impl Strategy<Value = Value> {
    select(CBOR_KEYS).prop_map(|k| Value::Text(k.to_string()))
}

/// Well-formed CBOR of any shape, often with the messages' keys.
fn cbor() -> impl Strategy<Value = Value> {
    let leaf = prop_oneof![
        any::<u64>().prop_map(|n| Value::Integer(n.into())),
        any::<i64>().prop_map(|n| Value::Integer(n.into())),
        any::<f64>().prop_map(Value::Float),
        any::<bool>().prop_map(Value::Bool),
        Just(Value::Null),
        ".{0,10}".prop_map(Value::Text),
        cbor_key(),
        vec(any::<u8>(), 0..10).prop_map(Value::Bytes),
    ];
    leaf.prop_recursive(5, 64, 6, |inner| {
        prop_oneof![
            vec(inner.clone(), 0..6).prop_map(Value::Array),
            vec((cbor_key(), inner.clone()), 0..6).prop_map(Value::Map),
            vec((inner.clone(), inner.clone()), 0..4).prop_map(Value::Map),
            (any::<u64>(), inner).prop_map(|(t, v)| Value::Tag(t, Box::new(v))),
        ]
    })
}

fn bytes_from(valid: BoxedStrategy<Vec<u8>>) -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        2 => vec(any::<u8>(), 0..96),
        2 => cbor().prop_map(|v| encode(&v)),
        5 => (valid.clone(), vec(byte_edit(), 1..6)).prop_map(|(b, e)| apply_bytes(b, &e)),
        1 => valid,
    ]
}

/// `bytes` decode as `T` or fail naming `what`; what decodes re-encodes to itself.
fn decodes_stably<T>(bytes: &[u8], what: &str) -> Result<(), TestCaseError>
where
    T: DeserializeOwned + Serialize + PartialEq + std::fmt::Debug,
{
    match decode::<T>(bytes, what) {
        Ok(v) => {
            let again = encode(&v);
            prop_assert_eq!(decode::<T>(&again, what).ok(), Some(v));
        }
        Err(e) => {
            prop_assert_eq!(&e.what, what);
            prop_assert!(e.to_string().starts_with(&format!("cannot decode {what}: ")), "{}", e);
        }
    }
    Ok(())
}

#[test]
fn subscribe_requests_decode_or_fail_naming_their_type() {
    let valid =
        prop_oneof![
            (any::<u32>(), ".{0,12}", any::<u64>())
                .prop_map(|(every, client, id)| SubscribeRequest::Subscribe { every, client, id }),
            (".{0,12}", any::<u64>()).prop_map(|(client, id)| SubscribeRequest::Unsubscribe { client, id }),
        ]
        .prop_map(|r| encode(&r))
        .boxed();
    check(1024, bytes_from(valid), |b| decodes_stably::<SubscribeRequest>(&b, "orsa.SubscribeRequest/1"));
}

#[test]
fn activate_requests_decode_or_fail_naming_their_type() {
    let mode = prop_oneof![Just(EventMode::Single), Just(EventMode::Continuous)];
    let valid = prop_oneof![
        (mode, vec(any::<u8>(), 0..24), ".{0,12}", any::<u64>())
            .prop_map(|(mode, params, client, id)| ActivateRequest::Activate { mode, params, client, id }),
        (".{0,12}", any::<u64>()).prop_map(|(client, id)| ActivateRequest::Deactivate { client, id }),
    ]
    .prop_map(|r| encode(&r))
    .boxed();
    check(1024, bytes_from(valid), |b| decodes_stably::<ActivateRequest>(&b, "orsa.ActivateRequest/1"));
}

#[test]
fn net_stats_replies_decode_or_fail_naming_their_type() {
    let valid = (any::<u64>(), any::<u64>(), any::<u64>())
        .prop_map(|(published, received, decode_errors)| {
            encode(&Reply::Ok(NetStats { published, received, decode_errors, ..NetStats::default() }))
        })
        .boxed();
    check(1024, bytes_from(valid), |b| decodes_stably::<Reply<NetStats>>(&b, "orsa.NetStats/1"));
}

/// A stamped robot communication object decodes or fails naming its type; what decodes
/// re-encodes to a fixed point.
fn stamped_decodes_stably<T: CommObject>(bytes: &[u8]) -> Result<(), TestCaseError> {
    match decode_stamped::<T>(bytes, T::ID) {
        Ok(msg) => {
            let again = encode_stamped(&msg);
            let back = decode_stamped::<T>(&again, T::ID)
                .map_err(|e| TestCaseError::fail(format!("a re-encoded {} does not decode: {e}", T::ID)))?;
            prop_assert_eq!(encode_stamped(&back), again);
        }
        Err(e) => {
            prop_assert_eq!(&e.what, T::ID);
            prop_assert!(e.to_string().starts_with(&format!("cannot decode {}: ", T::ID)), "{}", e);
        }
    }
    Ok(())
}

fn stamped<T: CommObject>(value: impl Strategy<Value = T> + 'static) -> BoxedStrategy<Vec<u8>> {
    (any::<u64>(), 0..u64::MAX / 2, value)
        .prop_map(move |(seq, stamp, value)| {
            encode_stamped(&Stamped { seq, sent_at: Timestamp(stamp), value })
        })
        .boxed()
}

#[test]
fn velocity_commands_decode_or_fail_naming_their_type() {
    let command = (0..u64::MAX / 2, any::<f64>(), any::<f64>()).prop_map(|(stamp, v_m_s, omega_rad_s)| {
        NavigationVelocity { stamp: Timestamp(stamp), v_m_s, omega_rad_s }
    });
    check(1024, bytes_from(stamped(command)), |b| stamped_decodes_stably::<NavigationVelocity>(&b));
}

#[test]
fn distance_scans_decode_or_fail_naming_their_type() {
    let reading = (any::<u8>(), 0..u64::MAX / 2, any::<bool>(), any::<f64>()).prop_map(
        |(sensor_id, stamp, valid, distance_m)| DistanceReading {
            sensor_id,
            stamp: Timestamp(stamp),
            valid,
            distance_m,
        },
    );
    let scan = (0..u64::MAX / 2, any::<bool>(), vec(reading, 0..4)).prop_map(|(stamp, sonar, readings)| {
        DistanceScan {
            stamp: Timestamp(stamp),
            ring: if sonar { Ring::Sonar } else { Ring::Infrared },
            readings,
        }
    });
    check(1024, bytes_from(stamped(scan)), |b| stamped_decodes_stably::<DistanceScan>(&b));
}
