//! Settings by name (`ceworld::settings`): every setting a config serialises can be set by that
//! name, so that a new setting reaches Python, checkpoints and provenance from its config alone.

use ceworld::ce::budget::Budget;
use ceworld::qlearn::Ties;
use ceworld::settings::{Given, Setting, Settings};
use ceworld::{CeConfig, ControllerConfig, Error, QConfig, WindowConfig};
use serde_json::{Value, json};

/// The setting `name` given as its JSON value (as the Python bindings would give it).
fn setting<'a>(name: &'a str, value: &Value) -> Setting<'a> {
    let given = match value {
        Value::Null => Given::Nothing,
        Value::Bool(b) => Given::Bool(*b),
        Value::Number(n) if n.is_u64() => Given::Int(i128::from(n.as_u64().unwrap())),
        Value::Number(n) if n.is_i64() => Given::Int(i128::from(n.as_i64().unwrap())),
        Value::Number(n) => Given::Real(n.as_f64().unwrap()),
        Value::String(s) => Given::Text(s.clone()),
        _ => Given::Other,
    };
    Setting { name, value: given, shown: value.to_string() }
}

/// Sets every setting of `changed` by name on a default config and checks the result is `changed`.
fn every_setting_is_set_by_its_name<S: Settings + Default + PartialEq + std::fmt::Debug>(changed: &S) {
    let Value::Object(map) = serde_json::to_value(changed).unwrap() else { panic!("not an object") };
    let mut config = S::default();
    for (name, value) in &map {
        config.set(&setting(name, value)).unwrap_or_else(|e| panic!("{name}: {e}"));
    }
    assert_eq!(&config, changed);
    assert_eq!(config.names().len(), map.len());
}

#[test]
fn every_ce_setting_is_set_by_its_name() {
    every_setting_is_set_by_its_name(&CeConfig {
        samples: 7,
        rho: 0.25,
        smoothing: 0.5,
        decision_smoothing: Some(0.125),
        patience: 3,
        max_iterations: Some(9),
        budget: Budget::seconds(2.5),
        target: Some(-1.5),
        seed: u64::MAX,
        threads: Some(2),
        eval_episodes: 11,
        memory_update: ceworld::MemoryUpdate::ForwardBackward,
        restarts: 4,
    });
    every_setting_is_set_by_its_name(&CeConfig::default());
}

#[test]
fn every_controller_setting_is_set_by_its_name() {
    every_setting_is_set_by_its_name(&ControllerConfig {
        nodes: 3,
        samples: 17,
        rho: 0.125,
        smoothing: 0.25,
        patience: 5,
        max_iterations: Some(6),
        target: Some(1.5),
        budget: Budget::seconds(8.0),
        tolerance: 1e-3,
        seed: 12,
        threads: Some(1),
        restarts: 2,
        episodes: 13,
        candidates: 2,
        select_episodes: 30,
        eval_episodes: 40,
        injection: 0.5,
        injections: 3,
        growths: 2,
        model_nodes: 9,
        template: ceworld::ce::controller::Template::Window,
        template_weight: 0.75,
        decisions: ceworld::ce::controller::Decisions::Mealy,
        memoryless_patience: 4,
        memory: ceworld::ce::controller::Memory::Registers,
        registers: 5,
        register_size: 6,
        credit: ceworld::ce::controller::Credit::Elite,
    });
    every_setting_is_set_by_its_name(&ControllerConfig::default());
}

#[test]
fn a_bad_setting_is_named() {
    let mut config = CeConfig::default();
    match config.set(&setting("sample", &Value::from(3))) {
        Err(Error::InvalidArgument { name, message }) => {
            assert_eq!(name, "setting");
            assert!(message.starts_with("\"sample\"") && message.contains("samples"), "{message}");
        }
        other => panic!("{other:?}"),
    }
    let cases = [
        ("samples", Value::from(-1), "non-negative int", true),
        ("samples", Value::from(2.0), "non-negative int", false),
        ("rho", Value::from("0.5"), "a number", false),
        ("patience", Value::Null, "non-negative int", false),
        ("memory_update", Value::from("posterior"), "forward-backward", true),
    ];
    for (name, value, expected, invalid) in cases {
        match (config.set(&setting(name, &value)), invalid) {
            (Err(Error::InvalidArgument { name: n, message }), true)
            | (Err(Error::WrongType { name: n, message }), false) => {
                assert_eq!(n, if name == "memory_update" { "memory_update" } else { name });
                assert!(message.contains(expected), "{name}: {message}");
            }
            (other, _) => panic!("{name}: {other:?}"),
        }
    }
    assert_eq!(config, CeConfig::default(), "a refused setting changes nothing");
}

#[test]
fn the_provenance_records_every_set_setting_by_name() {
    let config = CeConfig { decision_smoothing: Some(0.5), threads: Some(2), ..CeConfig::default() };
    let p = config.provenance();
    assert_eq!(p["decision_smoothing"], 0.5);
    assert!(!p.contains_key("threads") && !p.contains_key("max_iterations"));
    assert_eq!(p["samples"], 1000);
}

#[test]
fn every_q_and_window_setting_is_set_by_its_name() {
    every_setting_is_set_by_its_name(&QConfig { gamma: 0.5, alpha: 0.25, seed: u64::MAX, ties: Ties::Lowest });
    every_setting_is_set_by_its_name(&QConfig::default());
    every_setting_is_set_by_its_name(&WindowConfig {
        window: 7,
        episodes: 11,
        chains: 3,
        burn_in: u64::MAX,
        windows_per_chain: 5,
    });
    every_setting_is_set_by_its_name(&WindowConfig::default());
    assert_eq!(QConfig::default().names(), ["alpha", "gamma", "seed", "ties"]);
    assert_eq!(WindowConfig::default().names(), ["burn_in", "chains", "episodes", "window", "windows_per_chain"]);
}

#[test]
fn q_and_window_settings_are_checked_by_kind_and_name() {
    let mut q = QConfig::default();
    let set = |q: &mut QConfig, name: &str, value: Value| q.set(&setting(name, &value));
    let e = set(&mut q, "ties", json!("first")).unwrap_err().to_string();
    assert!(e.contains("ties") && e.contains("\"lowest\""), "{e}");
    assert!(matches!(set(&mut q, "ties", json!(1)), Err(Error::WrongType { .. })));
    assert!(matches!(set(&mut q, "gamma", json!("0.9")), Err(Error::WrongType { .. })));
    assert!(matches!(set(&mut q, "seed", json!(-1)), Err(Error::InvalidArgument { .. })));
    let e = set(&mut q, "epsilon", json!(0.1)).unwrap_err().to_string();
    assert!(e.contains("\"epsilon\"") && e.contains("alpha, gamma, seed, ties"), "{e}");
    assert_eq!(q, QConfig::default(), "a refused setting changes nothing");
    let mut w = WindowConfig::default();
    assert!(matches!(w.set(&setting("window", &json!(2.5))), Err(Error::WrongType { .. })));
    assert!(matches!(w.set(&setting("burn_in", &json!(true))), Err(Error::WrongType { .. })));
    let e = w.set(&setting("frames", &json!(3))).unwrap_err().to_string();
    assert!(e.contains("\"frames\"") && e.contains("burn_in, chains, episodes, window, windows_per_chain"), "{e}");
    // Settings are set one by one; their domains are `validate`'s.
    w.set(&setting("window", &json!(0))).unwrap();
    assert!(w.validate().unwrap_err().to_string().contains("window"));
    q.set(&setting("gamma", &json!(1))).unwrap();
    assert!(q.validate().unwrap_err().to_string().contains("gamma"));
}

#[test]
fn a_flag_is_a_bool_and_nothing_else() {
    let flag = |value: Given| Setting { name: "progress", value, shown: "x".into() }.flag();
    assert!(flag(Given::Bool(true)).unwrap() && !flag(Given::Bool(false)).unwrap());
    for other in [Given::Int(1), Given::Real(1.0), Given::Text("yes".into()), Given::Nothing, Given::Other] {
        let e = flag(other).unwrap_err();
        assert!(matches!(e, Error::WrongType { .. }) && e.to_string().contains("True or False"), "{e}");
    }
}
